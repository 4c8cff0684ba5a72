"""wbpower on real free-driving logs (issue 25, step 7; docs/real-logs.md, "Free driving").

The converted logs (benchmarks/real_logs/convert_borealtc.py, convert_euc.py) live outside
the repository, in `$WBPOWER_REAL_DRIVE` (default /work/real_drive); where there are none,
these tests are skipped, saying so. The energies are checked against the **raw source
files**, read here with this file's own code from the fetched mirrors (found from each
converted file's `source_repo` / `source_commit` / `source_path` metadata, under
`$WBPOWER_MIRRORS`, default /work/.mirror); without the mirror that check is skipped.

Every converted log is read (issue 26: no fixed ceiling, a phone app's stamps judged by its
own pattern, its drop-outs reported missing), except a file that holds more time in pauses
than in samples, decided from the raw data (`mostly_missing`), which is refused saying to cut
it. A Husky spinning in place is a `turn`, never idle.
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import os
import subprocess
from datetime import datetime
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from scripts import load_script

ROOT = Path(__file__).resolve().parents[1]
out = load_script("canonical_out", ROOT / "benchmarks" / "real_logs" / "canonical_out.py")
DRIVE = out.real_drive_root()
FILES = sorted(DRIVE.rglob("*.csv.gz")) if DRIVE.is_dir() else []
MIRRORS = Path(os.environ.get("WBPOWER_MIRRORS") or "/work/.mirror")
UNAVAILABLE = (
    f"no converted free-driving logs in {DRIVE} (set {out.REAL_DRIVE_VAR}, or convert them: "
    "docs/real-logs.md, 'Free driving')"
)
#: the Husky logs' assumed battery voltage [V] (the logs hold currents only; docs)
HUSKY_V = 24.0


def _meta(path: Path) -> dict[str, str]:
    with gzip.open(path, "rt") as fh:
        return dict(line[2:].rstrip("\n").split(": ", 1) for line in fh if line[:2] == "# ")


def _git_dir(repo_url: str) -> Path | None:
    owner, name = repo_url.rstrip("/").split("/")[-2:]
    for candidate in (
        MIRRORS / f"{owner}+{name}" / "repo" / ".git",
        MIRRORS / f"{owner}+{name}" / "repo",
    ):
        if (candidate / "HEAD").is_file():
            return candidate
    return None


def _raw_text(meta: dict[str, str], path: str) -> str:
    git_dir = _git_dir(meta["source_repo"])
    if git_dir is None:
        pytest.skip(f"the fetched mirror of {meta['source_repo']} is needed (under {MIRRORS})")
    return subprocess.run(
        ["git", f"--git-dir={git_dir}", "show", f"{meta['source_commit']}:{path}"],
        check=True,
        capture_output=True,
    ).stdout.decode()


@cache  # each raw file is read once per session (collection and tests)
def raw_samples(converted: Path) -> tuple[np.ndarray, np.ndarray]:
    """(time [s], power [W]) of the log's raw source file, read here from scratch."""
    meta = _meta(converted)
    path = meta["source_path"].split(",")[0].strip()
    rows = list(csv.DictReader(io.StringIO(_raw_text(meta, path))))
    if "norlab-ulaval/BorealTC" in meta["source_repo"]:
        t = np.array([float(r["time"]) for r in rows])
        amps = np.array([float(r["curL"]) + float(r["curR"]) for r in rows])
        return t, HUSKY_V * amps
    # phone apps: EUC World (datetime) or WheelLog (date, time); rows with a field missing
    # or a stamp not after the last one kept are skipped, as the converter's docs say
    times, watts, last = [], [], -np.inf
    for r in rows:
        stamp = r.get("datetime") or (r.get("date") and f"{r['date']}T{r['time']}")
        if not (stamp and r["voltage"] and r["current"] and r["speed"]):
            continue
        s = datetime.fromisoformat(stamp).timestamp()
        if s <= last:
            continue
        last = s
        times.append(s)
        watts.append(float(r["voltage"]) * float(r["current"]))
    return np.array(times) - times[0], np.array(watts)


#: a step between stamps longer than this [s] is time the log does not cover (an app
#: paused for minutes), not power held: the phone apps write at least every 4 s otherwise
MISSING_S = 5.0


