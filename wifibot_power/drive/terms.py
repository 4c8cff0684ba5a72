"""The drive model's terms: the robot's instantaneous electrical power as a sum of physically
named terms (cli.md, "The drive model"), one function each, pvlib-style.

    P = idle_W
        + drive_on_W                          (while moving or turning)
        + rolling_W_per_mps[surface] * |v|
        + quadratic_W_per_mps2 * v^2
        + effective_mass_kg * (a v)+          (speeding up: a v > 0)
        + braking_mass_kg * (a v)-            (slowing down: a v < 0)
        + turning_Nm[surface] * |yaw rate|

Each term is a force (or moment) times a speed (or rate of turn), divided by the drive's
efficiency, which the fitted coefficient absorbs: the coefficients are electrical, not
mechanical, quantities. `TERMS` is the only list of them: the design matrix, the summary
and the route energy loop over it.

A log of motor currents with an assumed voltage (`stats.current_proxy`) is not power but
V_nom I = u_0 F, a force times the motor's no-load speed at the ground (I = tau / k_t): its
terms take their force form (windows.py; docs/drive-model.md, "Current-only logs"), the
same names with the speed divided out: a constant rolling force while translating, a viscous
force |v|, m_eff a sign(v), and for turning a Coulomb moment while turning (its own term,
`turning_coulomb_W`, of the force form only; a motor current holds no drivers' step, so
`drive_on_W` has no column there) plus its part in |yaw rate|; on an arc only the outer side
drives (the inner one brakes, its current not logged), so every longitudinal and moment
column counts half there (moving.py `force_form_regressors`; Wong, "Theory of Ground Vehicles", 4th
ed., 2008, Sec. 7.2: F_out = F/2 + M/B, F_in = F/2 - M/B).

References
----------
[1] J. Morales, J. L. Martinez, A. Mandow, A. J. Garcia-Cerezo, S. Pedraza, "Power
    consumption modeling of skid-steer tracked mobile robots on rigid terrain", IEEE
    Transactions on Robotics 25(5), 2009, pp. 1098-1108.
[2] J. Jaramillo-Morales, S. Dogru, J. B. Gomez-Mendoza, L. Marques, "Energy estimation for
    differential drive mobile robots on straight and rotational trajectories", International
    Journal of Advanced Robotic Systems 17(2), 2020.
[3] R. Siegwart, I. Nourbakhsh, D. Scaramuzza, "Introduction to Autonomous Mobile Robots",
    2nd ed., MIT Press, 2011, Sec. 3.2 (kinematics of differential and skid-steer drives).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def idle_power_W(speed_mps: np.ndarray, idle_W: float) -> np.ndarray:
    """Power standing still with the drive enabled [W], at every sample of `speed_mps`: the
    electronics and the motor drivers' quiescent draw, present whether the robot moves or not
    (the constant term of [2], Eq. 1)."""
    return np.full(np.shape(speed_mps), float(idle_W))


def drive_on_power_W(moving: np.ndarray, drive_on_W: float) -> np.ndarray:
    """Power drawn only while the robot moves or turns, whatever its speed [W]: the motor
    drivers switching (an H-bridge's losses with current flowing), brakes released, a motor
    controller's speed loop active. A step between standing and moving that the paper's
    phase model carries as its cruise line's intercept above idle (paper Eq. 3-4: P_v(0+) >
    idle), and wbpower's own robot model as `drive_on_W` (simulate.py). `moving` is 1 while
    moving, 0 standing (or the share of a window spent moving)."""
    return drive_on_W * np.asarray(moving, dtype=np.float64)


def rolling_power_W(speed_mps: np.ndarray, rolling_W_per_mps: float) -> np.ndarray:
    """Rolling resistance and Coulomb (dry) friction: a force independent of speed times the
    speed, P = F_r |v| [W] with F_r = C_rr m g / eta (the electrical equivalent of the force,
    [N] = [W/(m/s)]). [2], Eq. 4 (friction torque times wheel speed); [1], Eq. 9 (the
    longitudinal rolling term). Depends on the surface."""
    return rolling_W_per_mps * np.abs(speed_mps)


def quadratic_power_W(speed_mps: np.ndarray, quadratic_W_per_mps2: float) -> np.ndarray:
    """Losses growing with the square of speed, P = c_2 v^2 [W]: viscous friction in the
    gearbox and bearings (a torque proportional to the wheel speed times the wheel speed) and
    the motors' back-EMF-dependent losses; at constant load the copper loss I^2 R of a DC motor
    grows with the current needed against viscous torque. [2], Eq. 4 (viscous coefficient)."""
    return quadratic_W_per_mps2 * np.square(speed_mps)


def inertial_power_W(
    speed_mps: np.ndarray, accel_mps2: np.ndarray, effective_mass_kg: float
) -> np.ndarray:
    """Power to speed the robot up, P = m_eff a v while a v > 0 [W] (reversing included: speeding
    up backwards has a < 0 and v < 0). m_eff = (m + J_w / r^2) / eta: the robot's mass plus its
    wheels' and rotors' inertia seen at the ground, over the drive efficiency: the rate of
    change of kinetic energy, d(m v^2 / 2)/dt = m a v, drawn through the drive. [2], Eq. 3."""
    return effective_mass_kg * np.maximum(accel_mps2 * speed_mps, 0.0)


def braking_power_W(
    speed_mps: np.ndarray, accel_mps2: np.ndarray, braking_mass_kg: float
) -> np.ndarray:
    """What slowing down does to the electrical power, P = m_b a v while a v < 0 [W]. The
    kinetic energy released, m a v < 0, is returned to the supply by a regenerative drive
    (m_b ~ m eta > 0: power drops below the cruise level), burnt in the drive's resistors or
    brakes (m_b ~ 0), or costs power when the controller drives the motors against the motion
    to stop (m_b < 0): its sign is the data's, not assumed. [2], Eq. 3 with the sign of a v."""
    return braking_mass_kg * np.minimum(accel_mps2 * speed_mps, 0.0)


