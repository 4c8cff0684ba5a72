"""Held-out run energy on real free-driving logs: the plain least squares and the drive model.

Issue 25, step 7 (docs/real-logs.md, "Free driving"). For each converted set (the
converters in benchmarks/real_logs/ write them to `$WBPOWER_REAL_DRIVE`, default
/work/real_drive; the F1/10 log is found as its tests find it), every log is read here
with numpy (not with wbpower's reader, which refuses some of them today: docs), cut into
**trips** and each trip's energy is predicted by models fitted on the other trips
(K-fold by trip), so no trip is ever predicted by a fit that saw it.

- **Reading**: power = `power_W`, else the sum of each `voltage_*_V` x `current_*_A`
  pair; speed = `speed_mps`; yaw rate [rad/s] = (`speed_right_mps` - `speed_left_mps`) /
  `track_m` where the log has both wheel speeds (log-format.md, "Turning"), else
  `yaw_rate_radps`, else none; the surface from the `surface` metadata or a per-sample
  `surface` column.
- **Energy**: each sample's power held until the next stamp, E = sum P_i (t_(i+1) - t_i)
  (the stamps as logged: the phone apps' bursty rows are not evened out).
- **Trips**: a log is cut at every **stop**: |speed| < `STOP_SPEED_MPS` and, where the
  log has a yaw rate, |yaw rate| < `STOP_YAW_RADPS` (a robot spinning in place is not
  stopped), lasting at least `STOP_S`. A trip runs from the end of one stop to the start of
  the next (the stops' standing samples belong to no trip), and is cut at any step between
  stamps over `GAP_S` (time the log does not cover: a paused app, a ride the next day);
  trips shorter than `MIN_TRIP_S` are dropped. A trip of a log with a per-sample surface
  takes the surface that holds >= 80% of its time, else it is `mixed`. A trip whose
  samples are those of a trip already taken (one source log holding another whole:
  EUC_core's mten4/2 repeats mten4/0) is dropped and counted, so that no trip is held out
  against its own copy.
- **Groups**: the surface where the logs name one; for the unicycles the wheel
  (`vehicle`: each is a different vehicle), surface unknown; else the whole set.
- **Baseline (a)**, the plain least squares of issue 25: power on an intercept, |v|, v^2
  and max(a*v, 0) (speeding up; braking gets no term), by least squares weighted by each
  sample's held time; `a` is the speed's central difference over `ACCEL_WINDOW_S`
  (interpolated, so a 6.5 Hz robot and a bursty app are treated alike). Fitted per group
  ("per surface") and on every group of the set together ("pooled", then scored per
  group). Where the set has a yaw rate, also with |yaw rate| as a fifth column ("+|yaw|":
  the naive turning term).
- **Drive model (b)**: `wifibot_power.drive.fit_drive` when it can be imported (the drive
  lane writes it); until then the line says "drive model not available yet".
- **Folds**: K = min(5, trips) folds of a group's trips, dealt by a seeded permutation
  (seed 0): the same folds for every model ("Same folds": the drive model identified on the
  plain least squares' folds, `heldout_drive`; its own rows use `fit_drive`'s 10 folds).
- **The floor** ("Repeated commands", `repeat_rows`): trips of a surface whose mean |speed|
  and |yaw rate| round alike repeat one command; each one's mean power predicted by the
  others' is the best any model of those inputs can do.
- **The sides of an arc** (`sides_rows`): the two sides' currents of a skid-steer log
  straight, spinning and on arcs: what the force form's arc rule rests on (drive/windows.py
  `_force_form`). **Slopes** (`grade_rows`): the potential energy of each trip's climb over
  its energy, where the log has a GPS altitude and a mass.

Columns: trips (`n`), of which `E<=0` have a net energy <= 0 (unicycles walked or pushed
at ~0.5 m/s, reading 0 W or a small negative power: left out of the percentages, still in
the fits), MAPE and median of |predicted - measured|
/ measured over the held-out trips [%], wAPE = sum |predicted - measured| / sum measured
[%] (the error on the total energy, weighted as a battery sees it), and the 90% interval
coverage [%] where the model gives intervals ("-": the baseline gives none). numpy only;
runs in well under a minute.

    .venv/bin/python benchmarks/validate_drive_real.py               # the tables
    .venv/bin/python benchmarks/validate_drive_real.py --write-docs  # into docs/real-logs.md
"""

from __future__ import annotations

import argparse
import gzip
import io
import re
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "real_logs"))
from canonical_out import real_drive_root  # noqa: E402  (the converters' shared module)