def stamps_energy_J(t: np.ndarray, p: np.ndarray) -> float:
    """sum P_i (t_(i+1) - t_i) over the steps up to MISSING_S, + P_last x (the median step):
    each sample held until the next stamp, the last one for one period (as a reader that
    counts samples x period does for an even log)."""
    step = np.diff(t)
    covered = step <= MISSING_S
    return float(np.sum(p[:-1][covered] * step[covered]) + p[-1] * np.median(step))


def raw_energy_J(converted: Path) -> float:
    """The energy of the raw source file over the time it covers (`stamps_energy_J`)."""
    return stamps_energy_J(*raw_samples(converted))


def mostly_missing(t: np.ndarray) -> bool:
    """The raw file spends more of its span in pauses (steps over MISSING_S) than in
    samples: two sessions in one file (euc_core/mten4/2: 8.4 h between two rides)."""
    step = np.diff(t)
    return float(np.sum(step[step > MISSING_S])) > 0.5 * float(t[-1] - t[0])


CASES = [pytest.param(f, id=str(f.relative_to(DRIVE))) for f in FILES] or [
    pytest.param(None, marks=pytest.mark.skip(reason=UNAVAILABLE))
]


@pytest.mark.parametrize("log", CASES)
def test_inspect_reads_the_log_and_its_energy_is_the_raw_files(log: Path, wbpower) -> None:
    """The energy over the covered time plus each reported gap's missing time at the power
    held before it is the raw file's hold integral (each sample held to the next stamp):
    what is missing is reported, and nothing else is left out or counted twice."""
    t, p = raw_samples(log)  # skips without the mirror
    result = wbpower("inspect", "--json", log)
    if mostly_missing(t):
        assert result.exit_code != 0, result.stderr
        assert "more time missing than the" in result.stderr
        assert "cut it at its longest gap" in result.stderr
        return
    assert result.exit_code == 0, result.stderr
    (entry,) = json.loads(result.stdout)["logs"]
    period_s = entry["sample_period_s"]
    hold_J = float(np.sum(p[:-1] * np.diff(t)) + p[-1] * period_s)
    gaps = [d for d in entry["problem_details"] if d["kind"] == "gap"]
    before = np.searchsorted(t, np.array([d["t_start_s"] for d in gaps]) - period_s - 1e-6)
    missing_J = float(np.sum(p[before] * np.array([d["duration_s"] for d in gaps])))
    # a logger stamping rows as they arrive is read on an even grid by sample and hold
    # (io/holdgrid.py): its energy is the hold integral's to the grid's rounding, measured
    # within 0.52% on these rides (euc_core/v9/2; each row held for the mean step instead:
    # up to 13% off, v9/4); evenly spaced logs agree to the converter's rounding (0.1%)
    assert entry["energy_J"] + missing_J == pytest.approx(hold_J, rel=0.01), (hold_J, entry)


@pytest.mark.parametrize(
    "log",
    [pytest.param(f, id=str(f.relative_to(DRIVE))) for f in FILES]
    or [pytest.param(None, marks=pytest.mark.skip(reason=UNAVAILABLE))],
)
def test_the_converted_log_holds_the_raw_files_energy(log: Path) -> None:
    """The converter, checked apart from wbpower: the converted file's energy (read with
    this test's own parser) is the raw file's to its rounding (0.1 V, 10 mA)."""
    with gzip.open(log, "rt") as fh:
        lines = [line for line in fh if not line.startswith("#")]
    rows = list(csv.DictReader(io.StringIO("".join(lines))))
    t = np.array([float(r["time_s"]) for r in rows])
    pairs = [
        n[len("voltage") : -2] for n in rows[0] if n.startswith("voltage") and n.endswith("_V")
    ]
    p = sum(
        np.array([float(r[f"voltage{k}_V"]) * float(r[f"current{k}_A"]) for r in rows])
        for k in pairs
    )
    assert stamps_energy_J(t, p) == pytest.approx(raw_energy_J(log), rel=1e-3)


def test_every_log_carries_its_provenance() -> None:
    if not FILES:
        pytest.skip(UNAVAILABLE)
    for f in FILES:
        meta = _meta(f)
        for key in ("source_repo", "source_commit", "source_path", "source_licence", "robot"):
            assert meta.get(key), (f, key)
        assert len(meta["source_commit"]) == 40, f


