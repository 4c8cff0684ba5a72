"""Held-out run energy on real free-driving logs: the plain least squares and the drive model.

Issue 25, step 7 (docs/real-logs.md, "Free driving"). For each converted set (the
converters in benchmarks/real_logs/ write them to `$WBPOWER_REAL_DRIVE`, default
/work/real_drive; the F1/10 log is found as its tests find it), every log is read as `fit`
reads it, cut into **trips** as the drive model cuts them, and each trip's energy is
predicted by models fitted on the other trips (K-fold by trip), so no trip is ever
predicted by a fit that saw it, and the drive model's rows are what `wbpower fit FOLDER
--json` gives (`drive.heldout`; tests/test_real_drive.py holds them equal).

- **Reading** (`runs_of`): wbpower's reader (`wifibot_power.io.read_log`): power, speed,
  the yaw rate from the two wheel speeds and `track_m`, the surface, the metadata
  (`voltage_assumed_V`: a current proxy), as `fit` has them; a log it refuses is left out
  and said on stderr, and a log that is a piece of another (pipeline/pieces.py) too.
- **Trips** (`trips_of`): the drive model's own (drive/windows.py): a log is cut in the
  middle of every stop of at least 3 s with motion on both sides, so a trip holds half of
  each stop it borders; only trips with a window count (drive/heldout.py). Each trip's
  samples, from its first window's start to the next trip's, are the baseline's; its name
  is the model's (`RUN`, `RUN#k` when the log has several). Until the thirteenth session
  the script cut its own trips (stops' samples left out, trips under 10 s dropped) and
  gave the drive model each trip as a run: flooring's 5.8 / 4.8% against `fit`'s 7.8 /
  6.0% (docs/drive-model.md, "Real logs").
- **Energy** (the baseline's): each sample's power held until the next stamp, E = sum P_i
  (t_(i+1) - t_i); the drive model's: its windows' (heldout.py).
- **Groups**: the surface where the logs name one (`mixed` for a log with a surface per
  sample); for the unicycles the wheel (`vehicle`: each is a different vehicle); else the
  whole set.
- **Baseline (a)**, the plain least squares of issue 25: power on an intercept, |v|, v^2
  and max(a*v, 0) (speeding up; braking gets no term), by least squares weighted by each
  sample's held time; `a` is the speed's central difference over `ACCEL_WINDOW_S`
  (interpolated, so a 6.5 Hz robot and a bursty app are treated alike). Fitted per group
  ("per surface") and on every group of the set together ("pooled", then scored per
  group). Where the set has a yaw rate, also with |yaw rate| as a fifth column ("+|yaw|":
  the naive turning term).
- **Drive model (b)**: `wifibot_power.drive.fit_drive` on the group's logs (one fit per
  group: `fit` of a surface's folder) and on the set's (`fit` of the set's folder), its
  held-out trips (`drive_heldout`).
- **Folds**: the drive model's deal (heldout.py: min(10, trips) folds, a seeded
  permutation, seed 0), the baseline's too (`folds_of`), so the two predict the same trips
  from the same others ("The same trips and folds").
- **The floor** ("Repeated commands", `repeat_rows`): trips of a surface whose mean |speed|
  and |yaw rate| round alike repeat one command; each one's mean power predicted by the
  others' is the best any model of those inputs can do.
- **The sides of an arc** (`sides_rows`): the two sides' currents of a skid-steer log
  straight, spinning and on arcs: what the force form's arc rule rests on (drive/windows.py
  `_force_form`). **Slopes** (`grade_rows`): the potential energy of each trip's climb over
  its energy, where the log has a GPS altitude and a mass (read with numpy: the reader
  keeps no altitude; its trips cut at the script's own stops, `moving_stretches`).

Columns: trips (`n`), of which `E<=0` have a net energy <= 0 (unicycles walked or pushed,
or whose halves of stops hold a charger's negative current: left out of the percentages,
still in the fits), MAPE and median of |predicted - measured|
/ measured over the held-out trips [%], wAPE = sum |predicted - measured| / sum measured
[%] (the error on the total energy, weighted as a battery sees it), and the 90% interval
coverage [%] where the model gives intervals ("-": the baseline gives none). Runs in well
under a minute.

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
from typing import TYPE_CHECKING

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "real_logs"))
from canonical_out import real_drive_root  # noqa: E402  (the converters' shared module)

from wifibot_power.drive.heldout import FOLDS, MIN_TRIPS  # noqa: E402
from wifibot_power.drive.stats import current_proxy  # noqa: E402
from wifibot_power.drive.windows import STOP_S as WINDOW_STOP_S  # noqa: E402

if TYPE_CHECKING:
    from wifibot_power.run import Run

# The slopes' table (`grade_rows`) cuts the unicycles' rides at its own stops (the GPS
# altitude is a column the reader does not keep):
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
#: the drive model's seed of its deal into folds (`fit_drive`'s default)
SEED = 0

DOCS = HERE.parent / "docs" / "real-logs.md"
BEGIN, END = "<!-- drive validation: begin -->", "<!-- drive validation: end -->"


@dataclass(frozen=True)
class Trip:
    """A trip as the drive model cuts it (`trips_of`), with its samples for the baseline."""

    #: the drive model's name for it (drive/heldout.py): the run's id, `#k` when it has several
    run_id: str
    group: str
    time_s: np.ndarray
    power_W: np.ndarray
    speed_mps: np.ndarray
    yaw_radps: np.ndarray | None
    #: its run's index in the set's runs (`runs_of`)
    run: int = -1

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


def runs_of(files: list[Path]) -> list[Run]:
    """Each file as wbpower reads it (`wifibot_power.io.read_log`, what `fit` reads): a file
    the reader refuses is left out, as `fit` skips it, and said on stderr."""
    from wifibot_power.errors import WbpowerError  # noqa: PLC0415
    from wifibot_power.io import read_log as read_run  # noqa: PLC0415

    runs = []
    for path in files:
        try:
            runs.append(read_run(path))
        except WbpowerError as exc:
            print(f"left out: {str(exc).splitlines()[0]}", file=sys.stderr)
    return runs


def group_of(run: Run, set_name: str) -> str:
    """The run's group: its `surface` metadata (`mixed` when a column names a surface per
    sample: BorealTC's MIXED run, fitted as its own folder is), else its `vehicle`, else the
    set."""
    extra = run.meta.extra
    if run.surface_index is not None:
        return "mixed"
    return extra.get("surface") or extra.get("vehicle") or set_name


def trips_of(run: Run, set_name: str, index: int = -1) -> list[Trip]:
    """The run's trips as the drive model cuts them (drive/windows.py: in the middle of every
    stop of at least `windows.STOP_S` with motion on both sides) and holds them out
    (drive/heldout.py: only trips with a window), each with its samples, named as the
    model's held-out rows name them, so that the baseline and the drive model predict the
    same trips and `fit FOLDER --json`'s numbers are these. `index`: the run's in the set."""
    from wifibot_power.drive.stats import drive_stats  # noqa: PLC0415
    from wifibot_power.drive.windows import run_windows  # noqa: PLC0415

    stats = drive_stats(run)
    windows = run_windows(stats) if stats is not None else None
    if windows is None or not windows.count:
        return []
    _, defined = windows.power_at(0)
    usable = windows.ok & defined
    # each trip's first window; its samples from that window's start to the next trip's
    first = np.flatnonzero(np.r_[True, np.diff(windows.trip) > 0])
    t = run.time_s
    starts_s = t[0] + first[1:] * (windows.n * stats.bin_s)
    bounds = [0, *np.searchsorted(t, starts_s - 1e-9), t.size]
    several = int(windows.trip[-1]) > 0
    group = group_of(run, set_name)
    yaw = run.yaw_rate_radps
    out = []
    for k, (a, b) in enumerate(zip(bounds[:-1], bounds[1:], strict=True)):
        if not usable[windows.trip == k].any():
            continue
        out.append(
            Trip(
                f"{run.meta.run_id}#{k + 1}" if several else run.meta.run_id,
                group,
                t[a:b],
                run.power_W[a:b],
                run.speed_mps[a:b],
                None if yaw is None else yaw[a:b],
                index,
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
    """The fold of each of n trips: a seeded deal into min(FOLDS, n) folds, as the drive
    model deals its trips (drive/heldout.py: the same seed, count and permutation), so that
    the baseline's folds are the model's."""
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


def drive_heldout(
    runs: list[Run], trips: list[Trip], lags: list[str] | None = None, label: str = ""
) -> dict[str, object] | None:
    """`fit_drive`'s held-out trips of `runs` (whole runs, as `fit` gives them), by trip id:
    each `HeldOutRun` (measured and predicted energy, 90% interval). None when it has no
    held-out accuracy. Its trips are `trips` (the same cut, `trips_of`); a trip of one and
    not the other is said on stderr (the tables would not compare the same trips). `lags`:
    the fit's lag row is added to it (`lag_row`, `label` its group)."""
    from wifibot_power.drive import fit_drive  # noqa: PLC0415

    model = fit_drive(runs)
    if lags is not None and model is not None:
        lags.append(lag_row(label, model))
    if model is None or model.heldout is None:
        return None
    held = {r.run_id: r for r in model.heldout.runs}
    mine = {tr.run_id for tr in trips}
    if set(held) != mine:
        print(
            f"the drive model held out {len(held)} trips, the baseline's cut has {len(mine)}: "
            f"{sorted(set(held) ^ mine)[:5]}",
            file=sys.stderr,
        )
    return held