#: below this |speed| [m/s] (0.36 km/h) a sample may be standing
STOP_SPEED_MPS = 0.1
#: below this |yaw rate| [rad/s] (3 deg/s) a sample may be standing
STOP_YAW_RADPS = 0.05
#: a stop lasts at least this long [s] to cut a log there
STOP_S = 3.0
#: a step between stamps longer than this [s] is time the log does not cover (an app paused,
#: a ride the next day): trips are cut there too and never integrate across it
GAP_S = 5.0
#: trips shorter than this [s] are dropped
MIN_TRIP_S = 10.0
#: the speed's central difference spans this window [s]
ACCEL_WINDOW_S = 1.0
#: folds of K-fold by trip (fewer when a group has fewer trips)
FOLDS = 5
#: a group needs this many trips to be scored
MIN_TRIPS = 3
#: a per-sample surface holding this share of a trip's time names the trip's surface
SURFACE_SHARE = 0.8
SEED = 0

DOCS = HERE.parent / "docs" / "real-logs.md"
BEGIN, END = "<!-- drive validation: begin -->", "<!-- drive validation: end -->"


@dataclass(frozen=True)
class Trip:
    run_id: str
    group: str
    time_s: np.ndarray
    power_W: np.ndarray
    speed_mps: np.ndarray
    yaw_radps: np.ndarray | None
    #: the log's `voltage_assumed_V` metadata: its power is a current proxy (drive/stats.py)
    voltage_assumed: str | None = None
    #: the log's `track_m` metadata [m] (its wheels' track: the turning radius over it)
    track_m: str | None = None

    @property
    def held_s(self) -> np.ndarray:
        """Each sample's held time [s] (the last sample: the median step)."""
        step = np.diff(self.time_s)
        return np.append(step, np.median(step) if step.size else 0.0)

    @property
    def energy_J(self) -> float:
        return float(np.sum(self.power_W * self.held_s))


def read_log(path: Path) -> tuple[dict[str, str], dict[str, np.ndarray]]:
    """A canonical wbpower CSV(.gz): its `#` metadata and its columns (floats; `surface` as
    strings)."""
    raw = gzip.open(path, "rt") if path.suffix == ".gz" else open(path)
    with raw as f:
        text = f.read()
    lines = text.splitlines()
    meta = {}
    k = 0
    while lines[k].startswith("#"):
        key, _, value = lines[k][1:].partition(":")
        meta[key.strip()] = value.strip()
        k += 1
    names = lines[k].split(",")
    body = "\n".join(lines[k + 1 :])
    numeric = [i for i, n in enumerate(names) if n != "surface"]
    table = np.genfromtxt(io.StringIO(body), delimiter=",", usecols=numeric, ndmin=2)
    cols = {names[i]: table[:, j] for j, i in enumerate(numeric)}
    if "surface" in names:
        s = names.index("surface")
        cols["surface"] = np.array([row.split(",")[s] for row in lines[k + 1 :]])
    return meta, cols


def power_of(cols: dict[str, np.ndarray]) -> np.ndarray:
    """power_W, else the sum over voltage_*_V x current_*_A pairs (log-format.md §1)."""
    if "power_W" in cols:
        return cols["power_W"]
    total = None
    for name in cols:
        m = re.fullmatch(r"voltage(_\w+)?_V", name)
        if m and f"current{m.group(1) or ''}_A" in cols:
            p = cols[name] * cols[f"current{m.group(1) or ''}_A"]
            total = p if total is None else total + p
    if total is None:
        raise SystemExit(f"no power or voltage/current columns in {sorted(cols)}")
    return total


def yaw_of(meta: dict[str, str], cols: dict[str, np.ndarray]) -> np.ndarray | None:
    if "speed_left_mps" in cols and "speed_right_mps" in cols and "track_m" in meta:
        return (cols["speed_right_mps"] - cols["speed_left_mps"]) / float(meta["track_m"])
    return cols.get("yaw_rate_radps")


def moving_stretches(
    time_s: np.ndarray, speed: np.ndarray, yaw: np.ndarray | None
) -> list[tuple[int, int]]:
    """[start, end) index ranges between stops (see the docstring), at least MIN_TRIP_S."""
    still = np.abs(speed) < STOP_SPEED_MPS
    if yaw is not None:
        still &= np.abs(yaw) < STOP_YAW_RADPS
    # runs of equal `still`: their bounds
    edges = np.flatnonzero(np.diff(still.astype(np.int8))) + 1
    starts = np.concatenate([[0], edges])
    ends = np.concatenate([edges, [still.size]])
    end_time = np.append(time_s[1:], time_s[-1] + np.median(np.diff(time_s)))
    long_stop = still[starts] & (end_time[ends - 1] - time_s[starts] >= STOP_S)
    # cut points: the long stops; the trips lie between them
    cuts = [(a, b) for a, b, s in zip(starts, ends, long_stop, strict=True) if s]
    bounds, prev = [], 0
    for a, b in cuts:
        bounds.append((prev, a))
        prev = b
    bounds.append((prev, still.size))
    # and at every gap in the stamps: [a, b) holds no step over GAP_S
    gaps = np.flatnonzero(np.diff(time_s) > GAP_S) + 1
    bounds = [
        piece
        for a, b in bounds
        for piece in zip(
            [a, *gaps[(gaps > a) & (gaps < b)]], [*gaps[(gaps > a) & (gaps < b)], b], strict=True
        )
    ]
    return [(a, b) for a, b in bounds if b - a >= 2 and end_time[b - 1] - time_s[a] >= MIN_TRIP_S]