#: Husky logs that spin in place between and after their straight stretches (measured:
#: asphalt/pro_05 spins at 0.46 rad/s and 372 W for its last 30 s; ice/pro_11 at 0.5-0.7
#: rad/s and 140-190 W for 1-9 s)
SPINNING = ("borealtc/asphalt/pro_05.csv.gz", "borealtc/ice/pro_11.csv.gz")
#: a phase whose mean |yaw rate| exceeds this [rad/s] turns (the validation's stop rule is
#: 0.05 rad/s; 0.2 rad/s is four times that and far below these logs' 0.46-0.7 rad/s)
TURNING_RADPS = 0.2


@pytest.mark.parametrize("name", SPINNING)
def test_a_spinning_husky_is_never_idle(name: str, wbpower) -> None:
    log = DRIVE / name
    if not log.is_file():
        pytest.skip(UNAVAILABLE)
    meta = _meta(log)
    with gzip.open(log, "rt") as fh:
        rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    t = np.array([float(r["time_s"]) for r in rows])
    yaw = np.array(
        [(float(r["speed_right_mps"]) - float(r["speed_left_mps"])) for r in rows]
    ) / float(meta["track_m"])
    result = wbpower("segment", "--json", log)
    assert result.exit_code == 0, result.stderr
    run = json.loads(result.stdout)  # one file: its object
    spinning_idles = [
        ph
        for ph in run["phases"]
        if ph["phase"] == "idle"
        and np.mean(np.abs(yaw[(t >= ph["t_start_s"] - 1e-9) & (t < ph["t_end_s"] - 1e-9)]))
        > TURNING_RADPS
    ]
    assert not spinning_idles, spinning_idles
    # and the spin is a turn (issues 25/26: read from the two wheel speeds and track_m)
    assert any(ph["phase"] == "turn" for ph in run["phases"]), run["phases"]


@pytest.mark.parametrize("surface", ["sandy_loam", "flooring"])
def test_the_validation_prints_what_the_cli_gives(surface: str, wbpower) -> None:
    """`wbpower fit FOLDER --json` on a BorealTC surface takes the current proxy's force form
    (the warning says so), and the validation script's trips and drive-model numbers are its
    held-out trips, number for number: the script reads the logs with wbpower's reader and
    takes the model's own trips. Until the thirteenth session it cut its own (dropping the
    stops' samples and trips under 10 s) and quoted flooring at 5.8 / 4.8% where `fit` gives
    7.8 / 6.0% (docs/drive-model.md, "Real logs"). Through the CLI the logs were fitted as
    power logs until the twelfth session (the reader lower-cases '# voltage_assumed_V')."""
    folder = DRIVE / "borealtc" / surface
    if not folder.is_dir():
        pytest.skip(UNAVAILABLE)
    result = wbpower("fit", "--json", folder)
    assert result.exit_code == 0, result.stderr
    drive = json.loads(result.stdout)["drive"]
    assert any("hold motor currents only" in w for w in drive["warnings"]), drive["warnings"]
    cli = {r["run_id"]: r for r in drive["heldout"]["runs"]}
    runs = validate.runs_of(sorted(folder.glob("*.csv.gz")))
    trips = [tr for k, run in enumerate(runs) for tr in validate.trips_of(run, "borealtc", k)]
    held = validate.drive_heldout(runs, trips)
    assert sorted(tr.run_id for tr in trips) == sorted(held) == sorted(cli)
    for key, row in held.items():
        assert row.measured_J == pytest.approx(cli[key]["measured_J"], rel=1e-9)
        assert row.predicted_J == pytest.approx(cli[key]["predicted_J"], rel=1e-9)
    mape, median, _ = validate.scores(
        np.array([r.measured_J for r in held.values()]),
        np.array([r.predicted_J for r in held.values()]),
    )
    assert mape == pytest.approx(drive["heldout"]["mape_pct"], rel=1e-9)
    assert median == pytest.approx(drive["heldout"]["median_ape_pct"], rel=1e-9)


# --- the validation script's own parts, on made-up data (no logs needed) ---------------

validate = load_script("validate_drive_real", ROOT / "benchmarks" / "validate_drive_real.py")


