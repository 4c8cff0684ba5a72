"""Energy of a trip: the paper's Eq. 5/6 per step, N steps per trip, and the named extensions.

A trip of `distance_m` in `steps` equal steps: in each step the robot accelerates at a
constant rate from rest to `speed_mps` in `t_acc_s`, cruises, and stops at once (paper
Eq. 5/6 of [1]). A step too short to reach the speed gets the physical triangular profile
(it accelerates at the same rate until the step is covered; see `step_kinematics`).

When the model carries extensions (added by `wbpower diagnose`, keyed by the cause names of
shared/spec/causes.md), each adds the term its cause's module computes (`Cause.energy_J`
in `wifibot_power/causes/`); this module loops over them and names none. The causes
package loads only for a model that has extensions: a fitted model has none, and `fit`
computes its stop-and-go overheads here without loading the causes.

References
----------
[1] D. Zorbas, T. Razafindralambo, "Modeling the power consumption of a Wifibot and
    studying the role of communication cost in operation time", arXiv:1512.04380.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from wifibot_power.errors import UsageError
from wifibot_power.model import PowerModel

#: Speeds of the paper's Figure 5 [m/s].
FIGURE5_SPEEDS_MPS: tuple[float, ...] = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)
#: Trip distances of the paper's Figure 5 [m].
FIGURE5_DISTANCES_M: tuple[float, ...] = (2.0, 10.0)
#: Step length of the stop-and-go curves of Figure 5 [m].
FIGURE5_STEP_M = 1.0


# -- kinematics of one step ------------------------------------------------------------
@dataclass(frozen=True)
class StepKinematics:
    """Times and speeds of one step [s, m/s]; `reaches_speed` is False for a triangular step."""

    speed_mps: float
    peak_speed_mps: float
    step_m: float
    accel_s: float
    cruise_s: float
    decel_s: float
    reaches_speed: bool

    @property
    def time_s(self) -> float:
        return self.accel_s + self.cruise_s + self.decel_s


def accel_distance_m(speed_mps: float, t_acc_s: float) -> float:
    """Distance covered while accelerating at a constant rate from rest to `speed_mps` [m].

    `s_acc = v * t_acc / 2` (paper Eq. 5, constant acceleration).
    """
    return speed_mps * t_acc_s / 2.0


def step_kinematics(
    speed_mps: float, step_m: float, t_acc_s: float, t_dec_s: float = 0.0
) -> StepKinematics:
    """Phase times of one step of `step_m` [m] at target speed `speed_mps` [m/s].

    Constant acceleration `a = v / t_acc` [m/s²] from rest (paper Eq. 5); cruise for
    `(s - s_acc - s_dec) / v` [s] (paper Eq. 6), where `s_acc = v t_acc / 2` and, with the
    `decel_phase` extension, `s_dec = v t_dec / 2` (constant deceleration over `t_dec_s`).
    The paper's robot stops at once (`t_dec_s = 0`).

    A step shorter than `s_acc + s_dec` never reaches `v`: the robot accelerates at `a`
    to a peak speed, then stops (at once, or at the deceleration rate `v / t_dec`). The
    distance is `v_peak² (t_acc + t_dec) / (2 v)`, so
    `v_peak = sqrt(2 s v / (t_acc + t_dec))`; with no deceleration phase this is
    `v_peak = sqrt(2 a s)` and the ramp lasts `v_peak / a`. This profile is continuous
    with Eq. 5/6 at `s = s_acc + s_dec`, and no phase time is ever negative.
    """
    if speed_mps <= 0 or not math.isfinite(speed_mps):
        raise UsageError(f"speed {speed_mps} m/s", fix="give a speed > 0")
    if step_m < 0 or t_acc_s < 0 or t_dec_s < 0:
        raise UsageError("negative step length or phase time", fix="give values >= 0")
    ramp_m = accel_distance_m(speed_mps, t_acc_s) + accel_distance_m(speed_mps, t_dec_s)
    if step_m >= ramp_m:
        return StepKinematics(
            speed_mps=speed_mps,
            peak_speed_mps=speed_mps,
            step_m=step_m,
            accel_s=t_acc_s,
            cruise_s=(step_m - ramp_m) / speed_mps,
            decel_s=t_dec_s,
            reaches_speed=True,
        )
    peak_mps = math.sqrt(2.0 * step_m * speed_mps / (t_acc_s + t_dec_s))
    return StepKinematics(
        speed_mps=speed_mps,
        peak_speed_mps=peak_mps,
        step_m=step_m,
        accel_s=peak_mps / speed_mps * t_acc_s,
        cruise_s=0.0,
        decel_s=peak_mps / speed_mps * t_dec_s,
        reaches_speed=False,
    )


# -- the paper's terms -----------------------------------------------------------------
def accel_energy_J(model: PowerModel, step: StepKinematics) -> float:
    """Energy of the acceleration phase of one step [J]: `P_acc(v) * t_acc` (paper Eq. 5).

    `P_acc(v) = a0 + a1 v` [W] (paper Eq. 1-2); for a triangular step it is evaluated at
    the peak speed reached, over the ramp's duration.
    """
    return model.accel_power_W(step.peak_speed_mps) * step.accel_s


def cruise_energy_J(model: PowerModel, step: StepKinematics) -> float:
    """Energy of the cruise phase of one step [J]: `P_v(v) * (s - s_acc) / v` (paper Eq. 6)."""
    return model.cruise_power_W(step.speed_mps) * step.cruise_s


# -- the extensions (shared/spec/causes.md): each cause's `energy_J`, in its own module --
def extension_names(model: PowerModel) -> list[str]:
    """The model's extensions that energy knows (registry order)."""
    if not model.extensions:
        return []
    from wifibot_power.causes import ordered

    return ordered(model.extensions)


