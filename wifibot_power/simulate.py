"""A physical model of the Wifibot that writes analyser logs with known truth.

Not a curve fit: the power drawn is built from the robot's physics, sample by sample
(vectorised), for a commanded trapezoidal speed profile:

    P(t) = P_idle + P_drive·[moving] + c_roll·v(t) + kI·(m + payload)·a(t)·v(t)·[accelerating]
           (+ the terms of the effects of causes.md) + analyser noise

- P_idle = 23.3 W: embedded system (paper Table 1, idle).
- P_drive = 0.6 W: motor drivers switched on while moving; the paper's intercepts 23.9 W minus idle.
- c_roll = 11.2 W/(m/s): rolling and drivetrain friction F_roll/η, the paper's cruise slope (Eq. 4).
- inertial power m·a·v/η (Newton's second law, power = force × speed, through a drivetrain of
  efficiency η): with m = 4 kg and a = 1 m/s², kI = 1/η = 4.6 makes the acceleration-phase mean
  23.9 + (11.2 + kI·m·a)/2·v = 23.9 + 14.8 v, the paper's Eq. 2 (mean of a linear ramp is v/2).

So with no effect the phase averages follow the paper's lines by construction of the physics,
and each effect of causes.md adds its own physical term. `truth` records the true parameters,
phase boundaries and motion energy of each run.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np

from wifibot_power.causes import CAUSES, SimTrace, ordered
from wifibot_power.errors import UsageError
from wifibot_power.io.manifest import MANIFEST_HEADER, manifest_line
from wifibot_power.io.options import FORMAT_CANONICAL
from wifibot_power.io.writer import format_log, write_log
from wifibot_power.outputs import write_json, write_text
from wifibot_power.run import PAPER_SAMPLE_PERIOD_S, Run, RunMeta


#: causes.md: name -> (unit of SIZE, default SIZE when only the name is given, realistic
#: range), read from the registry (`wifibot_power.causes`)
class _Effects(Mapping):
    """A live view of the registry: a cause registered later is an effect too."""

    def __getitem__(self, name: str) -> tuple[str, float, tuple[float, float]]:
        cause = CAUSES[name]
        return (cause.unit, cause.default_size, tuple(cause.realistic_range))

    def __iter__(self):
        return iter(CAUSES)

    def __len__(self) -> int:
        return len(CAUSES)


EFFECTS: Mapping[str, tuple[str, float, tuple[float, float]]] = _Effects()

#: `--realism`: what the analyser and the robot add beyond the effects (docs/simulator.md).
#: "lab" is the clean robot of the tests; "field" is what real logs carry: 0.8 W rms analyser
#: noise at 10 kHz, a 1 W motor-PWM tone near 1 kHz while the motors are driven, 0.5 % run-to-run
#: spread of motion power and 0.1 W run-to-run spread of idle power.
REALISM: dict[str, dict[str, float]] = {
    "lab": {
        "noise_W": 0.3,
        "pwm_tone_W": 0.0,
        "pwm_hz": 1050.0,
        "motion_spread_rel": 0.0,
        "idle_spread_W": 0.0,
    },
    "field": {
        "noise_W": 0.8,
        "pwm_tone_W": 1.0,
        "pwm_hz": 1050.0,
        "motion_spread_rel": 0.005,
        "idle_spread_W": 0.1,
    },
}

PAPER_SPEEDS_MPS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)
PAPER_TRIPS = ((2.0, 1), (10.0, 1), (10.0, 10))
#: paper Table 1: component powers net of idle [W]
MODE_POWERS_W = {"idle": 0.0, "network": 4.4, "video": 2.5, "cpu": 2.1}
SESSION_START = datetime(2015, 6, 1, 9, 0, 0, tzinfo=UTC)


@dataclass(frozen=True)
class RobotParams:
    """The simulated Wifibot (see the module docstring for where each number comes from)."""

    mass_kg: float = 4.0
    idle_W: float = 23.3
    drive_on_W: float = 0.6
    rolling_W_per_mps: float = 11.2
    accel_mps2: float = 1.0
    inertial_k: float = 4.6
    wheel_diameter_m: float = 0.13
    supply_V: float = 12.8
    internal_resistance_ohm: float = 0.02
    start_transient_tau_s: float = 0.05
    start_transient_window_s: float = 0.2
    decel_power_fraction: float = 0.5

    @property
    def ripple_hz_per_mps(self) -> float:
        """Wheel rotation frequency per unit speed: f = v / (π·d) [Hz per m/s]."""
        return 1.0 / (np.pi * self.wheel_diameter_m)


@dataclass(frozen=True)
class SimConfig:
    """What to simulate. Defaults: the paper's experiment grid at the paper's sample rate."""

    speeds_mps: tuple[float, ...] = PAPER_SPEEDS_MPS
    trips: tuple[tuple[float, int], ...] = PAPER_TRIPS
    repeats: int = 3
    payloads_kg: tuple[float, ...] | None = None
    modes: tuple[str, ...] = ("idle", "network", "video", "cpu")
    mode_repeats: int = 2
    mode_duration_s: float = 10.0
    sample_period_s: float = PAPER_SAMPLE_PERIOD_S
    #: white analyser noise, standard deviation per 0.1024 ms sample [W] (averaged over longer ones)
    noise_W: float = 0.3
    #: motor-PWM tone while the motors are driven: amplitude [W] and frequency [Hz]
    pwm_tone_W: float = 0.0
    pwm_hz: float = 1050.0
    #: run-to-run spread: motion power above idle x (1 + N(0, rel)), idle power + N(0, W)
    motion_spread_rel: float = 0.0
    idle_spread_W: float = 0.0
    effects: dict[str, float] = field(default_factory=dict)
    seed: int = 0
    idle_before_s: float = 2.0
    idle_between_s: float = 2.0
    idle_after_s: float = 2.0
    pause_between_runs_s: float = 60.0
    robot: RobotParams = field(default_factory=RobotParams)

    def payloads(self) -> tuple[float, ...]:
        if self.payloads_kg is not None:
            return self.payloads_kg
        # an effect only visible across payloads (its cause says so) adds them to the grid
        for name in ordered(self.effects):
            if CAUSES[name].grid_payloads_kg is not None:
                return CAUSES[name].grid_payloads_kg
        return (0.0,)


@dataclass(frozen=True, eq=False)
class SimRun:
    """A simulated run and its truth (true phase boundaries, parameters, energies)."""

    run: Run
    truth: dict[str, object]
    voltage_V: np.ndarray


def realism(name: str) -> dict[str, float]:
    """The `SimConfig` keyword arguments of a realism level (`REALISM`): `lab` or `field`."""
    if name not in REALISM:
        raise UsageError(f"unknown realism '{name}'", fix=f"use one of: {', '.join(REALISM)}")
    return dict(REALISM[name])


def parse_effects(specs: list[str]) -> dict[str, float]:
    """`NAME[=SIZE]` strings -> {name: size}; unknown names are a usage error."""
    effects: dict[str, float] = {}
    for spec in specs:
        name, _, size = spec.partition("=")
        name = name.strip()
        if name not in EFFECTS:
            raise UsageError(f"unknown effect '{name}'", fix=f"use one of: {', '.join(EFFECTS)}")
        try:
            effects[name] = float(size) if size else EFFECTS[name][1]
        except ValueError:
            raise UsageError(
                f"effect size '{size}' is not a number",
                fix=f"write {name}=SIZE in {EFFECTS[name][0]}",
            ) from None
        if effects[name] < 0:
            raise UsageError(f"effect size {size} is negative", fix="sizes are >= 0")
    return effects


@dataclass(frozen=True)
class _RunSpec:
    run_id: str
    mode: str
    speed_mps: float | None = None
    distance_m: float | None = None
    steps: int = 1
    payload_kg: float = 0.0
    repeat: int = 1


def plan_runs(config: SimConfig) -> list[_RunSpec]:
    """The grid, in session order (seeded shuffle, so session order is independent of speed)."""
    specs: list[_RunSpec] = []
    for repeat in range(1, config.repeats + 1):
        for speed in config.speeds_mps:
            for distance, steps in config.trips:
                for payload in config.payloads():
                    pay = f"_p{payload:g}" if payload else ""
                    specs.append(
                        _RunSpec(
                            f"v{speed:.2f}_d{distance:g}_s{steps}{pay}_r{repeat}",
                            "motion",
                            float(speed),
                            float(distance),
                            int(steps),
                            float(payload),
                            repeat,
                        )
                    )
    for repeat in range(1, config.mode_repeats + 1):
        for mode in config.modes:
            specs.append(_RunSpec(f"{mode}_r{repeat}", mode, repeat=repeat))
    order = np.random.default_rng([config.seed, 1]).permutation(len(specs))
    return [specs[i] for i in order]


def simulate_runs(config: SimConfig | None = None) -> list[SimRun]:
    """Every run of the grid, in memory (use `write_simulation` for large grids)."""
    return list(iter_simulation(config or SimConfig()))


def iter_simulation(config: SimConfig):
    """Yield the runs one at a time, in session order, so memory holds one run."""
    for name in config.effects:
        if name not in EFFECTS:
            raise UsageError(f"unknown effect '{name}'", fix=f"use one of: {', '.join(EFFECTS)}")
    motor_on_min = 0.0
    clock = SESSION_START
    for order, spec in enumerate(plan_runs(config)):
        rng = np.random.default_rng([config.seed, 2, order])
        sim = _simulate_one(spec, config, rng, motor_on_min, clock, order)
        motor_on_min += float(sim.truth["motor_on_s"]) / 60.0
        # runs start on whole seconds, a pause apart
        clock += timedelta(seconds=float(np.ceil(sim.run.duration_s + config.pause_between_runs_s)))
        yield sim


def _profile(
    spec: _RunSpec, config: SimConfig
) -> tuple[list[tuple[str, int, int, float, float]], float, float]:
    """Phase plan in samples: (phase, step, n_samples, v_start, v_end), plus t_acc and t_dec [s]."""
    dt = config.sample_period_s
    robot = config.robot
    t_acc_s = spec.speed_mps / robot.accel_mps2
    t_dec_s = sum(
        CAUSES[name].stop_time_s(CAUSES[name].sim_parameters(size))
        for name, size in config.effects.items()
    )
    step_m = spec.distance_m / spec.steps
    cruise_m = step_m - spec.speed_mps * t_acc_s / 2 - spec.speed_mps * t_dec_s / 2
    if cruise_m <= 0:
        raise UsageError(
            f"a {step_m:g} m step at {spec.speed_mps:g} m/s is too short to reach the speed",
            fix="use longer steps or a lower speed",
        )
    n_acc = round(t_acc_s / dt)
    n_cruise = round(cruise_m / spec.speed_mps / dt)
    n_dec = round(t_dec_s / dt)
    plan = [("idle", 0, round(config.idle_before_s / dt), 0.0, 0.0)]
    for step in range(1, spec.steps + 1):
        plan.append(("accel", step, n_acc, 0.0, spec.speed_mps))
        plan.append(("cruise", step, n_cruise, spec.speed_mps, spec.speed_mps))
        if n_dec:
            plan.append(("decel", step, n_dec, spec.speed_mps, 0.0))
        rest = config.idle_between_s if step < spec.steps else config.idle_after_s
        plan.append(("idle", step, round(rest / dt), 0.0, 0.0))
    return plan, n_acc * dt, n_dec * dt


def _simulate_one(
    spec: _RunSpec,
    config: SimConfig,
    rng: np.random.Generator,
    motor_on_min: float,
    started_at: datetime,
    order: int,
) -> SimRun:
    dt = config.sample_period_s
    robot = config.robot
    effects = config.effects
    if spec.mode != "motion":
        n = round(config.mode_duration_s / dt)
        clean_W = np.full(n, robot.idle_W + MODE_POWERS_W.get(spec.mode, 0.0))
        phases = [{"step": 0, "phase": "idle", "t_start_s": 0.0, "t_end_s": n * dt}]
        truth = {"mode_power_W": float(clean_W[0]), "motion_energy_J": 0.0, "motor_on_s": 0.0}
        return _finish(spec, config, rng, clean_W, phases, truth, started_at, order, None)

    plan, t_acc_s, t_dec_s = _profile(spec, config)
    speed, accel, kind, bounds = _plan_samples(plan, dt)
    moving = kind > 0
    accelerating = kind == 1
    mass_kg = robot.mass_kg
    # inertial power of the robot's own mass and its payload (kI = 1/eta, calibrated)
    motion_W = (
        robot.drive_on_W * moving
        + robot.rolling_W_per_mps * speed * ((kind == 1) | (kind == 2))
        + robot.decel_power_fraction * robot.rolling_W_per_mps * speed * (kind == 3)
        + accelerating * robot.inertial_k * (mass_kg + spec.payload_kg) * accel * speed
    )
    # each effect adds its own physical term (its cause's `inject`), multiplicative ones last
    trace = SimTrace(
        motion_W=motion_W,
        speed_mps=speed,
        accel_mps2=accel,
        kind=kind,
        plan=plan,
        bounds=bounds,
        dt_s=dt,
        target_speed_mps=spec.speed_mps,
        payload_kg=spec.payload_kg,
        motor_on_before_min=motor_on_min,
        robot=robot,
        rng=rng,
    )
    effect_truth: dict[str, object] = {}
    for name in sorted(ordered(effects), key=lambda c: CAUSES[c].inject_order):
        effect_truth.update(CAUSES[name].inject(effects[name], trace))
    motion_W = trace.motion_W
    clean_W = robot.idle_W + motion_W

    phases = _plan_phases(plan, bounds, dt)
    moving_energy_J = float(clean_W[moving].sum() * dt)
    truth = {
        "t_acc_s": t_acc_s,
        "t_dec_s": t_dec_s,
        "accel_mps2": robot.accel_mps2,
        "motion_energy_J": moving_energy_J,
        "accel_mean_power_W": float(clean_W[kind == 1].mean()),
        "cruise_mean_power_W": float(clean_W[kind == 2].mean()),
        "decel_mean_power_W": float(clean_W[kind == 3].mean()) if (kind == 3).any() else None,
        "motor_on_s": float(moving.sum() * dt),
        "motor_on_before_run_min": motor_on_min,
    }
    truth.update(effect_truth)
    return _finish(spec, config, rng, clean_W, phases, truth, started_at, order, moving)


def _plan_samples(
    plan: list[tuple[str, int, int, float, float]], dt: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A run's plan (`_profile`: name, step, sample count, v0, v1 per stretch) sampled
    every `dt` [s]: speed [m/s] at the middle of each sample of each linear ramp, its
    acceleration [m/s^2], its kind (0 idle, 1 accel, 2 cruise, 3 decel) and the stretches'
    sample bounds."""
    counts = np.array([p[2] for p in plan])
    n = int(counts.sum())
    bounds = np.concatenate(([0], np.cumsum(counts)))
    speed = np.zeros(n)
    accel = np.zeros(n)
    kind = np.zeros(n, dtype=np.int8)  # 0 idle, 1 accel, 2 cruise, 3 decel
    codes = {"idle": 0, "accel": 1, "cruise": 2, "decel": 3}
    for (name, _, count, v0, v1), start in zip(plan, bounds[:-1], strict=True):
        if count == 0:
            continue
        # speed at the middle of each sample of a linear ramp from v0 to v1
        frac = (np.arange(count) + 0.5) / count
        speed[start : start + count] = v0 + (v1 - v0) * frac
        accel[start : start + count] = (v1 - v0) / (count * dt)
        kind[start : start + count] = codes[name]
    return speed, accel, kind, bounds


