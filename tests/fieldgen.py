"""An independent generator of field-realistic Wifibot logs, to validate `diagnose` on
data it was not built from.

Written apart from `wifibot_power.simulate` (nothing of it is imported): its own robot
power model from the paper's lines, its own continuous-time phase construction, its own
field realism, and each catalogue cause in a physically plausible form *other* than the
exact one `causes.py` fits, plus off-catalogue effects that no cause of causes.md names.

The robot (paper Eq. 2 and 4, idle from Table 1):

    P(t) = 23.3 + 0.6·[driven] + 11.2·v(t) + K·a(t)·v(t)     [W]

with an acceleration of mean 0.8 m/s² over T = v/0.8: constant by default, or
jerk-limited (`Batch.jerk_s`, an S-shaped speed): the acceleration rises linearly over
jerk_s (a quarter of T at most), holds, and falls linearly over the last jerk_s, so the
power's drop at the end of the ramp is spread over jerk_s, not a step. (Measured: with
jerk_s = 0.05 s, `segment` takes the short cruise of 1 m steps at 0.7-0.9 m/s for part of
the acceleration and the idle after it for cruise, 20-40 % of those runs' energy; see
docs/diagnose.md.) The mean of a·v over any ramp from 0 to v in T is v²/(2T), and a
symmetric ramp's mean speed is v/2, so K = 18.4/0.8 = 23 W·s²/m² gives the paper's
acceleration line 23.9 + 14.8·v as the ramp's mean power; cruise is 23.9 + 11.2·v. The
robot stops at once (the paper's robot) unless `decel_phase` is given. Phase boundaries
fall anywhere in continuous time (the motion starts 2 s plus a random fraction of a
sample in); each sample is the mean of 4 sub-samples (an averaging analyser), so edges
are off sample edges and mixed into one sample.

Field realism (always on): white analyser noise 0.8 W per 0.1024 ms, averaged down at
longer periods; 1/f (pink) noise of 0.05 W rms per run; a motor-PWM tone of 1 W near
1 kHz (990-1010 Hz per run, averaged over each sample: A·sinc(f·dt)) while driven;
run-to-run spread: motion power above idle x (1 + N(0, 0.5 %)), idle power + N(0, 0.1 W).

Catalogue causes, other forms (`CATALOGUE`, SIZE in causes.md's unit):
- `speed_quadratic`: k2·v(t)² while driven, over the jerk-limited ramp (whose mean of v² is
  not v²/3) and any stop.
- `start_transient`: an inrush pulse (E/τ)·exp(−t/τ) at each start, τ drawn 20-60 ms per run,
  not cut off at 0.2 s.
- `decel_phase`: an exponential stop v·exp(−t/τ) with τ = SIZE/3 (95 % stopped after SIZE
  seconds), driven at 0.6 W + 0.5·11.2·v(t); the stop's distance comes from the cruise.
- `accel_inertial`: payloads 0 and 3 kg; SIZE·payload·a(t)·v(t) over the jerk-limited ramp.
- `thermal_drift`: motion power above idle x (1 + SIZE·θ), θ [min] the motor-on time
  with a thermal leak: dθ/dt = [driven] − θ/τ_th, τ_th = 20 min (the motors cool in the
  pauses and the heating saturates; not a straight line in accumulated time).
- `cruise_ripple`: wheel eccentricity of a 0.15 m wheel (f = v/(π·0.15)) with a second
  harmonic at 30 %, amplitude following v(t)/v.

Off-catalogue effects (`OFF_CATALOGUE`, default sizes are the ones validated):
- `condition_change`: the floor changes partway through the session (between two runs in
  its middle third): power above idle x (1 + SIZE) from then on (SIZE 0.15).
- `low_speed_extra`: motor drivers lose SIZE W more while driven at the grid's lowest speed
  only (PWM at low duty; SIZE 1.0 W): a threshold, not a curve.
- `speed_resonance`: a chassis resonance at one wheel rate adds SIZE W in cruise only,
  at 0.5 m/s (Gaussian in speed, 0.04 m/s wide; SIZE 1.0 W).
- `heading_hold`: a heading controller engages after 5 s of cruise, SIZE W for the rest of
  each cruise (cruise only, long cruises only; SIZE 0.8 W).
- `intermittent_fault`: a wheel rubs in a random quarter of the motion runs: SIZE W for 3 s
  at a random moment of motion (SIZE 4 W).
- `battery_sag`: the pack's polarisation under motor load: SIZE·(1 − exp(−t_on/30 s)) W
  more while driven, t_on the run's motor-on time (SIZE 2 W).
- `payload_cruise`: rolling resistance grows with the payload's weight: SIZE·payload·v(t)
  W while driven (SIZE 1.0 W/(m/s)/kg); payloads 0 and 3 kg (with their inertia, K's share
  of the payload: 4.6·payload·a·v, which is `accel_inertial`'s physics).

`generate(Batch(...))` returns the runs in memory; `write_batch` writes canonical CSV logs
(log-format.md §1) and a `runs.csv` manifest.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np

IDLE_W = 23.3
DRIVEN_W = 0.6
ROLLING_W_PER_MPS = 11.2
ACCEL_MEAN_MPS2 = 0.8
INERTIAL_K = 18.4 / ACCEL_MEAN_MPS2
PAYLOAD_INERTIAL_K = 4.6
WHEEL_DIAMETER_M = 0.15
OVERSAMPLE = 4
PAPER_PERIOD_S = 0.1024e-3

CATALOGUE = {
    "speed_quadratic": (3.0, 10.0),
    "start_transient": (1.5, 8.0),
    "decel_phase": (0.3, 1.0),
    "accel_inertial": (2.5, 6.0),
    "thermal_drift": (0.01, 0.03),
    "cruise_ripple": (0.5, 2.0),
}
OFF_CATALOGUE = {
    "condition_change": 0.15,
    "low_speed_extra": 1.0,
    "speed_resonance": 1.0,
    "heading_hold": 0.8,
    "intermittent_fault": 4.0,
    "battery_sag": 2.0,
    "payload_cruise": 1.0,
}
PAYLOAD_EFFECTS = ("accel_inertial", "payload_cruise")


@dataclass(frozen=True)
class Batch:
    """A session of runs: the paper's grid thinned to 5 speeds by default, at 1 kHz."""

    speeds_mps: tuple[float, ...] = (0.1, 0.3, 0.5, 0.7, 0.9)
    trips: tuple[tuple[float, int], ...] = ((2.0, 1), (10.0, 1), (10.0, 10))
    repeats: int = 2
    idle_runs: int = 2
    sample_period_s: float = 1e-3
    effects: dict[str, float] = field(default_factory=dict)
    seed: int = 0
    pause_s: float = 60.0
    #: jerk-limited ramps: the acceleration's rise and fall time [s]; 0: constant (module doc)
    jerk_s: float = 0.0

    def payloads(self) -> tuple[float, ...]:
        return (0.0, 3.0) if any(e in self.effects for e in PAYLOAD_EFFECTS) else (0.0,)


