"""The energy of a planned motion from a fitted drive model (cli.md, `energy --profile`): a
route's time, speed and optionally rate of turn and surface go through the same bins and
windows as a log (stats.py, windows.py), and the model's terms give each window's power.

- `energy_J`: the sum over windows of the predicted mean power times the window's duration;
- `terms_J`: how much of it each determined term accounts for (its coefficient times its
  regressor, summed), by the term's name;
- `undetermined_J`: the share of the terms the logs did not determine (reported as not
  determined, too loose to mean anything, but kept in the fit: identify.py `_honest`), one
  sum, not split by name: the data could not tell them apart from the others, so a share
  under a term's name would be a number that only looks exact. `undetermined_terms` names
  them; `terms_J` and `undetermined_J` add up to `energy_J` (cli.md is silent on such terms:
  the two keys are added to its object);
- `pi90_J`: a 90% prediction interval for the energy a run of this route would measure, from
  the run-to-run spread of held-out errors (heldout.py): energy x (1 +- t(0.95, n-1) x rms x
  sqrt(1 + 1/n)); none when the model has no held-out accuracy;
- `mean_ci95_W`: the 95% interval of the mean power the model predicts (the coefficients'
  uncertainty only: what to compare with another model's mean power, not a run's).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from wifibot_power.drive.model import DriveModel
from wifibot_power.drive.stats import (
    UNKNOWN_SURFACE,
    VOLTAGE_ASSUMED_KEY,
    drive_stats,
    sample_surfaces,
)
from wifibot_power.drive.terms import TERM_BY_NAME
from wifibot_power.drive.windows import assemble, run_windows
from wifibot_power.power_kind import unit_doubts
from wifibot_power.run import Run, RunMeta
from wifibot_power.stats import t_quantile


@dataclass(frozen=True)
class RouteEnergy:
    energy_J: float
    pi90_J: tuple[float, float] | None
    time_s: float
    distance_m: float
    mean_power_W: float
    mean_ci95_W: tuple[float, float]
    terms_J: dict[str, float]
    warnings: tuple[str, ...] = ()
    undetermined_J: float = 0.0
    undetermined_terms: tuple[str, ...] = ()

    def summary(self) -> dict[str, object]:
        """cli.md's `energy --profile --json` object."""
        return {
            "energy_J": self.energy_J,
            "pi90_J": list(self.pi90_J) if self.pi90_J is not None else None,
            "time_s": self.time_s,
            "distance_m": self.distance_m,
            "mean_power_W": self.mean_power_W,
            "terms_J": dict(self.terms_J),
            "undetermined_J": self.undetermined_J,
            "undetermined_terms": list(self.undetermined_terms),
        }