def _plan_phases(
    plan: list[tuple[str, int, int, float, float]], bounds: np.ndarray, dt: float
) -> list[dict]:
    """The true phases of a run's plan (its non-empty stretches), times in [s]."""
    return [
        {
            "step": step,
            "phase": name,
            "t_start_s": float(start * dt),
            "t_end_s": float((start + count) * dt),
        }
        for (name, step, count, _, _), start in zip(plan, bounds[:-1], strict=True)
        if count
    ]


def _finish(
    spec: _RunSpec,
    config: SimConfig,
    rng: np.random.Generator,
    clean_W: np.ndarray,
    phases: list[dict],
    truth: dict,
    started_at: datetime,
    order: int,
    moving: np.ndarray | None,
) -> SimRun:
    dt = config.sample_period_s
    robot = config.robot
    clean_W = _field_realism(spec, config, clean_W, truth, order, moving)
    # an averaging analyser: noise of a longer sample period is the mean of 0.1024 ms samples
    sigma_W = config.noise_W * np.sqrt(PAPER_SAMPLE_PERIOD_S / dt)
    power_W = clean_W + rng.normal(0.0, sigma_W, clean_W.size) if sigma_W > 0 else clean_W.copy()
    voltage_V = robot.supply_V - robot.internal_resistance_ohm * power_W / robot.supply_V
    meta = RunMeta(
        run_id=spec.run_id,
        mode=spec.mode,
        speed_mps=spec.speed_mps,
        distance_m=spec.distance_m,
        steps=spec.steps,
        payload_kg=spec.payload_kg,
        started_at=started_at,
        sample_period_s=dt,
    )
    run = Run(
        file=f"{spec.run_id}.csv",
        format=FORMAT_CANONICAL,
        meta=meta,
        stamps_s=None,  # evenly spaced from 0 at dt (`Run.time_s`)
        power_W=power_W,
    )
    full_truth = {
        "run_id": spec.run_id,
        "mode": spec.mode,
        "speed_mps": spec.speed_mps,
        "distance_m": spec.distance_m,
        "steps": spec.steps,
        "payload_kg": spec.payload_kg,
        "repeat": spec.repeat,
        "session_order": order,
        "started_at": started_at.isoformat().replace("+00:00", "Z"),
        "energy_J": float(clean_W.sum() * dt),
        **truth,
        "phases": phases,
    }
    return SimRun(run=run, truth=full_truth, voltage_V=voltage_V)