def _trip(t: np.ndarray, v: np.ndarray, coef: tuple[float, ...], group: str = "g"):
    """A Trip whose power is exactly the baseline's terms with `coef`."""
    a = (np.interp(t + 0.5, t, v) - np.interp(t - 0.5, t, v)) / 1.0
    p = coef[0] + coef[1] * np.abs(v) + coef[2] * v * v + coef[3] * np.maximum(a * v, 0)
    return validate.Trip(f"{group}#{t[0]:.0f}", group, t, p, v, None)


def test_the_baseline_predicts_a_held_out_trip_whose_power_is_its_terms() -> None:
    rng = np.random.default_rng(3)
    coef = (28.0, 120.0, 40.0, 55.0)  # W, W/(m/s), W/(m/s)^2, kg-like W/(m^2/s^3)
    trips = []
    for k in range(8):
        t = np.arange(0, 60, 0.2)
        v = np.clip(np.cumsum(rng.normal(0, 0.05, t.size)) + 0.5 + 0.1 * k, 0, None)
        trips.append(_trip(t, v, coef))
    pred = validate.heldout_ls(trips, with_yaw=False)
    measured = np.array([tr.energy_J for tr in trips])
    assert np.max(np.abs(pred - measured) / measured) < 1e-6
    # and a trip of another robot (twice the rolling power) is missed by the same fit
    other = _trip(trips[0].time_s, trips[0].speed_mps, (28.0, 240.0, 40.0, 55.0))
    coef_fit = validate.fit_ls(trips, with_yaw=False)
    assert validate.predict_ls(coef_fit, other, False) < 0.9 * other.energy_J


def test_the_baselines_trips_are_the_drive_models_own() -> None:
    """The script's trips are those `fit` holds out (drive/windows.py: cut in the middle of
    each stop of 3 s or more), named as its held-out rows, and together they hold every
    sample of the run: the stops' samples were dropped by the script's own cut before."""
    from wifibot_power.drive import fit_drive
    from wifibot_power.run import Run, RunMeta

    period_s = 0.05
    t = np.arange(0, 80, period_s)
    v = np.where((t % 16.0) < 10.0, 0.5, 0.0)  # 10 s driving, 6 s standing
    v[t >= 74] = 0.5  # no stop at the end: 4 stops, 5 trips
    meta = RunMeta(run_id="made", mode="motion", sample_period_s=period_s)
    run = Run("made.csv", "wbpower-csv", meta, t, 10.0 + 20.0 * v, speed_mps=v)
    trips = validate.trips_of(run, "set", 0)
    assert [tr.run_id for tr in trips] == [f"made#{k}" for k in range(1, 6)]
    held = fit_drive([run]).heldout
    assert sorted(r.run_id for r in held.runs) == [tr.run_id for tr in trips]
    assert sum(tr.time_s.size for tr in trips) == t.size  # no sample lost nor counted twice
    # each cut in the middle of its stop (to a window, 0.5 s)
    cuts_s = np.array([tr.time_s[0] for tr in trips[1:]])
    assert np.max(np.abs(cuts_s - (np.arange(1, 5) * 16.0 - 3.0))) <= 0.5


def test_trips_are_cut_at_long_stops_and_at_gaps_not_at_short_stops() -> None:
    t = np.concatenate([np.arange(0, 100, 0.5), np.arange(110, 140, 0.5)])  # a 10 s gap
    v = np.full(t.size, 1.0)
    v[(t >= 20) & (t < 21)] = 0.0  # a 1 s stop: not a cut
    v[(t >= 50) & (t < 55)] = 0.0  # a 5 s stop: a cut
    stretches = validate.moving_stretches(t, v, None)
    spans = [(t[a], t[b - 1]) for a, b in stretches]
    assert spans == [(0.0, 49.5), (55.0, 99.5), (110.0, 139.5)]
    # a robot spinning in place (yaw rate) during the 5 s "stop" is not stopped
    yaw = np.where((t >= 50) & (t < 55), 0.5, 0.0)
    assert len(validate.moving_stretches(t, v, yaw)) == 2