def route_energy(
    model: DriveModel,
    time_s: np.ndarray,
    speed_mps: np.ndarray,
    yaw_rate_radps: np.ndarray | None = None,
    surface: str | np.ndarray | None = None,
) -> RouteEnergy:
    """The energy of a route (module docstring). Its samples are what the robot should do at
    each time (a planner's profile, evenly spaced or not); `surface` names the model's
    surface it drives on (the model's only one when None), or each sample's (a route that
    crosses surfaces: each window takes its surface's terms, as a log's windows do in the
    fit, and `terms_J` names a surface's term with its surface, "rolling_W_per_mps[grass]")."""
    time_s = np.asarray(time_s, dtype=np.float64)
    speed_mps = np.asarray(speed_mps, dtype=np.float64)
    index, names = _route_surfaces(model, surface, time_s.size)
    surface = names[0]
    period_s = float(np.median(np.diff(time_s))) if time_s.size > 1 else model.window_s
    extra = {"surface": surface}
    warnings = _power_kind_warnings(model, speed_mps, yaw_rate_radps)
    warnings += unit_doubts(model.warnings)  # its terms, and so this energy, are then wrong
    if model.power_kind == "current_proxy":  # the route's design in the force form, as fitted
        extra[VOLTAGE_ASSUMED_KEY] = "the model's (its logs held motor currents only)"
    meta = RunMeta(run_id="route", sample_period_s=period_s, extra=extra)
    run = Run(
        file="route",
        format="profile",
        meta=meta,
        stamps_s=time_s - time_s[0],
        power_W=np.zeros(time_s.size),
        speed_mps=speed_mps,
        yaw_rate_radps=None if yaw_rate_radps is None else np.asarray(yaw_rate_radps, float),
        surface_index=index,
        surface_names=names if index is not None else (),
    )
    stats = drive_stats(run)
    windows = assemble([run_windows(stats, model.window_s)], 0, model.surface_names)
    coef = np.array(model.coef)
    kept = np.isfinite(coef)
    contributions_J = windows.design[:, kept] * coef[kept] * windows.window_s
    energy_J = float(contributions_J.sum())
    terms_J, undetermined_J, undetermined = _shares(
        model, names, np.array(model.columns)[kept], contributions_J.sum(axis=0)
    )
    used = np.any(windows.design[:, ~kept] != 0, axis=0)
    for column in np.array(model.columns)[~kept][used]:
        warnings.append(f"the route needs {column}, which the logs did not determine: left out")
    duration_s = windows.size * windows.window_s
    mean_W = energy_J / duration_s if duration_s > 0 else math.nan
    summed = windows.design[:, kept].sum(axis=0) * windows.window_s / max(duration_s, 1e-12)
    cov = np.array(model.cov) if model.cov else np.zeros((kept.sum(), kept.sum()))
    half_W = t_quantile(0.975, max(model.dof, 1)) * math.sqrt(max(summed @ cov @ summed, 0.0))
    pi90 = None
    held = model.heldout
    if held is not None and held.dof >= 1:
        spread = t_quantile(0.95, held.dof) * held.relative_rms * math.sqrt(1 + 1 / held.dof)
        pi90 = (energy_J * (1 - spread), energy_J * (1 + spread))
    distance_m = float(np.sum(np.abs(stats.speed_mps[np.isfinite(stats.speed_mps)])) * stats.bin_s)
    return RouteEnergy(
        energy_J=energy_J,
        pi90_J=pi90,
        time_s=duration_s,
        distance_m=distance_m,
        mean_power_W=mean_W,
        mean_ci95_W=(mean_W - half_W, mean_W + half_W),
        terms_J=terms_J,
        warnings=tuple(warnings),
        undetermined_J=undetermined_J,
        undetermined_terms=undetermined,
    )


def log_surfaces(run: Run) -> str | np.ndarray | None:
    """The surface a log drives on, as `route_energy` takes it: its samples' (a `surface`
    column: each sample's name, an empty one the metadata's or `UNKNOWN_SURFACE`, as the fit
    reads it, stats.py `sample_surfaces`), else its `surface` metadata (None without)."""
    index, names = sample_surfaces(run)
    if index is None:
        return run.meta.extra.get("surface")
    return np.asarray(names)[index]


def _route_surfaces(
    model: DriveModel, surface: str | np.ndarray | None, samples: int
) -> tuple[np.ndarray | None, tuple[str, ...]]:
    """The route's surfaces: (None, (its one surface,)) (`_route_surface`), or for a name per
    sample each sample's index into the names (every one a surface of the model's)."""
    if surface is None or isinstance(surface, str):
        return None, (_route_surface(model, surface),)
    labels = np.asarray(surface, dtype=str)
    if labels.shape != (samples,):
        raise ValueError(f"{labels.size} surfaces for {samples} samples: give one a sample")
    names, index = np.unique(np.char.strip(labels), return_inverse=True)
    if "" in names:
        raise ValueError("a sample of the route names no surface: name one for every sample")
    names = tuple(_route_surface(model, str(name)) for name in names)
    if len(names) == 1:
        return None, names
    return index.astype(np.int16), names


def _route_surface(model: DriveModel, surface: str | None) -> str:
    """The model's surface the route drives on: `surface`, or the model's only one."""
    surfaces = [s for s in model.surface_names if s]
    if surface is None:
        if len(surfaces) > 1:
            raise ValueError(f"the model has several surfaces ({', '.join(surfaces)}): name one")
        surface = surfaces[0] if surfaces else UNKNOWN_SURFACE
    if surface not in model.surface_names:
        named = [s for s in surfaces if s != UNKNOWN_SURFACE]
        fitted = (
            f"its surfaces: {', '.join(named)}"
            if named
            else "it was fitted on logs that name none: leave the surface out"
        )
        raise ValueError(f"surface '{surface}' is not one the model was fitted on ({fitted})")
    return surface