def _field_realism(
    spec: _RunSpec,
    config: SimConfig,
    clean_W: np.ndarray,
    truth: dict,
    order: int,
    moving: np.ndarray | None,
) -> np.ndarray:
    """What a real robot and analyser add once the effects are in (docs/simulator.md):
    run-to-run spread of motion power (x (1 + e), on the power above idle) and of idle power
    (+ d, every sample), and the motor-PWM tone while the motors are driven. The spread is
    real energy, so the truth's energies include it; the tone averages out over a run. Its
    own random stream: the analyser noise of a seed is the same with or without it."""
    if not (config.motion_spread_rel or config.idle_spread_W or config.pwm_tone_W):
        return clean_W
    rng = np.random.default_rng([config.seed, 3, order])
    spread_rel = rng.normal(0.0, config.motion_spread_rel) if config.motion_spread_rel else 0.0
    idle_offset_W = rng.normal(0.0, config.idle_spread_W) if config.idle_spread_W else 0.0
    robot = config.robot
    if spec.mode == "motion":
        clean_W = robot.idle_W + (clean_W - robot.idle_W) * (1.0 + spread_rel)
    clean_W = clean_W + idle_offset_W
    truth["motion_spread_rel"] = spread_rel
    truth["idle_offset_W"] = idle_offset_W
    dt = config.sample_period_s
    if moving is not None:
        truth["motion_energy_J"] = float(clean_W[moving].sum() * dt)
        for key in ("accel_mean_power_W", "cruise_mean_power_W", "decel_mean_power_W"):
            if truth.get(key) is not None:
                above_W = truth[key] - robot.idle_W
                truth[key] = robot.idle_W + above_W * (1.0 + spread_rel) + idle_offset_W
    if spec.mode != "motion":
        truth["mode_power_W"] = float(clean_W[0])
    if config.pwm_tone_W and moving is not None:
        # an averaging analyser reports the mean of A·sin(2π f t + φ) over each sample period
        # T: A·sinc(f T)·sin(2π f t_mid + φ), t_mid the sample's middle. Evaluated at the
        # sample middles, the tone aliases as a real analyser's does (f above the Nyquist
        # frequency folds back), and averaging over T attenuates it by sinc(f T).
        t_mid_s = (np.arange(clean_W.size) + 0.5) * dt
        phase0 = rng.uniform(0.0, 2 * np.pi)
        amplitude_W = config.pwm_tone_W * np.sinc(config.pwm_hz * dt)
        clean_W = clean_W + moving * amplitude_W * np.sin(
            2 * np.pi * config.pwm_hz * t_mid_s + phase0
        )
    return clean_W