def trips_of(path: Path, set_name: str) -> list[Trip]:
    meta, cols = read_log(path)
    t, p, v = cols["time_s"], power_of(cols), cols["speed_mps"]
    yaw = yaw_of(meta, cols)
    fine = np.isfinite(p) & np.isfinite(v) & np.isfinite(t)
    if yaw is not None:
        fine &= np.isfinite(yaw)
    if not fine.all():
        raise SystemExit(f"{path}: {np.count_nonzero(~fine)} sample(s) without a number")
    group = meta.get("surface") or meta.get("vehicle") or set_name
    out = []
    for k, (a, b) in enumerate(moving_stretches(t, v, yaw)):
        g = group
        if "surface" in cols:
            held = np.diff(t[a : b + 1]) if b < t.size else np.append(np.diff(t[a:b]), 0)
            labels, inverse = np.unique(cols["surface"][a:b], return_inverse=True)
            share = np.bincount(inverse, weights=held[: b - a]) / max(np.sum(held), 1e-12)
            g = labels[np.argmax(share)] if share.max() >= SURFACE_SHARE else "mixed"
            g = g or "unlabelled"
        out.append(
            Trip(
                f"{meta.get('run_id', path.stem)}#{k}",
                g,
                t[a:b],
                p[a:b],
                v[a:b],
                None if yaw is None else yaw[a:b],
                meta.get("voltage_assumed_V"),
                meta.get("track_m"),
            )
        )
    return out


def design(trip: Trip, with_yaw: bool) -> np.ndarray:
    """Regressors of the plain least squares: 1, |v|, v^2, max(a v, 0) (and |yaw|)."""
    t, v = trip.time_s, trip.speed_mps
    half = ACCEL_WINDOW_S / 2
    a = (np.interp(t + half, t, v) - np.interp(t - half, t, v)) / ACCEL_WINDOW_S
    cols = [np.ones_like(v), np.abs(v), v * v, np.maximum(a * v, 0.0)]
    if with_yaw:
        cols.append(np.abs(trip.yaw_radps))
    return np.column_stack(cols)


def fit_ls(trips: list[Trip], with_yaw: bool) -> np.ndarray:
    """Coefficients minimising sum held_s (P - X b)^2 over the trips' samples."""
    x = np.vstack([design(tr, with_yaw) for tr in trips])
    y = np.concatenate([tr.power_W for tr in trips])
    w = np.sqrt(np.concatenate([tr.held_s for tr in trips]))
    coef, *_ = np.linalg.lstsq(x * w[:, None], y * w, rcond=None)
    return coef


def predict_ls(coef: np.ndarray, trip: Trip, with_yaw: bool) -> float:
    return float(np.sum((design(trip, with_yaw) @ coef) * trip.held_s))


def folds_of(n: int) -> np.ndarray:
    """The fold of each of n trips: a seeded deal into min(FOLDS, n) folds."""
    k = min(FOLDS, n)
    order = np.random.default_rng(SEED).permutation(n)
    fold = np.empty(n, dtype=int)
    fold[order] = np.arange(n) % k
    return fold


def heldout_ls(trips: list[Trip], with_yaw: bool) -> np.ndarray:
    """Each trip's predicted energy from a fit on the other folds [J]."""
    fold = folds_of(len(trips))
    pred = np.empty(len(trips))
    for f in np.unique(fold):
        coef = fit_ls([tr for tr, g in zip(trips, fold, strict=True) if g != f], with_yaw)
        for i in np.flatnonzero(fold == f):
            pred[i] = predict_ls(coef, trips[i], with_yaw)
    return pred


def scores(measured: np.ndarray, predicted: np.ndarray) -> tuple[float, float, float]:
    """MAPE, median APE and the energy-weighted error sum|P - M| / sum M [%] over the trips
    whose measured energy is positive (a relative error of a net energy <= 0 means nothing;
    those trips are counted apart)."""
    ok = measured > 0
    if not ok.any():
        return (np.nan, np.nan, np.nan)
    m, p = measured[ok], predicted[ok]
    ape = np.abs(p - m) / m * 100
    return (
        float(np.mean(ape)),
        float(np.median(ape)),
        float(np.sum(np.abs(p - m)) / np.sum(m) * 100),
    )