def _power_kind_warnings(
    model: DriveModel, speed_mps: np.ndarray, yaw_rate_radps: np.ndarray | None
) -> list[str]:
    """What a route's energy from a current-proxy model is (and what it cannot predict of
    arcs); a model of power and current logs together predicts no route."""
    if model.power_kind == "mixed":
        raise ValueError(
            "the model was fitted on power logs and current-only logs together: its terms are "
            "not one robot's power (fit the two kinds apart)"
        )
    if model.power_kind != "current_proxy":
        return []
    warnings = [
        "the model was fitted on current-only logs (voltage_assumed_V): this energy is "
        "theirs, a nominal voltage times the motors' current, not the battery's energy"
    ]
    if yaw_rate_radps is not None and np.any((np.asarray(yaw_rate_radps) != 0) & (speed_mps != 0)):
        warnings.append(
            "the route's arcs are predicted with a spin's scrubbing moment: the model keeps "
            "no track width, so the moment's fall with the turning radius (Wong's factor, "
            "as fitted where the logs gave track_m) is not applied: arcs come out high"
        )
    return warnings


def _shares(
    model: DriveModel, surfaces: tuple[str, ...], columns: np.ndarray, joules: np.ndarray
) -> tuple[dict[str, float], float, tuple[str, ...]]:
    """Each fitted column's energy [J] under its term's name where the model reports the term
    (`model.terms`, or the surface's `model.surfaces`), else summed into one undetermined
    share with the names of its terms (module docstring). On a route of several `surfaces`
    a surface's term is named with its surface ("rolling_W_per_mps[grass]")."""
    terms_J: dict[str, float] = {}
    undetermined_J = 0.0
    undetermined: list[str] = []
    for column, share_J in zip(columns, joules, strict=True):
        name, _, rest = str(column).partition("[")
        on = rest[:-1]
        if rest and on not in surfaces:  # another surface's column: 0 on this route
            continue
        shown = set(model.terms) | set(model.surfaces.get(on or surfaces[0], {}))
        key = f"{name}[{on}]" if rest and len(surfaces) > 1 else name
        if name in shown:
            terms_J[key] = terms_J.get(key, 0.0) + float(share_J)
        else:
            undetermined_J += float(share_J)
            undetermined += [] if key in undetermined else [key]
    return terms_J, undetermined_J, tuple(undetermined)


def step_phase_powers(
    model: DriveModel, speed_mps: float, t_acc_s: float, surface: str | None = None
) -> dict[str, tuple[float, tuple[float, float]]]:
    """The drive model's mean power [W] with its 95% interval over the paper's acceleration
    phase (a linear ramp from 0 to v in t_acc: the mean of |v| is v/2, of v^2 v^2/3, of a v
    v^2/(2 t_acc)) and over a cruise at v (|v| = v, v^2): to set beside P_acc(v) and P_v(v)
    (paper Eq. 1-4). Keys `accel`, `cruise`."""
    surface = surface or next(iter(model.surface_names), UNKNOWN_SURFACE)
    v = float(speed_mps)
    means = {
        "accel": {
            "1": 1.0,
            "moving": 1.0,
            "|v|": v / 2,
            "v^2": v * v / 3,
            "(a v)+": v * v / (2 * t_acc_s),
        },
        "cruise": {"1": 1.0, "moving": 1.0, "|v|": v, "v^2": v * v},
    }
    coef = np.array(model.coef)
    kept = np.isfinite(coef)
    cov = np.array(model.cov) if model.cov else np.zeros((kept.sum(), kept.sum()))
    t95 = t_quantile(0.975, max(model.dof, 1))
    out = {}
    for phase, regressors in means.items():
        gradient = np.zeros(coef.size)
        for j, column in enumerate(model.columns):
            name, _, rest = column.partition("[")
            if rest and rest[:-1] != surface:
                continue
            gradient[j] = regressors.get(TERM_BY_NAME[name].regressor, 0.0)
        power_W = float(gradient[kept] @ coef[kept])
        half = t95 * math.sqrt(max(gradient[kept] @ cov @ gradient[kept], 0.0))
        out[phase] = (power_W, (power_W - half, power_W + half))
    return out