def true_parameters(config: SimConfig) -> dict[str, object]:
    """The robot's true model parameters, in the names `fit` and `diagnose` report."""
    robot = config.robot
    kI_m_a = robot.inertial_k * robot.mass_kg * robot.accel_mps2
    return {
        "idle_W": robot.idle_W,
        "accel": {
            "intercept_W": robot.idle_W + robot.drive_on_W,
            "slope_W_per_mps": (robot.rolling_W_per_mps + kI_m_a) / 2,
        },
        "cruise": {
            "intercept_W": robot.idle_W + robot.drive_on_W,
            "slope_W_per_mps": robot.rolling_W_per_mps,
        },
        "t_acc": {"intercept_s": 0.0, "slope_s_per_mps": 1.0 / robot.accel_mps2},
        "components_W": {m: p for m, p in MODE_POWERS_W.items() if m != "idle"},
        "effects": dict(config.effects),
        "ripple_hz_per_mps": robot.ripple_hz_per_mps,
        "robot": asdict(robot),
    }


#: `--compress` value -> the log files' suffix (the readers decompress by suffix)
COMPRESSIONS = {"none": ".csv", "gz": ".csv.gz", "zst": ".csv.zst"}
#: `--columns` value -> what each log holds
COLUMN_SETS = ("full", "power")