def test_the_converters_write_the_logs_found_byte_for_byte(tmp_path: Path) -> None:
    """The converted logs in WBPOWER_REAL_DRIVE are what the committed converters write from
    the fetched mirrors (gzip without a time stamp: the same input, the same bytes)."""
    bt = load_script("convert_borealtc", ROOT / "benchmarks" / "real_logs" / "convert_borealtc.py")
    euc = load_script("convert_euc", ROOT / "benchmarks" / "real_logs" / "convert_euc.py")
    jobs = {
        "borealtc": (f"https://github.com/{bt.REPO}", lambda m, o: bt.convert(m, o, "borealtc")),
        "vulpi": (f"https://github.com/{bt.REPO}", lambda m, o: bt.convert(m, o, "vulpi")),
        **{
            name: (
                f"https://github.com/{src.repo}",
                lambda m, o, name=name: euc.convert(name, m, o)[0],
            )
            for name, src in euc.SOURCES.items()
        },
    }
    compared = 0
    for name, (repo, convert) in jobs.items():
        found = DRIVE / name
        mirror = _git_dir(repo)
        if not found.is_dir() or mirror is None:
            continue
        written = convert(mirror, tmp_path / name)
        assert sorted(p.relative_to(tmp_path / name) for p in written) == sorted(
            p.relative_to(found) for p in found.rglob("*.csv.gz")
        ), name
        for p in written:
            assert p.read_bytes() == (found / p.relative_to(tmp_path / name)).read_bytes(), p
        compared += 1
    if not compared:
        pytest.skip(f"{UNAVAILABLE}; or no fetched mirror under {MIRRORS}")


def _sides_proxy(
    v: np.ndarray, yaw: np.ndarray, track_m: float, viscous: float = 40.0, wong: bool = False
) -> np.ndarray:
    """A Husky-like current proxy built side by side, not from the drive model's columns:
    each side needs half the rolling force (50 W proxy while it moves) and its viscous force
    (40 W/(m/s) of its own speed) along its motion, plus or minus the scrubbing moment over
    the track (125 W Coulomb + 40 W/(rad/s)), F_side = F/2 +- M/B (Wong 2008, Sec. 7.2); a
    side's current is logged only while it drives (F_side > 0: a braking side reads ~0 A);
    idle 30 W. `wong`: the moment on a turn of radius R is its spin's times 0.925 / (0.925 +
    0.15 R/B) (Wong 2008, Sec. 7.2)."""
    total = np.full(v.size, 30.0)
    moment = np.where(yaw != 0, 125.0 + 40.0 * np.abs(yaw), 0.0)
    if wong:
        with np.errstate(divide="ignore", invalid="ignore"):
            radius_m = np.where(yaw != 0, np.abs(v) / np.abs(yaw), 0.0)
        moment = moment * 0.925 / (0.925 + 0.15 * radius_m / track_m)
    for side in (-1.0, 1.0):
        side_v = v + side * yaw * track_m / 2
        moves = np.abs(side_v) > 1e-9
        # along its own motion: the moment helps the side turning against it (the inner
        # side of an arc), drives both sides of a spin (each turns its own way)
        sign = np.sign(side_v) * side * np.sign(yaw)
        along = np.where(moves, 50.0 + viscous * np.abs(side_v) + sign * moment, 0.0)
        total += np.maximum(along, 0.0)
    return total