def as_run(trip: Trip):
    """The trip as a wbpower `Run` (the fields the drive model reads: stamps, power, speed,
    and the yaw rate and surface where this version of `Run` has those fields)."""
    from dataclasses import fields

    from wifibot_power.run import Run, RunMeta

    step = float(np.median(np.diff(trip.time_s)))
    extra_meta = {"surface": trip.group}
    if trip.voltage_assumed is not None:
        extra_meta["voltage_assumed_V"] = trip.voltage_assumed
    if trip.track_m is not None:
        extra_meta["track_m"] = trip.track_m
    meta = RunMeta(run_id=trip.run_id, mode="motion", sample_period_s=step, extra=extra_meta)
    extra = {}
    if "yaw_rate_radps" in {f.name for f in fields(Run)} and trip.yaw_radps is not None:
        extra["yaw_rate_radps"] = trip.yaw_radps
    return Run(
        file=trip.run_id,
        format="wbpower-csv",
        meta=meta,
        stamps_s=trip.time_s - trip.time_s[0],
        power_W=trip.power_W,
        speed_mps=trip.speed_mps,
        **extra,
    )


def heldout_drive(trips: list[Trip]) -> tuple[np.ndarray, np.ndarray]:
    """Each trip's measured and predicted energy [J] over its windows, the drive model
    identified (lag, determined terms, coefficients: `fit_drive`'s steps, without its own
    held-out loop) on the other folds of `folds_of`: the plain least squares' folds, so the
    two are compared on the same partition. NaN where a trip has no window."""
    from wifibot_power.drive.identify import identify, lag_search
    from wifibot_power.drive.stats import drive_stats
    from wifibot_power.drive.windows import assemble, run_windows

    runs = [run_windows(drive_stats(as_run(tr))) for tr in trips]
    surfaces = tuple(sorted({s for rw in runs for s in rw.stats.surfaces}))
    fold = folds_of(len(trips))
    measured, predicted = np.full(len(trips), np.nan), np.full(len(trips), np.nan)
    for f in np.unique(fold):
        train = [rw for rw, g in zip(runs, fold, strict=True) if g != f and rw.count]
        lag_bins, _ = lag_search(train, surfaces)
        windows = assemble(train, lag_bins, surfaces)
        clusters = windows.run if len(train) >= 10 else windows.trip
        model = identify(windows, lag_bins, clusters)
        for i in np.flatnonzero(fold == f):
            if not runs[i].count or not model.kept.any():
                continue  # no window, or no term determined (e.g. a bursty phone app's
                # stamps: every window holds a drop-out): no prediction
            held = assemble([runs[i]], lag_bins, surfaces)
            measured[i] = float(np.sum(held.power_W)) * held.window_s
            predicted[i] = float(np.sum(model.predict_W(held.design))) * held.window_s
    return measured, predicted


def drive_model_rows(trips: list[Trip], by_vehicle: bool) -> list[str] | None:
    """The drive model's held-out rows (group, n, E<=0, MAPE, median, wAPE, cover90), or None
    when `wifibot_power.drive.fit_drive` cannot be imported yet. Each trip is given to it as
    a run (so its held-out units are these trips, as the baseline's are); its folds and any
    further cutting are its own (K-fold by trip, seed 0). Surfaces are its own per-surface
    terms: one fit per set; a set of different vehicles (the unicycles) gets one fit per
    vehicle, as the baseline's "per group" does."""
    try:
        from wifibot_power.drive import fit_drive
    except ImportError:
        return None
    fits = (
        [[tr for tr in trips if tr.group == g] for g in sorted({tr.group for tr in trips})]
        if by_vehicle
        else [trips]
    )
    held = []
    for members in fits:
        model = fit_drive([as_run(tr) for tr in members])
        if model is None or model.heldout is None:
            continue
        group_of = {tr.run_id: tr.group for tr in members}
        held += [(group_of.get(r.run_id, r.surface), r) for r in model.heldout.runs]
    if not held:
        return [f"| all | 0 | - | no held-out accuracy from the drive model ({len(trips)} trips) |"]
    rows = []
    for g in [*sorted({g for g, _ in held}), "all"]:
        mine = [r for h, r in held if g in ("all", h)]
        m = np.array([r.measured_J for r in mine])
        p = np.array([r.predicted_J for r in mine])
        lo = np.array([r.pi90_J[0] for r in mine])
        hi = np.array([r.pi90_J[1] for r in mine])
        cover = float(np.mean((m >= lo) & (m <= hi)) * 100)
        cells = " | ".join(fmt(c) for c in (*scores(m, p), cover))
        rows.append(f"| {g} | {len(mine)} | {int(np.count_nonzero(m <= 0))} | {cells} |")
    return rows