# -- the trip --------------------------------------------------------------------------
@dataclass(frozen=True)
class PhaseEnergy:
    """One phase or term of a whole trip: time [s], mean power [W], energy [J]."""

    phase: str
    time_s: float
    energy_J: float

    @property
    def mean_power_W(self) -> float:
        return self.energy_J / self.time_s if self.time_s > 0 else float("nan")


@dataclass(frozen=True)
class TripEnergy:
    """Energy of one trip of `steps` equal steps (paper Eq. 5/6, times N)."""

    speed_mps: float
    distance_m: float
    steps: int
    t_acc_s: float
    payload_kg: float
    step: StepKinematics
    phases: tuple[PhaseEnergy, ...]
    #: the model's extensions whose terms are in `phases` (registry order)
    extensions: tuple[str, ...] = ()

    @property
    def energy_J(self) -> float:
        return float(sum(p.energy_J for p in self.phases))

    @property
    def time_s(self) -> float:
        return self.steps * self.step.time_s


def _extension(model: PowerModel, cause: str) -> dict[str, float]:
    from wifibot_power.causes import CAUSES

    params = model.extensions[cause]
    missing = [k for k in CAUSES[cause].parameters if k not in params]
    if missing:
        raise UsageError(
            f"model extension '{cause}' lacks {', '.join(missing)}",
            fix="re-run 'wbpower diagnose -o' or remove the extension from model.json",
        )
    return {k: float(v) for k, v in params.items()}


def trip_energy(
    model: PowerModel,
    speed_mps: float,
    distance_m: float,
    steps: int = 1,
    *,
    t_acc_s: float | None = None,
    payload_kg: float = 0.0,
    motor_on_before_min: float = 0.0,
) -> TripEnergy:
    """Energy and time of a trip of `distance_m` [m] in `steps` equal steps at `speed_mps`.

    Per step `E = P_acc(v) t_acc + P_v(v) (s - s_acc) / v` with `s = D / N` and
    `s_acc = v t_acc / 2` (paper Eq. 5/6); the trip is N steps. `t_acc_s` overrides the
    model's `t_acc(v)`. Extensions in `model.extensions` add their terms (causes.md);
    `motor_on_before_min` is how far into a session of driving the trip starts (for terms
    that depend on it, e.g. a warming motor; 0: from cold).
    """
    if not math.isfinite(speed_mps) or speed_mps <= 0:
        # before t_acc(v), which a NaN speed would make NaN and be blamed for
        raise UsageError(f"speed {speed_mps} m/s", fix="give a speed > 0")
    if not math.isfinite(distance_m) or distance_m <= 0:
        raise UsageError(f"distance {distance_m} m", fix="give a distance > 0")
    if int(steps) != steps or steps < 1:
        raise UsageError(f"{steps} steps", fix="give a whole number of steps >= 1")
    if payload_kg < 0:
        raise UsageError(f"payload {payload_kg} kg", fix="give a payload >= 0")
    steps = int(steps)
    t_acc = model.t_acc_s(speed_mps) if t_acc_s is None else float(t_acc_s)
    if not math.isfinite(t_acc) or t_acc < 0:
        # said by argument (a library error; the CLI's --t-acc is this argument)
        given = "t_acc_s" if t_acc_s is not None else f"the model's t_acc({speed_mps:g} m/s)"
        raise UsageError(
            f"acceleration time {t_acc} s ({given})",
            fix="give t_acc_s >= 0, or a model whose t_acc is fitted",
        )
    extensions = {name: _extension(model, name) for name in extension_names(model)}
    if extensions:
        from wifibot_power.causes import CAUSES, TripTerms
    stop_s = sum(CAUSES[name].stop_time_s(p) for name, p in extensions.items())
    step = step_kinematics(speed_mps, distance_m / steps, t_acc, stop_s)

    phases = [
        PhaseEnergy("accel", steps * step.accel_s, steps * accel_energy_J(model, step)),
        PhaseEnergy("cruise", steps * step.cruise_s, steps * cruise_energy_J(model, step)),
    ]
    # each term in its stage: phase powers (counted above idle), fixed lumps, then scales of
    # the energy above idle of the phase powers
    motion_time_s = steps * step.time_s
    above_idle_J = 0.0
    for stage in ("power", "lump", "scale") if extensions else ():
        if stage == "lump":
            above_idle_J = sum(p.energy_J for p in phases) - model.idle_W * motion_time_s
        terms = TripTerms(
            model=model,
            step=step,
            steps=steps,
            payload_kg=float(payload_kg),
            motor_on_before_min=float(motor_on_before_min),
            motion_above_idle_J=above_idle_J,
            motion_time_s=motion_time_s,
        )
        for name, params in extensions.items():
            cause = CAUSES[name]
            if cause.energy_stage == stage:
                time_s, energy_J = cause.energy_J(params, terms) or (0.0, 0.0)
                phases.append(PhaseEnergy(cause.energy_phase or name, time_s, energy_J))
    return TripEnergy(
        speed_mps=float(speed_mps),
        distance_m=float(distance_m),
        steps=steps,
        t_acc_s=t_acc,
        payload_kg=float(payload_kg),
        step=step,
        phases=tuple(phases),
        extensions=tuple(extensions),
    )