def lag_row(label: str, model) -> str:
    """The fit's lag, its 95% interval (`lag_ci95_s`, drive/laginterval.py) and whether
    the logs determine it (its `not_determined` entry), as a table row."""
    ci = model.lag_ci95_s
    interval = f"[{ci[0]:.2f}, {ci[1]:.2f}]" if ci is not None else "none"
    entry = [r for r in model.not_determined if r.startswith("lag_s:")]
    said = "no: " + entry[0].split(", ", 1)[1].split("; the predictions")[0] if entry else "yes"
    return f"| {label} | {model.lag_s:.3f} | {interval} | {said} |"


def drive_model_rows(trips: list[Trip], held: dict[str, object]) -> list[str]:
    """The drive model's held-out rows (group, n, E<=0, MAPE, median, wAPE, cover90) per group
    of `trips` and `all`, from `drive_heldout`'s trips."""
    if not held:
        return [f"| all | 0 | - | no held-out accuracy from the drive model ({len(trips)} trips) |"]
    group_of_trip = {tr.run_id: tr.group for tr in trips}
    pairs = [(group_of_trip.get(key, r.surface), r) for key, r in held.items()]
    rows = []
    for g in [*sorted({g for g, _ in pairs}), "all"]:
        mine = [r for h, r in pairs if g in ("all", h)]
        m = np.array([r.measured_J for r in mine])
        p = np.array([r.predicted_J for r in mine])
        lo = np.array([r.pi90_J[0] for r in mine])
        hi = np.array([r.pi90_J[1] for r in mine])
        scaled = p != 0  # a trip predicted at 0 J has no interval (heldout.py)
        cover = float(np.mean(((m >= lo) & (m <= hi))[scaled]) * 100) if scaled.any() else np.nan
        cells = " | ".join(fmt(c) for c in (*scores(m, p), cover))
        rows.append(f"| {g} | {len(mine)} | {int(np.count_nonzero(m <= 0))} | {cells} |")
    return rows