def same_folds_rows(trips: list[Trip], groups: list[str], ls_per_group: np.ndarray) -> list[str]:
    """The plain least squares and the drive model, each fitted per group on the same folds
    (`folds_of`), side by side: each one's errors over its own measure of a trip's energy
    (the samples' for the least squares, the windows' for the drive model)."""
    rows = []
    pooled: dict[str, list[np.ndarray]] = {"m": [], "d": [], "lm": [], "lp": []}
    for g in groups:
        idx = [i for i, tr in enumerate(trips) if tr.group == g]
        if len(idx) < MIN_TRIPS:
            continue
        measured, predicted = heldout_drive([trips[i] for i in idx])
        ls_measured = np.array([trips[i].energy_J for i in idx])
        ls_predicted = ls_per_group[idx]
        pooled["m"].append(measured)
        pooled["d"].append(predicted)
        pooled["lm"].append(ls_measured)
        pooled["lp"].append(ls_predicted)
        rows.append((g, len(idx), ls_measured, ls_predicted, measured, predicted))
    if not rows:
        return []
    join = {k: np.concatenate(v) for k, v in pooled.items()}
    rows.append(("all", join["m"].size, join["lm"], join["lp"], join["m"], join["d"]))
    out = [
        "\nSame folds, fitted per group (the plain least squares beside the drive model; "
        "MAPE / median / wAPE [%]; the drive model's n: trips it predicts, with a window "
        "and a term determined):\n",
        "| group | n | LS: MAPE | median | wAPE | drive: n | MAPE | median | wAPE |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for g, n, lm, lp, m, d in rows:
        known = np.isfinite(m) & np.isfinite(d) & (m > 0)
        cells = [*scores(lm, lp), int(known.sum()), *scores(m[known], d[known])]
        text = " | ".join(str(c) if isinstance(c, int) else fmt(c) for c in cells)
        out.append(f"| {g} | {n} | {text} |")
    return out


def _meta_of(path: Path) -> dict[str, str]:
    """A converted file's `#` metadata alone (the lines before its header)."""
    meta = {}
    with gzip.open(path, "rt") as fh:
        for line in fh:
            if not line.startswith("#"):
                break
            key, _, value = line[1:].partition(":")
            meta[key.strip()] = value.strip()
    return meta


def sets() -> dict[str, list[Path]]:
    """Every converted set: the free-driving folder's sets and the F1/10 log."""
    found = {}
    root = real_drive_root()
    for folder in sorted(p for p in root.glob("*") if p.is_dir()):
        files = without_pieces(sorted(folder.rglob("*.csv.gz")))
        if files:
            found[folder.name] = files
    sys.path.insert(0, str(HERE / "real_logs"))
    import convert_f1tenth  # noqa: PLC0415  (a module beside the converters)

    f1 = convert_f1tenth.locate(HERE.parent / ".cache" / "real_logs" / "f1tenth")
    if f1 is not None:  # the three sides of the logger's gaps (the whole log has them)
        found["f1tenth"] = [f1 / n for n in ("ds5_a.csv.gz", "ds5_b.csv.gz", "ds5_c.csv.gz")]
    return found


def without_pieces(files: list[Path]) -> list[Path]:
    """`files` less each that is a piece of another (wbpower's rule, pipeline/pieces.py: as
    `fit` leaves them out): BorealTC's snow run pro_12 is the first 183 rows of pro_13, and a
    trip in both would sit in a fit and its held-out fold at once. Said on stderr."""
    from wifibot_power.errors import WbpowerError  # noqa: PLC0415
    from wifibot_power.io import read_log as read_run  # noqa: PLC0415
    from wifibot_power.pipeline.pieces import overlaps, piece_signature  # noqa: PLC0415

    def signature(path: Path) -> str | None:
        try:
            return piece_signature(read_run(path)).encode()
        except WbpowerError:  # a log wbpower refuses (several sessions in one): kept here
            return None

    signatures = [signature(path) for path in files]
    pieces = {o.this: o.other for o in overlaps(signatures) if o.is_piece}
    for this, other in sorted(pieces.items()):
        print(f"left out: {files[this]} is a piece of {files[other]}", file=sys.stderr)
    return [path for k, path in enumerate(files) if k not in pieces]


#: a Husky motor's current standing still [A] (convert_borealtc.py): a side at or under it
#: is not driving
STANDSTILL_A = 0.6
#: a sample turns (for the sides' table) above this rate of turn [rad/s]; a side moves above
#: this wheel speed [m/s]
ARC_YAW_RADPS = 0.15
SIDE_MOVING_MPS = 0.05
#: trips repeat one command when their mean |speed| and |yaw rate| round to the same
#: multiple of this [m/s, rad/s] on one surface
COMMAND_STEP = 0.05


def sides_rows(files: list[Path]) -> list[str]:
    """The sides of a skid-steer robot's turns (drive/windows.py `_force_form`): per surface
    and kind of motion (straight, spinning in place, an arc: both sides forward, turning over
    `ARC_YAW_RADPS`), the samples, the share where the slower ("inner") side's current is at
    most the standstill current, its median and the other side's [A]. Logs without two
    sides' currents and speeds: none."""
    rows = []
    tally = sides_currents(files)
    for (surface, kind), both_sides in sorted(tally.items(), key=lambda x: (x[0][1], x[0][0])):
        if both_sides.shape[0] < 10:
            continue
        inner, outer = both_sides[:, 0], both_sides[:, 1]
        share = float(np.mean(inner <= STANDSTILL_A) * 100)
        rows.append(
            f"| {kind} | {surface} | {inner.size} | {share:.0f} | {np.median(inner):.1f} "
            f"| {np.median(outer):.1f} |"
        )
    return rows


def sides_currents(files: list[Path]) -> dict[tuple[str, str], np.ndarray]:
    """Per (surface, kind of motion): the slower and the faster side's current of every such
    sample [A] (a row each; `sides_rows`); empty for logs without both sides."""
    tally: dict[tuple[str, str], list[np.ndarray]] = {}
    for path in files:
        meta, cols = read_log(path)
        need = ("current_left_A", "current_right_A", "speed_left_mps", "speed_right_mps")
        if not all(n in cols for n in need) or "track_m" not in meta:
            return {}
        i_l, i_r = cols["current_left_A"], cols["current_right_A"]
        v_l, v_r = cols["speed_left_mps"], cols["speed_right_mps"]
        yaw = (v_r - v_l) / float(meta["track_m"])
        both = (np.abs(v_l) > SIDE_MOVING_MPS) & (np.abs(v_r) > SIDE_MOVING_MPS)
        same = np.sign(v_l) == np.sign(v_r)
        kinds = {
            "straight": both & same & (np.abs(yaw) < 0.02),
            "spin": both & ~same,
            "arc": both & same & (np.abs(yaw) > ARC_YAW_RADPS),
        }
        slower_left = np.abs(v_l) < np.abs(v_r)
        inner = np.where(slower_left, i_l, i_r)
        outer = np.where(slower_left, i_r, i_l)
        surface = meta.get("surface") or "mixed"
        for kind, mask in kinds.items():
            tally.setdefault((surface, kind), []).append(np.column_stack((inner, outer))[mask])
    return {key: np.vstack(parts) for key, parts in tally.items()}


def repeat_rows(trips: list[Trip]) -> list[str]:
    """The floor no model of speed, rate of turn and surface can beat: trips of one surface
    that repeat one command (mean |speed| and |yaw rate| the same to `COMMAND_STEP`) have
    the same inputs, so each one's energy is predicted at best by its duration times the mean
    power of the others (leave one out). Per surface: the groups (their mean powers [W] and
    coefficient of variation) and that prediction's MAPE and median over their trips [%]."""
    groups: dict[tuple[str, float, float], list[float]] = {}
    for tr in trips:
        speed = round(float(np.mean(np.abs(tr.speed_mps))) / COMMAND_STEP) * COMMAND_STEP
        yaw = 0.0 if tr.yaw_radps is None else float(np.mean(np.abs(tr.yaw_radps)))
        yaw = round(yaw / COMMAND_STEP) * COMMAND_STEP
        groups.setdefault((tr.group, speed, yaw), []).append(tr.energy_J / float(np.sum(tr.held_s)))
    errors: dict[str, list[float]] = {}
    rows = []
    for (group, speed, yaw), powers in sorted(groups.items()):
        if len(powers) < 2:
            continue
        p = np.array(powers)
        others = (p.sum() - p) / (p.size - 1)
        ape = list(np.abs(others - p) / p * 100)
        errors.setdefault(group, []).extend(ape)
        errors.setdefault("all", []).extend(ape)
        cv = 100 * p.std(ddof=1) / p.mean()
        listed = ", ".join(f"{x:.0f}" for x in p)
        rows.append(
            f"| {group} | {speed:.2f} | {yaw:.2f} | {p.size} | {listed} | {cv:.1f} "
            f"| {np.mean(ape):.1f} | {np.median(ape):.1f} |"
        )
    for group, ape in sorted(errors.items(), key=lambda x: (x[0] == "all", x[0])):
        rows.append(
            f"| **{group}** | | | {len(ape)} | | | **{np.mean(ape):.1f}** "
            f"| **{np.median(ape):.1f}** |"
        )
    return rows


#: GPS altitude is smoothed over this [s] (on a 1 s grid) before its changes are taken
ALTITUDE_SMOOTH_S = 10
G_MPS2 = 9.81


def grade_rows(files: list[Path]) -> list[str]:
    """What a slope puts in a trip's energy that no term of speed can (the drive model has no
    grade term: docs/drive-model.md, "What is not modelled"): per group, over the trips of
    logs with `gps_altitude_m` and a `mass_kg` (+ `payload_kg`, the rider), the potential
    energy m g (h_end - h_start) of the trip's net climb and m g sum(dh > 0) of its gross
    climb, each over the trip's measured energy [%] (altitude the mean over
    `ALTITUDE_SMOOTH_S`: GPS altitude is noisy to a few metres, so a lower bound on what the
    road does, and an upper one on the gross climb of a flat ride). The trips are cut as
    `trips_of` cuts them."""
    net: dict[str, list[float]] = {}
    gross: dict[str, list[float]] = {}
    for path in files:
        meta, cols = read_log(path)
        if "gps_altitude_m" not in cols or "mass_kg" not in meta:
            continue
        mass_kg = float(meta["mass_kg"]) + float(meta.get("payload_kg") or 0)
        t, p, v, h = cols["time_s"], power_of(cols), cols["speed_mps"], cols["gps_altitude_m"]
        group = meta.get("surface") or meta.get("vehicle") or "all"
        for a, b in moving_stretches(t, v, None):
            energy_J = float(np.sum(p[a:b] * np.append(np.diff(t[a:b]), 0.0)))
            known = np.isfinite(h[a:b])
            grid = np.arange(t[a], t[b - 1], 1.0)
            if energy_J <= 0 or known.sum() < 2 or grid.size < 2 * ALTITUDE_SMOOTH_S:
                continue
            height = np.interp(grid, t[a:b][known], h[a:b][known])
            kernel = np.ones(ALTITUDE_SMOOTH_S) / ALTITUDE_SMOOTH_S
            height = np.convolve(height, kernel, mode="valid")
            weight = mass_kg * G_MPS2 / energy_J * 100
            for key in (group, "all"):
                net.setdefault(key, []).append(abs(height[-1] - height[0]) * weight)
                gross.setdefault(key, []).append(np.sum(np.maximum(np.diff(height), 0)) * weight)
    rows = []
    for key in sorted(net, key=lambda k: (k == "all", k)):
        n, g = np.array(net[key]), np.array(gross[key])
        rows.append(
            f"| {key} | {n.size} | {np.median(n):.1f} | {np.mean(n > 5) * 100:.0f} "
            f"| {np.median(g):.1f} |"
        )
    return rows


def fmt(x: float) -> str:
    return f"{x:.1f}"


def report() -> str:
    out = []
    found = sets()
    if not found:
        return (
            f"no converted logs in {real_drive_root()} (convert them: docs/real-logs.md, "
            "'Free driving')\n"
        )
    out.append(
        f"Trips: cut at stops (|speed| < {STOP_SPEED_MPS} m/s and |yaw| < {STOP_YAW_RADPS} "
        f"rad/s) of >= {STOP_S:g} s, kept when >= {MIN_TRIP_S:g} s; "
        f"K = {FOLDS}-fold by trip (seed {SEED}); errors of held-out trip energies [%]. In "
        f"`all`, the per-group columns cover the groups of >= {MIN_TRIPS} trips.\n"
    )
    for name, files in found.items():
        trips, seen, copies = [], set(), 0
        for tr in (tr for f in files for tr in trips_of(f, name)):
            key = (tr.group, tr.power_W.size, tr.power_W.tobytes(), tr.speed_mps.tobytes())
            copies += key in seen
            if key not in seen:
                seen.add(key)
                trips.append(tr)
        has_yaw = all(tr.yaw_radps is not None for tr in trips)
        groups = sorted({tr.group for tr in trips})
        measured_all = np.array([tr.energy_J for tr in trips])
        pooled = heldout_ls(trips, False) if len(trips) >= MIN_TRIPS else None
        pooled_yaw = heldout_ls(trips, True) if has_yaw and len(trips) >= MIN_TRIPS else None
        hours = sum(tr.time_s[-1] - tr.time_s[0] for tr in trips) / 3600
        out.append(
            f"#### {name}\n\n{len(files)} logs, {len(trips)} trips, {hours:.2f} h of trips, "
            f"{measured_all.sum() / 3.6e6:.3f} kWh"
            + (f"; {copies} trip(s) repeated in another log dropped" if copies else "")
            + ".\n"
        )
        # each trip's held-out prediction: fitted within its group, and on the whole set
        per = {False: np.full(len(trips), np.nan), True: np.full(len(trips), np.nan)}
        for g in groups:
            idx = [i for i, tr in enumerate(trips) if tr.group == g]
            if len(idx) < MIN_TRIPS:
                continue
            for with_yaw in (False, True) if has_yaw else (False,):
                per[with_yaw][idx] = heldout_ls([trips[i] for i in idx], with_yaw)
        head = (
            "| group | n | E<=0 | LS per group: MAPE | median | wAPE | cover90 "
            "| LS pooled: MAPE | median | wAPE |"
        )
        if has_yaw:
            head += (
                " LS+abs(yaw) per group: MAPE | median | wAPE "
                "| LS+abs(yaw) pooled: MAPE | median | wAPE |"
            )
        rule = "|" + "---|" * (head.count("|") - 1)
        out += [head, rule]
        for g in [*groups, "all"]:
            idx = np.array([i for i, tr in enumerate(trips) if g in ("all", tr.group)])
            m = measured_all[idx]
            nonpos = int(np.count_nonzero(m <= 0))
            if idx.size < MIN_TRIPS:
                blank = " |" * (head.count("|") - 4)
                out.append(f"| {g} | {idx.size} | {nonpos} | too few trips |{blank}")
                continue
            # "all" scores the per-group fits over every trip of a scored group
            scored = idx[np.isfinite(per[False][idx])]
            cells = [*scores(measured_all[scored], per[False][scored]), None]
            cells += scores(m, pooled[idx])
            if has_yaw:
                cells += scores(measured_all[scored], per[True][scored])
                cells += scores(m, pooled_yaw[idx])
            text = " | ".join("-" if c is None else fmt(c) for c in cells)
            out.append(f"| {g} | {idx.size} | {nonpos} | {text} |")
        repeats = repeat_rows(trips) if has_yaw else []
        if repeats:
            out += [
                "\nRepeated commands (the floor: trips of a surface whose mean |speed| and "
                f"|yaw rate| round to the same multiple of {COMMAND_STEP} m/s, rad/s; each "
                "trip's mean power predicted by the others' mean; MAPE, median [%]):\n",
                "| group | speed [m/s] | yaw [rad/s] | trips | mean power [W] | cv [%] "
                "| MAPE | median |",
                "|---|---|---|---|---|---|---|---|",
                *repeats,
            ]
        grades = grade_rows(files)
        if grades:
            out += [
                "\nSlopes (trips of logs with a GPS altitude and a mass: the potential energy "
                "of the net climb and of the gross climb, m g dh, over the trip's energy [%]):\n",
                "| group | trips | net: median | net > 5% of trips | gross: median |",
                "|---|---|---|---|---|",
                *grades,
            ]
        sides = sides_rows(files)
        if sides:
            out += [
                "\nThe sides of an arc (samples; the slower side's current at most the "
                f"standstill {STANDSTILL_A} A [%]; medians of the slower and the faster side "
                "[A]):\n",
                "| motion | surface | samples | slower <= standstill | slower | faster |",
                "|---|---|---|---|---|---|",
                *sides,
            ]
        vehicles = any(tr.group != name for tr in trips) and all(
            "vehicle" in _meta_of(f) for f in files
        )
        proxy = any(tr.voltage_assumed is not None for tr in trips)
        form = " (force form: a current proxy, drive/stats.py)" if proxy else ""
        # one fit per group (every term per surface, as "LS per group"); and, where the
        # groups are surfaces of one robot, one fit for the set (per-surface rolling and
        # turning terms, the rest shared: what `fit` does with a folder of them)
        out += same_folds_rows(trips, groups, per[False])
        for by_group in (True,) if vehicles else (True, False):
            drive = drive_model_rows(trips, by_vehicle=by_group)
            if drive is None:
                out.append("\nDrive model: drive model not available yet\n")
                break
            how = "one fit per group" if by_group else "one fit for the set"
            out += [
                f"\nDrive model{form}, {how} (`fit_drive`, each trip a run; its own folds):\n",
                "| group | n | E<=0 | MAPE | median | wAPE | cover90 |",
                "|---|---|---|---|---|---|---|",
                *drive,
                "",
            ]
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write-docs", action="store_true", help=f"into {DOCS.name}")
    args = parser.parse_args(argv)
    text = report()
    print(text, end="")
    if args.write_docs:
        write_between(DOCS, BEGIN, END, text)
    return 0


def write_between(path: Path, begin: str, end: str, text: str) -> None:
    """Replace what `path` holds between its `begin` and `end` marker lines with `text` (the
    docs' generated tables: validate_drive.py uses it too)."""
    doc = path.read_text()
    if begin not in doc or end not in doc:
        raise SystemExit(f"{path}: no {begin} ... {end} markers")
    head, _, rest = doc.partition(begin)
    _, _, tail = rest.partition(end)
    path.write_text(f"{head}{begin}\n{text}{end}{tail}")


if __name__ == "__main__":
    raise SystemExit(main())