def stop_and_go_overhead_pct(energy_J: float, one_step_energy_J: float) -> float:
    """Extra energy of a trip in N steps over the same trip in one: `100 (E_N / E_1 - 1)` [%]."""
    return 100.0 * (energy_J / one_step_energy_J - 1.0)


@dataclass(frozen=True)
class EnergyReport:
    """A trip in N steps beside the same trip in one step, and the stop-and-go overhead."""

    trip: TripEnergy
    one_step: TripEnergy
    model_source: str
    ignored_extensions: tuple[str, ...] = field(default_factory=tuple)
    #: why the answer may not hold (e.g. a speed outside the model's fitted range)
    warnings: tuple[str, ...] = field(default_factory=tuple)

    @property
    def overhead_pct(self) -> float:
        return stop_and_go_overhead_pct(self.trip.energy_J, self.one_step.energy_J)

    def summary(self) -> dict[str, object]:
        """The `energy --json` object (cli.md), plus the per-phase breakdown."""
        trip, step = self.trip, self.trip.step
        return {
            "speed_mps": trip.speed_mps,
            "distance_m": trip.distance_m,
            "steps": trip.steps,
            "energy_J": trip.energy_J,
            "time_s": trip.time_s,
            "one_step_energy_J": self.one_step.energy_J,
            "overhead_pct": self.overhead_pct,
            "one_step_time_s": self.one_step.time_s,
            "step_m": step.step_m,
            "t_acc_s": trip.t_acc_s,
            "payload_kg": trip.payload_kg,
            "reaches_speed": step.reaches_speed,
            "peak_speed_mps": step.peak_speed_mps,
            "energy_per_m_J": trip.energy_J / trip.distance_m,
            "model": self.model_source,
            "extensions": list(trip.extensions),
            "ignored_extensions": list(self.ignored_extensions),
            "warnings": list(self.warnings),
            "phases": [
                {
                    "phase": p.phase,
                    "time_s": p.time_s,
                    "mean_power_W": p.mean_power_W,
                    "energy_J": p.energy_J,
                }
                for p in trip.phases
            ],
        }


def energy_report(
    model: PowerModel,
    speed_mps: float,
    distance_m: float,
    steps: int,
    *,
    t_acc_s: float | None = None,
    payload_kg: float = 0.0,
) -> EnergyReport:
    """The `wbpower energy` computation: the N-step trip, the one-step trip, the overhead."""
    kwargs = {"t_acc_s": t_acc_s, "payload_kg": payload_kg}
    return EnergyReport(
        trip=trip_energy(model, speed_mps, distance_m, steps, **kwargs),
        one_step=trip_energy(model, speed_mps, distance_m, 1, **kwargs),
        model_source=model.source,
        ignored_extensions=tuple(sorted(set(model.extensions) - set(extension_names(model)))),
        warnings=tuple(model.warnings_at(speed_mps)),
    )


def speed_sweep(
    model: PowerModel,
    *,
    t_acc_s: float | None = None,
    payload_kg: float = 0.0,
    speeds_mps: tuple[float, ...] = FIGURE5_SPEEDS_MPS,
    distances_m: tuple[float, ...] = FIGURE5_DISTANCES_M,
    step_m: float = FIGURE5_STEP_M,
) -> list[EnergyReport]:
    """The paper's Figure 5: each distance in one step and in `step_m` steps, at each speed.

    A row's `energy_J` is the stop-and-go trip (`D / step_m` steps), `one_step_energy_J`
    the same trip in one step.
    """
    rows = []
    for distance_m in distances_m:
        steps = max(1, int(np.ceil(distance_m / step_m - 1e-9)))
        for speed_mps in speeds_mps:
            rows.append(
                energy_report(
                    model, speed_mps, distance_m, steps, t_acc_s=t_acc_s, payload_kg=payload_kg
                )
            )
    return rows