def read_profile(
    path: str | Path,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, str | None]:
    """A planned route (cli.md, `energy --profile`): a CSV of `time_s`, `speed_mps`, and
    optionally `yaw_rate_radps` and `surface` (one surface a route). Returns time [s], speed
    [m/s], rate of turn [rad/s] or None, and the surface or None; a one-line `LogError`
    naming the file for anything else."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    from wifibot_power.errors import LogError

    path = Path(path)
    try:
        table = pacsv.read_csv(path)
    except (OSError, pa.ArrowException) as exc:
        raise LogError(
            f"cannot read the route ({str(exc).splitlines()[0][:80]})",
            file=path,
            fix="give a CSV with time_s and speed_mps columns",
        ) from None
    names = {name.strip().lower(): name for name in table.column_names}
    missing = [c for c in ("time_s", "speed_mps") if c not in names]
    if missing:
        raise LogError(
            f"the route has no {' or '.join(missing)} column",
            file=path,
            fix="give a CSV with time_s and speed_mps (and optionally yaw_rate_radps, surface)",
        )

    def numbers(name: str) -> np.ndarray:
        try:
            values = table[names[name]].to_numpy(zero_copy_only=False).astype(np.float64)
        except (ValueError, TypeError, pa.ArrowException):
            values = np.array([np.nan])
        if not np.isfinite(values).all():
            raise LogError(
                f"column '{name}' holds a value that is not a number",
                file=path,
                fix="every cell of time_s, speed_mps and yaw_rate_radps must be a number",
            )
        return values

    time_s, speed_mps = numbers("time_s"), numbers("speed_mps")
    if time_s.size < 2 or not np.all(np.diff(time_s) > 0):
        raise LogError(
            "the route's time_s does not go forwards", file=path, fix="sort it, 2 rows or more"
        )
    yaw = numbers("yaw_rate_radps") if "yaw_rate_radps" in names else None
    _check_units(path, speed_mps, yaw, float(np.median(np.diff(time_s))))
    surface: str | np.ndarray | None = None
    if "surface" in names:
        labels = ["" if s is None else str(s).strip() for s in table[names["surface"]].to_pylist()]
        found = set(labels) - {""}
        if len(found) > 1:  # a route that crosses surfaces: each sample's (`route_energy`)
            if "" in labels:
                raise LogError(
                    f"the route crosses surfaces ({', '.join(sorted(found))}) and leaves some "
                    "rows without one",
                    file=path,
                    fix="name the surface on every row",
                )
            surface = np.array(labels)
        else:
            surface = next(iter(found), None)
    return time_s, speed_mps, yaw, surface


def _check_units(
    path: Path, speed_mps: np.ndarray, yaw_rate_radps: np.ndarray | None, period_s: float
) -> None:
    """A route's speed and rate of turn judged as a log's are (io/validate.py: a speed over 50
    m/s, a rate over 30 rad/s; io/kinematics.py: a sideways |v·ω| over 3 g for 0.5 s), each a
    one-line `LogError` naming the line: a planned route is not driven by a vehicle spinning
    out, so a turn no tyre holds is a unit (deg/s), whose turning energy would be 57x."""
    from wifibot_power.errors import LogError
    from wifibot_power.io.kinematics import G_MPS2, lateral_peak
    from wifibot_power.io.validate import check_speed, check_yaw_rate

    line_of = lambda index: index + 2  # noqa: E731 - the header is line 1
    check_speed(str(path), "speed_mps", speed_mps, line_of=line_of)
    if yaw_rate_radps is None:
        return
    check_yaw_rate(str(path), "yaw_rate_radps", yaw_rate_radps, line_of=line_of)
    found = lateral_peak(speed_mps, yaw_rate_radps, period_s)
    if found is not None:
        first, worst, window_s = found
        raise LogError(
            f"|speed_mps x yaw_rate_radps| reaches {worst:.3g} m/s^2 ({worst / G_MPS2:.2g} g) "
            f"over {window_s:.2g} s: a turn no tyre holds",
            file=path,
            where=f"line {line_of(first)}",
            fix="give the rate of turn in rad/s (deg/s divided by 57.3)",
        )


def load_drive_model(path: str | Path) -> DriveModel:
    """The drive model of a model.json (`fit -o`: its `drive` section) or of a drive section
    saved alone (`DriveModel.to_json`); a one-line `UsageError` naming the file otherwise."""
    import json

    from wifibot_power.errors import UsageError

    path = Path(path)
    fix = "give a model.json from 'wbpower fit -o' on logs with a speed column"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        message = f"cannot read the model ({exc.__class__.__name__})"
        raise UsageError(message, file=path, fix=fix) from None
    section = data.get("drive", data) if isinstance(data, dict) else None
    if not isinstance(section, dict) or "coef" not in section:
        raise UsageError("the model has no drive model", file=path, fix=fix)
    try:
        return DriveModel.from_json(section)
    except (KeyError, TypeError, ValueError):
        raise UsageError("the drive model is damaged", file=path, fix=fix) from None