def test_a_current_proxys_arc_counts_the_driving_side_only() -> None:
    # drive/windows.py `_force_form`: driving straight the proxy is F, spinning F_r + 2M/B,
    # on an arc F/2 + M/B (its inner side brakes): a proxy made side by side is fitted back
    # exactly on steady windows, with the rolling, viscous and moment terms the sides were
    # given; counting an arc as a spin plus a straight run (its longitudinal and moment
    # columns in full) misses it
    from wifibot_power.drive.identify import least_squares
    from wifibot_power.drive.stats import drive_stats
    from wifibot_power.drive.windows import assemble, run_windows
    from wifibot_power.run import Run, RunMeta

    track_m, period_s = 0.57, 0.01
    t = np.arange(0, 60, period_s)
    plan = [  # (start, end, speed [m/s], yaw rate [rad/s]); standing elsewhere
        (3, 11, 0.4, 0.0),
        (14, 22, 0.8, 0.0),
        (25, 33, 0.0, 0.5),
        (36, 44, 0.0, 1.0),
        (47, 57, 0.3, 0.4),
    ]
    v, yaw = np.zeros(t.size), np.zeros(t.size)
    for start, end, speed, rate in plan:
        inside = (t >= start) & (t < end)
        v[inside], yaw[inside] = speed, rate
    meta = RunMeta(
        run_id="arc", sample_period_s=period_s, extra={"surface": "s", "voltage_assumed_V": "24"}
    )
    proxy = _sides_proxy(v, yaw, track_m)
    run = Run("arc.csv", "wbpower-csv", meta, t, proxy, speed_mps=v, yaw_rate_radps=yaw)
    windows = assemble([run_windows(drive_stats(run))], 0)
    start = np.arange(windows.size) * windows.window_s
    steady = np.ones(windows.size, dtype=bool)
    for edge in sorted({e for s, f, *_ in plan for e in (s, f)}):  # no window across a step
        steady &= (start + windows.window_s <= edge) | (start >= edge)
    names = ("idle_W", "rolling_W_per_mps[s]", "quadratic_W_per_mps2", "turning_coulomb_W[s]")
    X = windows.design[steady][:, [windows.columns.index(n) for n in (*names, "turning_Nm[s]")]]
    y = windows.power_W[steady]
    coef = least_squares(X, y)
    # idle, rolling (both sides), viscous (both sides: 2 x 40), Coulomb moment 2 x 125;
    # the rate part: 2 x 40 and a spinning side's viscous force at omega B/2
    expected = (30.0, 100.0, 80.0, 250.0, 80.0 + 80.0 * track_m / 2)
    np.testing.assert_allclose(coef, expected, rtol=1e-6)
    arc = steady & (start >= 47) & (start < 57)
    np.testing.assert_allclose(X[arc[steady]] @ coef, y[arc[steady]], rtol=1e-9)


def test_vulpis_aliased_wheel_speeds_are_replaced_and_nothing_else() -> None:
    # convert_borealtc.dealias: a sample reading about half of its two agreeing neighbours
    # (Vulpi's every third or fourth) takes their mean; a real change of speed, a stop, a
    # start from rest and a half-speed stretch longer than one sample are kept as logged
    bt = load_script("convert_borealtc", ROOT / "benchmarks" / "real_logs" / "convert_borealtc.py")
    cruise = np.full(12, 0.56)
    cruise[[2, 6, 9]] = [0.29, 0.30, 0.27]  # aliased
    ramp = np.linspace(0.56, 0.0, 8)  # braking to a stop
    halved = np.array([0.56, 0.28, 0.28, 0.28, 0.56])  # a real stretch at half speed
    start = np.array([0.0, 0.0, 0.3, 0.56, 0.56])
    speed = np.concatenate((cruise, ramp, halved, start))
    fixed, count = bt.dealias(speed)
    assert count == 3
    expected = speed.copy()
    expected[[2, 6, 9]] = [0.56, 0.56, 0.56]
    np.testing.assert_allclose(fixed, expected)
    # backwards alike
    fixed, count = bt.dealias(-speed)
    assert count == 3
    np.testing.assert_allclose(fixed, -expected)


def test_a_current_proxy_that_never_stands_keeps_its_rolling_force_not_idle() -> None:
    # trips that never stand make idle and the rolling force (on while moving) one column;
    # in the force form idle is the motors' standstill current and the rolling force is
    # what moving takes, so rolling is kept (identify.PREFERENCE_FORCE_FORM) and an arc,
    # where the rolling force counts half, is predicted from straight runs and spins alone
    from wifibot_power.drive import fit_drive
    from wifibot_power.drive.stats import drive_stats
    from wifibot_power.run import Run, RunMeta

    track_m, period_s = 0.57, 0.01
    t = np.arange(0, 20, period_s)
    extra = {"surface": "s", "voltage_assumed_V": "24"}

    def run(name: str, speed: float, rate: float) -> Run:
        v, yaw = np.full(t.size, speed), np.full(t.size, rate)
        meta = RunMeta(run_id=name, sample_period_s=period_s, extra=extra)
        proxy = _sides_proxy(v, yaw, track_m) - 30.0  # no idle to see: 0 W standing
        return Run(f"{name}.csv", "wbpower-csv", meta, t, proxy, speed_mps=v, yaw_rate_radps=yaw)

    kinds = [(0.4, 0.0), (0.8, 0.0), (0.0, 0.5), (0.0, 1.0)]
    runs = [run(f"r{k}{j}", *kind) for k, kind in enumerate(kinds) for j in range(2)]
    model = fit_drive(runs)
    assert "rolling_W_per_mps" in model.surfaces["s"]
    assert "idle_W" not in model.terms
    measured_J, predicted_J = model.run_energy_J(drive_stats(run("arc", 0.3, 0.4)))
    assert abs(predicted_J / measured_J - 1) < 0.01, (measured_J, predicted_J)