def same_folds_rows(
    trips: list[Trip], groups: list[str], ls_per_group: np.ndarray, held: dict[str, object]
) -> list[str]:
    """The plain least squares and the drive model, each fitted per group, side by side on the
    same trips and folds (the model's: `trips_of`, `folds_of`): each one's errors over its own
    measure of a trip's energy (the samples' for the least squares, the windows' for the drive
    model)."""
    rows = []
    for g in [*groups, "all"]:
        idx = [
            i
            for i, tr in enumerate(trips)
            if g in ("all", tr.group) and np.isfinite(ls_per_group[i])
        ]
        if not idx or (g == "all" and len(rows) < 2):
            continue
        ls_m = np.array([trips[i].energy_J for i in idx])
        drive = [held.get(trips[i].run_id) for i in idx]
        m = np.array([np.nan if r is None else r.measured_J for r in drive])
        d = np.array([np.nan if r is None else r.predicted_J for r in drive])
        known = np.isfinite(m) & np.isfinite(d) & (m > 0)
        cells = [*scores(ls_m, ls_per_group[idx]), int(known.sum()), *scores(m[known], d[known])]
        text = " | ".join(str(c) if isinstance(c, int) else fmt(c) for c in cells)
        rows.append(f"| {g} | {len(idx)} | {text} |")
    if not rows:
        return []
    return [
        "\nThe same trips and folds, fitted per group (the plain least squares beside the drive "
        "model: `fit FOLDER --json`'s held-out trips; MAPE / median / wAPE [%]; the drive "
        "model's n: trips it predicts):\n",
        "| group | n | LS: MAPE | median | wAPE | drive: n | MAPE | median | wAPE |",
        "|---|---|---|---|---|---|---|---|---|",
        *rows,
    ]


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
        "Logs read by wbpower's reader (as `fit` reads them: a log it refuses is left out), "
        "cut into trips by the drive model (in the middle of every stop of >= "
        f"{WINDOW_STOP_S:g} s with motion on both sides; trips with a window); K = "
        f"min({FOLDS}, trips)-fold by trip, the drive model's deal (seed {SEED}); errors of "
        f"held-out trip energies [%]. In `all`, the per-group columns cover the groups of >= "
        f"{MIN_TRIPS} trips.\n"
    )
    for name, files in found.items():
        runs = runs_of(files)
        trips = [tr for k, run in enumerate(runs) for tr in trips_of(run, name, k)]
        has_yaw = all(tr.yaw_radps is not None for tr in trips)
        groups = sorted({tr.group for tr in trips})
        measured_all = np.array([tr.energy_J for tr in trips])
        pooled = heldout_ls(trips, False) if len(trips) >= MIN_TRIPS else None
        pooled_yaw = heldout_ls(trips, True) if has_yaw and len(trips) >= MIN_TRIPS else None
        hours = sum(tr.time_s[-1] - tr.time_s[0] for tr in trips) / 3600
        out.append(
            f"#### {name}\n\n{len(files)} logs, {len(trips)} trips, {hours:.2f} h of trips, "
            f"{measured_all.sum() / 3.6e6:.3f} kWh" + ".\n"
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
            "vehicle" in run.meta.extra for run in runs
        )
        proxy = any(current_proxy(run) for run in runs)
        form = " (force form: a current proxy, drive/stats.py)" if proxy else ""
        # one fit per group (every term per surface, as "LS per group": `fit` on a surface's
        # folder); and, where the groups are surfaces of one robot, one fit for the set
        # (per-surface rolling and turning terms, the rest shared: `fit` on the set's folder)
        per_group: dict[str, object] = {}
        lags: list[str] = []
        for g in groups:
            members = [trips[i] for i in range(len(trips)) if trips[i].group == g]
            chosen = [runs[k] for k in sorted({tr.run for tr in members})]
            held = drive_heldout(chosen, members, lags, g)
            per_group.update(held or {})
        out += same_folds_rows(trips, groups, per[False], per_group)
        for by_group in (True,) if vehicles else (True, False):
            held = per_group if by_group else drive_heldout(runs, trips, lags, "all")
            how, whose = (
                ("one fit per group", "group's") if by_group else ("one fit for the set", "set's")
            )
            out += [
                f"\nDrive model{form}, {how} (`fit_drive` on the {whose} logs, `fit FOLDER "
                "--json`'s held-out trips):\n",
                "| group | n | E<=0 | MAPE | median | wAPE | cover90 |",
                "|---|---|---|---|---|---|---|",
                *drive_model_rows(trips, held or {}),
                "",
            ]
        out += [
            "The lag of each fit above (`lag_s`; its 95% interval `lag_ci95_s`, a cluster "
            "bootstrap of the lag search: drive/laginterval.py; determined unless the interval "
            "spans over half the lags tried, reaches the longest, or cannot be made):\n",
            "| group | lag_s [s] | 95% interval [s] | determined |",
            "|---|---|---|---|",
            *lags,
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