@dataclass(frozen=True)
class WriteOptions:
    """How logs are written: the paper's full canonical columns by default."""

    columns: str = "full"  # "full": time_s, voltage_V, current_A, power_W; "power": power_W only
    compress: str = "none"  # "none", "gz" or "zst" (COMPRESSIONS)
    decimals: int = 4

    def __post_init__(self) -> None:
        if self.columns not in COLUMN_SETS:
            raise UsageError(
                f"--columns {self.columns!r} is not known", fix=f"give {'|'.join(COLUMN_SETS)}"
            )
        if self.compress not in COMPRESSIONS:
            raise UsageError(
                f"--compress {self.compress!r} is not known", fix=f"give {'|'.join(COMPRESSIONS)}"
            )


#: How one simulated run becomes a log: (its metadata, power [W], voltage [V]) -> (the file
#: name's suffix, the log's uncompressed bytes); `write_log` compresses by the suffix.
Render = Callable[[RunMeta, np.ndarray, np.ndarray], tuple[str, bytes]]


def write_simulation(
    config: SimConfig,
    out_dir: Path,
    write: WriteOptions | None = None,
    *,
    render: Render | None = None,
    generator: str = "wbpower simulate",
    on_run: Callable[[int, int], None] | None = None,
) -> dict[str, object]:
    """Write every run as a canonical log, plus `runs.csv` (manifest) and `truth.json`.

    `render` writes each run in another layout instead (`benchmarks/corpora.py`: an N6705
    export, voltage and current only, ...); `generator` names the writer in truth.json;
    `on_run(k, n)` is called as run k of n begins (the command's progress line)."""
    write = write or WriteOptions()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    render = render or _canonical(write)
    manifest = [MANIFEST_HEADER]
    runs_truth = []
    total_bytes = 0
    n_runs = len(plan_runs(config)) if on_run is not None else 0
    for k, sim in enumerate(iter_simulation(config), start=1):
        if on_run is not None:
            on_run(k, n_runs)
        meta = sim.run.meta
        suffix, data = render(meta, sim.run.power_W, sim.voltage_V)
        name = f"{meta.run_id}{suffix}"
        write_log(out_dir / name, data)
        total_bytes += len(data)
        manifest.append(manifest_line(name, meta, str(sim.truth["started_at"])))
        runs_truth.append({"file": name, **sim.truth})
    write_text(out_dir / "runs.csv", "\n".join(manifest) + "\n")
    truth = {
        "generator": generator,
        "seed": config.seed,
        "sample_period_s": config.sample_period_s,
        "noise_W": config.noise_W,
        "realism": {k: getattr(config, k) for k in REALISM["lab"]},
        "parameters": true_parameters(config),
        "runs": runs_truth,
    }
    write_json(out_dir / "truth.json", truth)
    return {
        "out_dir": str(out_dir),
        "runs": len(runs_truth),
        "csv_bytes": total_bytes,
        "effects": dict(config.effects),
        "seed": config.seed,
    }


def _canonical(write: WriteOptions) -> Render:
    """The canonical log (log-format.md §1) with `write`'s columns and decimals."""
    suffix = COMPRESSIONS[write.compress]

    def render(meta: RunMeta, power_W: np.ndarray, voltage_V: np.ndarray) -> tuple[str, bytes]:
        full = write.columns == "full"
        data = format_log(
            meta,
            power_W,
            voltage_V=voltage_V if full else None,
            time_column=full,
            decimals=write.decimals,
        )
        return suffix, data

    return render


def load_truth(path: Path) -> dict[str, object]:
    """Read a `truth.json` (for scoring in tests and benchmarks, never inside `diagnose`)."""
    return json.loads(Path(path).read_text(encoding="utf-8"))