@pytest.mark.skipif(
    not (DRIVE / "borealtc").is_dir(), reason=UNAVAILABLE.replace("logs in", "BorealTC logs in")
)
def test_a_huskys_arc_is_driven_by_its_outer_side_alone() -> None:
    # what `_force_form` assumes, read from the raw side currents, not from any fit: on an
    # arc the slower side reads at most the standstill current in most samples of every
    # surface, its median at that level, while driving straight or spinning in place a side
    # seldom does; the faster side of an arc carries at least half a spin's side
    files = sorted((DRIVE / "borealtc").rglob("*.csv.gz"))
    tally = validate.sides_currents(files)
    standstill = validate.STANDSTILL_A
    for (surface, kind), sides in tally.items():
        if sides.shape[0] < 100:
            continue
        idle_share = float(np.mean(sides[:, 0] <= standstill))
        if kind == "arc":
            assert idle_share > 0.5, (surface, idle_share)
            assert np.median(sides[:, 0]) <= standstill, surface
            spin = tally.get((surface, "spin"))
            if spin is not None and spin.shape[0] >= 100:
                assert np.median(sides[:, 1]) > 0.5 * np.median(spin), surface
        else:
            assert idle_share < 0.1, (surface, kind, idle_share)
    assert {kind for _, kind in tally} == {"arc", "spin", "straight"}


def test_a_current_proxys_arc_turns_with_the_moment_of_its_radius() -> None:
    # windows._radius_factor: with the log's track the arc's moment is its spin's times
    # 0.925 / (0.925 + 0.15 R/B); a proxy made side by side with that moment is fitted back
    # exactly, and without the track (the factor unknown: 1) it is not
    from wifibot_power.drive.identify import least_squares
    from wifibot_power.drive.stats import drive_stats
    from wifibot_power.drive.windows import assemble, run_windows
    from wifibot_power.run import Run, RunMeta

    track_m, period_s = 0.57, 0.01
    t = np.arange(0, 50, period_s)
    plan = [(3, 11, 0.4, 0.0), (14, 22, 0.0, 0.5), (25, 33, 0.0, 1.0), (36, 46, 0.3, 0.4)]
    v, yaw = np.zeros(t.size), np.zeros(t.size)
    for start, end, speed, rate in plan:
        inside = (t >= start) & (t < end)
        v[inside], yaw[inside] = speed, rate
    proxy = _sides_proxy(v, yaw, track_m, viscous=0.0, wong=True)
    fits = {}
    for with_track in (True, False):
        extra = {"surface": "s", "voltage_assumed_V": "24"}
        if with_track:
            extra["track_m"] = str(track_m)
        meta = RunMeta(run_id="arc", sample_period_s=period_s, extra=extra)
        run = Run("arc.csv", "wbpower-csv", meta, t, proxy, speed_mps=v, yaw_rate_radps=yaw)
        windows = assemble([run_windows(drive_stats(run))], 0)
        start = np.arange(windows.size) * windows.window_s
        steady = np.ones(windows.size, dtype=bool)
        for edge in sorted({e for s, f, *_ in plan for e in (s, f)}):
            steady &= (start + windows.window_s <= edge) | (start >= edge)
        names = ("idle_W", "rolling_W_per_mps[s]", "turning_coulomb_W[s]", "turning_Nm[s]")
        X = windows.design[steady][:, [windows.columns.index(n) for n in names]]
        y = windows.power_W[steady]
        coef = least_squares(X, y)
        fits[with_track] = (coef, float(np.max(np.abs(X @ coef - y) / y)))
    np.testing.assert_allclose(fits[True][0], (30.0, 100.0, 250.0, 80.0), rtol=1e-6)
    assert fits[True][1] < 1e-9
    assert fits[False][1] > 0.01
