"""Realistic motor logs with known truth, for segmentation tests (not the simulator's
Wifibot-shaped runs, and written apart from segment.py's assumptions).

A small differential-drive robot whose logger sees the motors only (idle 0 W unless
`idle_W` is set), from a DC-motor model:

- speed follows a commanded profile: a constant-acceleration ramp to each speed level,
  smoothed by the drive's own ~`lag_s` first-order response (no sharp corners);
- electrical power while driving: P = P_on + c1 v + c2 v² + k m a v (friction, copper
  losses, the inertial term while speeding up), plus PWM noise: white noise growing with
  the motor current and an aliased PWM tone at `pwm_tone_hz`;
- braking `short`: the drive shorts the motors: power falls to ~0 at once while the wheels
  coast to a stop under viscous (`coast_tau_s`) and Coulomb (`coast_friction_mps2`)
  friction; `drive`: a controlled linear ramp
  down with power falling with the speed (P_on + c1 v); `none`: the log ends moving;
- the velocity column is an encoder's: quantised to `speed_resolution_mps` (so a standing
  robot reads exactly 0) plus a little jitter while moving;
- the logger samples every `period_s` (1 ms, or 55 ms for an ~18 Hz logger): each value is
  the mean over its period.

`truth` holds the motion interval (first and last sample where the encoder reads a
non-zero speed) and the commanded phase plan with its times and speeds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from wifibot_power.run import Run, RunMeta


@dataclass(frozen=True)
class Scenario:
    levels_mps: tuple[float, ...] = (0.5,)
    accel_mps2: float = 1.0
    idle_before_s: float = 1.0
    cruise_s: float = 2.0
    idle_after_s: float = 1.0
    start_moving: bool = False  # the log starts during the first cruise
    brake: str = "short"  # "short", "drive" or "none" (the log ends moving)
    decel_mps2: float = 1.0  # for brake="drive"
    coast_tau_s: float = 0.12
    coast_friction_mps2: float = 0.5
    idle_W: float = 0.0
    period_s: float = 1e-3
    noise_W: float = 0.05  # white noise at standstill-free driving, per 1 ms
    pwm_noise_frac: float = 0.02  # extra noise sd per W of motor power
    pwm_tone_hz: float = 137.0
    lag_s: float = 0.01
    speed_resolution_mps: float = 0.002
    p_on_W: float = 1.5
    c1_W_per_mps: float = 8.0
    c2_W_per_mps2: float = 3.0
    inertial_W_per_mps2_mps: float = 6.0
    seed: int = 0
    run_id: str = "real-like"
    mode: str = "motion"
    steps: int = 1
    extra: dict[str, str] = field(default_factory=dict)


def realistic_run(sc: Scenario) -> tuple[Run, dict[str, object]]:
    """A run and its truth (see the module docstring)."""
    rng = np.random.default_rng(sc.seed)
    fine_dt = 1e-4  # the physics at 10 kHz, then averaged to the logger's period
    # commanded speed profile: (name, duration, v_from, v_to)
    plan: list[tuple[str, float, float, float]] = []
    if not sc.start_moving:
        plan.append(("idle", sc.idle_before_s, 0.0, 0.0))
    v = sc.levels_mps[0] if sc.start_moving else 0.0
    for k, level in enumerate(sc.levels_mps):
        if not (sc.start_moving and k == 0):
            plan.append(("accel", abs(level - v) / sc.accel_mps2, v, level))
        plan.append(("cruise", sc.cruise_s, level, level))
        v = level
    if sc.brake == "drive":
        plan.append(("decel", v / sc.decel_mps2, v, 0.0))
        plan.append(("idle", sc.idle_after_s, 0.0, 0.0))
    elif sc.brake == "short":
        plan.append(("coast", sc.idle_after_s + 8 * sc.coast_tau_s, v, 0.0))
    counts = [max(1, round(d / fine_dt)) for _, d, _, _ in plan]
    n = int(sum(counts))
    cmd = np.empty(n)
    driving = np.ones(n, dtype=bool)
    phase_times = []
    start = 0
    for (name, _, v0, v1), count in zip(plan, counts, strict=True):
        frac = (np.arange(count) + 0.5) / count
        if name == "coast":
            # viscous (tau) and Coulomb friction: dv/dt = -v / tau - a_c, so the wheels stop
            # in finite time, at t = tau ln(1 + v0 / (tau a_c))
            t = (np.arange(count) + 0.5) * fine_dt
            tau, a_c = sc.coast_tau_s, sc.coast_friction_mps2
            coast = (v0 + tau * a_c) * np.exp(-t / tau) - tau * a_c
            cmd[start : start + count] = np.clip(coast, 0.0, None)
            driving[start : start + count] = False
        else:
            cmd[start : start + count] = v0 + (v1 - v0) * frac
            driving[start : start + count] = name != "idle"
        phase_times.append((name, start * fine_dt, (start + count) * fine_dt, v0, v1))
        start += count
    # the drive's lag (first order, alpha per fine step) on the driven part; a coast is
    # already physical (exponential)
    alpha = fine_dt / (sc.lag_s + fine_dt)
    speed = cmd.copy()
    if sc.lag_s > 0:
        # first-order filter by a short FIR of its impulse response (vectorised)
        taps = alpha * (1 - alpha) ** np.arange(int(6 * sc.lag_s / fine_dt))
        taps /= taps.sum()
        padded = np.concatenate((np.full(taps.size - 1, cmd[0]), cmd))
        lagged = np.convolve(padded, taps, mode="valid")
        speed = np.where(driving | (cmd > lagged), lagged, cmd)
    accel = np.gradient(speed, fine_dt)
    motor_W = np.where(
        driving & (speed > 1e-4),
        sc.p_on_W
        + sc.c1_W_per_mps * speed
        + sc.c2_W_per_mps2 * speed**2
        + sc.inertial_W_per_mps2_mps * np.clip(accel, 0, None) * speed,
        0.0,
    )
    # a drive ramping down has no inertial pull (the robot's energy is spent in friction)
    t_fine = np.arange(n) * fine_dt
    noise_sd = (sc.noise_W + sc.pwm_noise_frac * motor_W) * np.sqrt(1e-3 / fine_dt)
    power = (
        sc.idle_W
        + motor_W
        + rng.normal(0.0, 1.0, n) * noise_sd * (motor_W > 0)
        + 0.3 * sc.pwm_noise_frac * motor_W * np.sin(2 * np.pi * sc.pwm_tone_hz * t_fine)
    )
    if sc.idle_W > 0:
        power = power + rng.normal(0.0, sc.noise_W * np.sqrt(1e-3 / fine_dt), n)
    # the logger: means over its period
    per = max(1, round(sc.period_s / fine_dt))
    m = n // per
    power_log = power[: m * per].reshape(m, per).mean(axis=1)
    speed_mean = speed[: m * per].reshape(m, per).mean(axis=1)
    jitter = rng.normal(0.0, sc.speed_resolution_mps, m) * (speed_mean > sc.speed_resolution_mps)
    speed_log = np.round((speed_mean + jitter) / sc.speed_resolution_mps)
    speed_log = np.clip(speed_log, 0, None) * sc.speed_resolution_mps
    period = per * fine_dt
    moving = np.flatnonzero(speed_log > 0)
    truth = {
        "motion_start_s": float(moving[0] * period) if moving.size else None,
        "motion_end_s": float((moving[-1] + 1) * period) if moving.size else None,
        "ends_moving": bool(speed_log[-1] > 0),
        "starts_moving": bool(speed_log[0] > 0),
        "plan": [
            {"phase": name, "t_start_s": t0, "t_end_s": t1, "v_from": v0, "v_to": v1}
            for name, t0, t1, v0, v1 in phase_times
        ],
    }
    meta = RunMeta(
        run_id=sc.run_id,
        mode=sc.mode,
        speed_mps=max(sc.levels_mps),
        distance_m=1.0,
        steps=sc.steps,
        sample_period_s=period,
        extra=dict(sc.extra),
    )
    run = Run(
        file=f"{sc.run_id}.csv",
        format="canonical",
        meta=meta,
        stamps_s=None,  # evenly spaced (`Run.time_s`)
        power_W=power_log,
        speed_mps=speed_log,
    )
    return run, truth


def plan_time(truth: dict[str, object], index: int, edge: str = "t_start_s") -> float:
    """The time of one edge of the commanded plan."""
    return float(truth["plan"][index][edge])  # type: ignore[index]