def turning_power_W(yaw_rate_radps: np.ndarray, turning_Nm: float) -> np.ndarray:
    """Skid-steer scrubbing: the wheels (or tracks) slide sideways while the robot turns, and the
    friction of that sliding is a resisting moment M_r about the centre of turn; the power to
    overcome it is P = M_r |yaw rate| [W] ([1], Eq. 20-22: the lateral friction moment
    mu m g l / 4 for a uniform load times the rate of turn, over the drive efficiency). [1]
    finds M_r varies with the turning radius (larger on tight turns); a constant moment is
    its spin-in-place value (a current proxy's force form scales an arc's by Wong's
    0.925 / (0.925 + 0.15 R/B) where the track is known: moving.py `radius_factor`). For a
    differential drive the same form holds with a much smaller moment (caster scrub, [2],
    Sec. 3.2). Depends on the surface."""
    return turning_Nm * np.abs(yaw_rate_radps)


def turning_coulomb_proxy_W(turning: np.ndarray, turning_coulomb_W: float) -> np.ndarray:
    """The Coulomb (rate-independent) part of the skid-steer scrubbing moment in a current
    proxy's force form [W of V_nom I]: while the robot turns, its wheels slide sideways
    against a lateral friction moment M_c = mu m g l / 4 ([1], Eq. 20-22), which the motors
    hold with a torque, and so a current, whatever the rate of turn; V_nom I = u_0 M_c /
    (B/2) (u_0 the motors' no-load speed at the ground, B the track: docs/drive-model.md,
    "Current-only logs"). In a power log the same moment draws M_c |yaw rate|: `turning_Nm`
    carries it, and this term has no column. `turning` is 1 while turning, 0 not (or the
    share of a window spent turning). Depends on the surface (mu)."""
    return turning_coulomb_W * np.asarray(turning, dtype=np.float64)


@dataclass(frozen=True)
class Term:
    """One term of the drive model: its name (with its unit), the unit, whether it is one per
    surface, whether physics bounds it below by 0, and what its column of the design is."""

    name: str
    unit: str
    per_surface: bool
    non_negative: bool
    #: the design column's description (docs, `not_determined` reasons)
    regressor: str


#: The drive model's terms, in the order of the design (per-surface terms repeat per surface).
TERMS: tuple[Term, ...] = (
    Term("idle_W", "W", False, True, "1"),
    Term("drive_on_W", "W", False, True, "moving"),
    Term("rolling_W_per_mps", "W/(m/s)", True, True, "|v|"),
    Term("quadratic_W_per_mps2", "W/(m/s)^2", False, True, "v^2"),
    Term("effective_mass_kg", "kg", False, True, "(a v)+"),
    Term("braking_mass_kg", "kg", False, False, "(a v)-"),
    Term("turning_Nm", "N m", True, True, "|yaw rate|"),
    #: the force form's only (current-proxy logs: windows.py): 0 in a power log's design
    Term("turning_coulomb_W", "W", True, True, "turning"),
)
TERM_BY_NAME = {term.name: term for term in TERMS}
#: Each term's unit in the force form, the terms of logs whose "power" is a nominal voltage
#: times motor currents (~ torque: stats.py `current_proxy`, moving.py `force_form_regressors`): a
#: coefficient is a force (or moment) times the motors' no-load speed, in the proxy's W.
FORCE_FORM_UNITS = {
    "idle_W": "W",
    "drive_on_W": "W",
    "rolling_W_per_mps": "W (force)",
    "quadratic_W_per_mps2": "W/(m/s)",
    "effective_mass_kg": "W/(m/s^2)",
    "braking_mass_kg": "W/(m/s^2)",
    "turning_Nm": "W/(rad/s)",
    "turning_coulomb_W": "W",
}


def term_unit(name: str, force_form: bool = False) -> str:
    """A term's unit: its own, or in the force form of current-proxy logs (`FORCE_FORM_UNITS`),
    wherever a value of it is said (the table, a not-determined reason)."""
    return FORCE_FORM_UNITS[name] if force_form else TERM_BY_NAME[name].unit


def power_W(
    speed_mps: np.ndarray,
    accel_mps2: np.ndarray,
    yaw_rate_radps: np.ndarray,
    coefficients: dict[str, float],
) -> np.ndarray:
    """The drive model's power [W]: the sum of the terms above, each with its coefficient
    (one surface: `coefficients` holds a value for every name of `TERMS` but the force
    form's `turning_coulomb_W`, which a power has not)."""
    moving = (speed_mps != 0) | (yaw_rate_radps != 0)
    return (
        idle_power_W(speed_mps, coefficients["idle_W"])
        + drive_on_power_W(moving, coefficients["drive_on_W"])
        + rolling_power_W(speed_mps, coefficients["rolling_W_per_mps"])
        + quadratic_power_W(speed_mps, coefficients["quadratic_W_per_mps2"])
        + inertial_power_W(speed_mps, accel_mps2, coefficients["effective_mass_kg"])
        + braking_power_W(speed_mps, accel_mps2, coefficients["braking_mass_kg"])
        + turning_power_W(yaw_rate_radps, coefficients["turning_Nm"])
    )