@dataclass(frozen=True, eq=False)
class GenRun:
    meta: dict[str, object]
    power_W: np.ndarray
    truth: dict[str, object]


def sizes(kind: str, seed: int) -> float:
    """A catalogue cause's size drawn from its range, or an off-catalogue default."""
    if kind in CATALOGUE:
        low, high = CATALOGUE[kind]
        return float(np.random.default_rng([seed, 7]).uniform(low, high))
    return OFF_CATALOGUE[kind]


def _plan(batch: Batch, rng: np.random.Generator) -> list[dict[str, object]]:
    runs = []
    grid = itertools.product(
        range(1, batch.repeats + 1), batch.speeds_mps, batch.trips, batch.payloads()
    )
    for repeat, v, (d, n), p in grid:
        pay = f"_p{p:g}" if p else ""
        runs.append(
            dict(
                run_id=f"v{v:.2f}_d{d:g}_s{n}{pay}_r{repeat}",
                mode="motion",
                speed_mps=v,
                distance_m=d,
                steps=n,
                payload_kg=p,
            )
        )
    runs += [dict(run_id=f"idle_r{i + 1}", mode="idle") for i in range(batch.idle_runs)]
    return [runs[i] for i in rng.permutation(len(runs))]


def generate(batch: Batch) -> list[GenRun]:
    """Every run of the session, in session order (module docstring)."""
    unknown = set(batch.effects) - set(CATALOGUE) - set(OFF_CATALOGUE)
    if unknown:
        raise ValueError(f"unknown effects {sorted(unknown)}")
    rng = np.random.default_rng([batch.seed, 1])
    plan = _plan(batch, rng)
    lowest = min(batch.speeds_mps)
    n_motion = sum(r["mode"] == "motion" for r in plan)
    change_at = int(rng.integers(len(plan) // 3, 2 * len(plan) // 3))
    faulty = set(rng.choice(n_motion, size=max(1, n_motion // 4), replace=False).tolist())
    clock = datetime(2016, 3, 1, 10, 0, 0, tzinfo=UTC)
    theta_min = 0.0  # thermal state: leaky motor-on minutes
    out = []
    motion_index = 0
    for order, spec in enumerate(plan):
        run_rng = np.random.default_rng([batch.seed, 2, order])
        context = dict(
            lowest=lowest,
            changed=order >= change_at,
            faulty=spec["mode"] == "motion" and motion_index in faulty,
            theta_min=theta_min,
        )
        if spec["mode"] == "motion":
            motion_index += 1
        run = _one_run(batch, spec, run_rng, context)
        run.meta["started_at"] = clock
        out.append(run)
        duration_s = run.power_W.size * batch.sample_period_s
        theta_min = run.truth["theta_end_min"] * np.exp(-batch.pause_s / 60.0 / 20.0)
        clock += timedelta(seconds=float(np.ceil(duration_s + batch.pause_s)))
    return out


def _one_run(
    batch: Batch, spec: dict[str, object], rng: np.random.Generator, context: dict
) -> GenRun:
    dt = batch.sample_period_s
    effects = batch.effects
    sub_dt = dt / OVERSAMPLE
    if spec["mode"] != "motion":
        n = int(round(10.0 / dt))
        t = (np.arange(n * OVERSAMPLE) + 0.5) * sub_dt
        power = np.full(t.size, IDLE_W)
        driven = np.zeros(t.size, dtype=bool)
        truth = {"motion_energy_J": 0.0, "theta_end_min": context["theta_min"]}
        return _realise(batch, spec, rng, t, power, driven, truth)

    v, d, n_steps = float(spec["speed_mps"]), float(spec["distance_m"]), int(spec["steps"])
    payload = float(spec["payload_kg"])
    t_acc = v / ACCEL_MEAN_MPS2
    tau_stop = effects["decel_phase"] / 3.0 if "decel_phase" in effects else 0.0
    stop_s = 5.0 * tau_stop
    step_m = d / n_steps
    cruise_s = (step_m - v * t_acc / 2 - v * tau_stop) / v
    if cruise_s <= 0:
        raise ValueError(f"{step_m} m at {v} m/s is too short")
    lead_s = 2.0 + rng.uniform(0, dt)  # off the sample grid
    step_s = t_acc + cruise_s + stop_s
    total_s = lead_s + n_steps * step_s + (n_steps - 1) * 2.0 + 2.0
    n = int(np.ceil(total_s / dt))
    t = (np.arange(n * OVERSAMPLE) + 0.5) * sub_dt
    speed = np.zeros(t.size)
    accel = np.zeros(t.size)
    phase = np.zeros(t.size, dtype=np.int8)  # 0 still, 1 accel, 2 cruise, 3 stop
    since_start = np.full(t.size, np.inf)
    in_cruise_s = np.zeros(t.size)
    starts = []
    for k in range(n_steps):
        t0 = lead_s + k * (step_s + 2.0)
        starts.append(t0)
        tau = t - t0
        ramp = (tau >= 0) & (tau < t_acc)
        speed[ramp], accel[ramp] = _jerk_limited(tau[ramp], t_acc, v, batch.jerk_s)
        phase[ramp] = 1
        cruise = (t >= t0 + t_acc) & (t < t0 + t_acc + cruise_s)
        speed[cruise] = v
        phase[cruise] = 2
        in_cruise_s[cruise] = t[cruise] - (t0 + t_acc)
        if stop_s:
            t_end = t0 + t_acc + cruise_s
            stop = (t >= t_end) & (t < t_end + stop_s)
            speed[stop] = v * np.exp(-(t[stop] - t_end) / tau_stop)
            accel[stop] = -speed[stop] / tau_stop
            phase[stop] = 3
        after = t >= t0
        since_start[after] = t[after] - t0
    driven = phase > 0
    motion_W = DRIVEN_W * driven + ROLLING_W_PER_MPS * speed * (phase < 3)
    motion_W += 0.5 * ROLLING_W_PER_MPS * speed * (phase == 3)
    motion_W += INERTIAL_K * accel * speed * (phase == 1)
    k_payload = effects.get("accel_inertial", PAYLOAD_INERTIAL_K)
    motion_W += k_payload * payload * accel * speed * (phase == 1)

    # catalogue causes in their other forms
    if "speed_quadratic" in effects:
        motion_W += effects["speed_quadratic"] * speed**2 * driven
    if "start_transient" in effects:
        tau = rng.uniform(0.02, 0.06)
        for t0 in starts:
            after = (t >= t0) & (t < t0 + 10 * tau)
            motion_W[after] += effects["start_transient"] / tau * np.exp(-(t[after] - t0) / tau)
    if "cruise_ripple" in effects:
        angle = 2.0 * np.cumsum(speed) * sub_dt / WHEEL_DIAMETER_M + rng.uniform(0, 2 * np.pi)
        shape = np.sin(angle) + 0.3 * np.sin(2 * angle + rng.uniform(0, 2 * np.pi))
        motion_W += effects["cruise_ripple"] * speed / v * shape * driven

    # off-catalogue effects
    if "condition_change" in effects and context["changed"]:
        motion_W *= 1.0 + effects["condition_change"]
    if "low_speed_extra" in effects and v <= context["lowest"] + 1e-9:
        motion_W += effects["low_speed_extra"] * driven
    if "speed_resonance" in effects:
        weight = np.exp(-0.5 * ((v - 0.5) / 0.04) ** 2)
        motion_W += effects["speed_resonance"] * weight * (phase == 2)
    if "heading_hold" in effects:
        motion_W += effects["heading_hold"] * ((phase == 2) & (in_cruise_s > 5.0))
    if "battery_sag" in effects:
        t_on = np.cumsum(driven) * sub_dt
        motion_W += effects["battery_sag"] * (1 - np.exp(-t_on / 30.0)) * driven
    if "payload_cruise" in effects:
        motion_W += effects["payload_cruise"] * payload * speed * driven
    if "intermittent_fault" in effects and context["faulty"]:
        on_idx = np.flatnonzero(driven)
        begin = t[on_idx[int(rng.integers(0, on_idx.size))]]
        burst = (t >= begin) & (t < begin + 3.0) & driven
        motion_W += effects["intermittent_fault"] * burst

    # thermal drift with a time constant: theta' = driven - theta / tau_th (exact, vectorised)
    tau_th_min = 20.0
    t_min = t / 60.0
    grow = np.cumsum(driven * np.exp(t_min / tau_th_min)) * sub_dt / 60.0
    theta = np.exp(-t_min / tau_th_min) * (context["theta_min"] + grow)
    if "thermal_drift" in effects:
        motion_W *= 1.0 + effects["thermal_drift"] * theta
    truth = {
        "t_acc_s": t_acc,
        "tau_stop_s": tau_stop,
        "theta_end_min": float(theta[-1]),
        "phase_starts_s": starts,
    }
    return _realise(batch, spec, rng, t, IDLE_W + motion_W, driven, truth)


def _jerk_limited(
    tau: np.ndarray, t_acc: float, v: float, jerk_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """Speed and acceleration of a ramp from 0 to v in t_acc. With jerk_s > 0 the
    acceleration rises linearly over the first jerk_s (at most a quarter of the ramp),
    holds, and falls linearly over the last (a trapezoidal acceleration, as motor
    controllers command it); with 0, it is constant (the paper's ramp)."""
    if jerk_s <= 0:
        return v * tau / t_acc, np.full(tau.size, v / t_acc)
    tj = min(jerk_s, t_acc / 4)
    peak = v / (t_acc - tj)
    rise, fall = tau < tj, tau >= t_acc - tj
    hold = ~rise & ~fall
    accel = np.where(rise, peak * tau / tj, np.where(fall, peak * (t_acc - tau) / tj, peak))
    speed = np.empty_like(tau)
    speed[rise] = peak * tau[rise] ** 2 / (2 * tj)
    speed[hold] = peak * tj / 2 + peak * (tau[hold] - tj)
    speed[fall] = v - peak * (t_acc - tau[fall]) ** 2 / (2 * tj)
    return speed, accel


def _realise(
    batch: Batch,
    spec: dict[str, object],
    rng: np.random.Generator,
    t: np.ndarray,
    power_W: np.ndarray,
    driven: np.ndarray,
    truth: dict,
) -> GenRun:
    """Field realism, then the analyser's averaging of 4 sub-samples per sample."""
    dt = batch.sample_period_s
    sub_dt = dt / OVERSAMPLE
    spread = rng.normal(0, 0.005) if spec["mode"] == "motion" else 0.0
    power_W = IDLE_W + (power_W - IDLE_W) * (1 + spread) + rng.normal(0, 0.1)
    truth["motion_energy_J"] = float(power_W[driven].sum() * sub_dt)
    samples = power_W.reshape(-1, OVERSAMPLE).mean(axis=1)
    moving = driven.reshape(-1, OVERSAMPLE).mean(axis=1)
    n = samples.size
    pwm_hz = rng.uniform(990, 1010)
    t_mid = (np.arange(n) + 0.5) * dt
    samples += (
        moving * np.sinc(pwm_hz * dt) * np.sin(2 * np.pi * pwm_hz * t_mid + rng.uniform(0, 6.3))
    )
    samples += rng.normal(0, 0.8 * np.sqrt(PAPER_PERIOD_S / dt), n)
    samples += _pink(rng, n, 0.05)
    meta = {k: spec.get(k) for k in ("run_id", "mode", "speed_mps", "distance_m", "steps")}
    meta["payload_kg"] = spec.get("payload_kg", 0.0)
    meta["sample_period_s"] = dt
    return GenRun(meta, samples, truth)


def _pink(rng: np.random.Generator, n: int, rms_W: float) -> np.ndarray:
    """1/f noise of the given rms: white noise shaped by 1/sqrt(f) in frequency."""
    spectrum = np.fft.rfft(rng.standard_normal(n))
    f = np.arange(spectrum.size, dtype=np.float64)
    f[0] = 1.0
    spectrum /= np.sqrt(f)
    spectrum[0] = 0.0
    x = np.fft.irfft(spectrum, n)
    return x * rms_W / max(float(x.std()), 1e-12)


def to_runs(generated: list[GenRun]):
    """The runs as `wifibot_power.run.Run` objects (what `diagnose_runs` takes)."""
    from wifibot_power.io.options import FORMAT_CANONICAL
    from wifibot_power.run import Run, RunMeta

    runs = []
    for g in generated:
        m = g.meta
        meta = RunMeta(
            run_id=m["run_id"],
            mode=m["mode"],
            speed_mps=m["speed_mps"],
            distance_m=m["distance_m"],
            steps=m["steps"] if m["steps"] is not None else 1,
            payload_kg=m["payload_kg"],
            started_at=m["started_at"],
            sample_period_s=m["sample_period_s"],
        )
        time_s = np.arange(g.power_W.size) * m["sample_period_s"]
        runs.append(Run(f"{m['run_id']}.csv", FORMAT_CANONICAL, meta, time_s, g.power_W))
    return runs


def write_batch(generated: list[GenRun], out_dir: Path) -> Path:
    """Canonical CSV logs (power only, sample period in the metadata) and runs.csv."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    manifest = ["file,run_id,mode,speed_mps,distance_m,steps,payload_kg,started_at"]
    for g in generated:
        m = g.meta
        started = m["started_at"].strftime("%Y-%m-%dT%H:%M:%SZ")
        header = [
            "# wbpower-log: 1",
            f"# run_id: {m['run_id']}",
            f"# mode: {m['mode']}",
            f"# started_at: {started}",
            f"# sample_period_s: {m['sample_period_s']:g}",
        ]
        name = f"{m['run_id']}.csv"
        with open(out_dir / name, "w", encoding="utf-8", newline="\n") as f:
            f.write("\n".join(header) + "\npower_W\n")
            np.savetxt(f, g.power_W, fmt="%.4f")
        motion = m["mode"] == "motion"
        cells = [
            name,
            str(m["run_id"]),
            str(m["mode"]),
            f"{m['speed_mps']:g}" if motion else "",
            f"{m['distance_m']:g}" if motion else "",
            str(m["steps"]) if motion else "",
            f"{m['payload_kg']:g}" if motion else "",
            started,
        ]
        manifest.append(",".join(cells))
    (out_dir / "runs.csv").write_text("\n".join(manifest) + "\n", encoding="utf-8")
    return out_dir
