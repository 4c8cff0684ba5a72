"""Metadata keys of log-format.md ("Metadata keys"): parsing and consistency checks."""

from __future__ import annotations

import math
from collections.abc import Callable
from datetime import datetime

from wifibot_power.errors import LogError
from wifibot_power.io.options import SAMPLE_PERIOD_RANGE_S
from wifibot_power.run import MODES, PAPER_SAMPLE_PERIOD_S, RunMeta

KNOWN_KEYS = (
    "run_id",
    "mode",
    "speed_mps",
    "distance_m",
    "steps",
    "payload_kg",
    "started_at",
    "sample_period_s",
)

#: The metadata key of the robot's own mass, without payload [kg] (log-format.md): it stays a
#: string in `RunMeta.extra`, checked by `build_meta` (a number > 0), read by `robot_mass_kg`.
MASS_KEY = "mass_kg"


#: The key of `build_meta`'s values that holds the run_id to use when none is given (instead
#: of the file name): set by a batch for logs whose file names collide (`discover.find_logs`).
#: Not a name a metadata line or a manifest column can have: the readers lower-case those.
DEFAULT_RUN_ID = "Default run_id"


def _number(values: dict[str, str], key: str, file: str, where: str) -> float | None:
    """The value of `key` as a float (a lone decimal comma is accepted), or None if unset."""
    text = values.get(key)
    if text is None or text == "":
        return None
    try:
        value = (
            float(text.replace(",", "."))
            if text.count(",") == 1 and "." not in text
            else float(text)
        )
    except ValueError:
        raise LogError(
            f"metadata '{key}' is '{text}', not a number",
            file=file,
            where=where,
            fix=f"write {key} as a plain number in SI units",
        ) from None
    if not math.isfinite(value):
        raise LogError(
            f"metadata '{key}' is {text}", file=file, where=where, fix="give a finite number"
        )
    return value


def build_meta(
    values: dict[str, str],
    *,
    file: str,
    stem: str,
    where: str,
    origins: dict[str, str] | None = None,
    speed_column: bool = False,
) -> RunMeta:
    """A checked `RunMeta` from `key: value` strings (file metadata with manifest overrides).

    `origins` maps a key to where its value was set ("metadata line 3", "runs.csv line 4"),
    so an error names the row at fault; `where` is the fallback. `speed_column`: the log has
    a speed (a speed column or two wheel speeds), so a motion run needs no commanded
    `speed_mps`: "a log with a speed column is a motion log whether or not its metadata
    gives a commanded speed: it may be free driving" (log-format.md, "Speed").
    """
    origins = origins or {}

    def at(*keys: str) -> str:
        found = [origins[k] for k in keys if k in origins]
        return ", ".join(dict.fromkeys(found)) or where

    speed = _number(values, "speed_mps", file, at("speed_mps"))
    distance = _number(values, "distance_m", file, at("distance_m"))
    steps_f = _number(values, "steps", file, at("steps"))
    payload = _number(values, "payload_kg", file, at("payload_kg"))
    period = _number(values, "sample_period_s", file, at("sample_period_s"))
    mass = _number(values, MASS_KEY, file, at(MASS_KEY))

    mode = _mode(values, speed, file, at)
    _check_values(values, mode, speed, distance, steps_f, payload, file, at, speed_column)
    if mass is not None and mass <= 0:
        raise LogError(
            f"mass_kg is {values[MASS_KEY]}",
            file=file,
            where=at(MASS_KEY),
            fix="give the robot's own mass in kg (> 0), without its payload",
        )
    _check_period(period, file, at)
    started = _started_at(values, file, at)
    extra = {k: v for k, v in values.items() if k not in KNOWN_KEYS and k != DEFAULT_RUN_ID}
    return RunMeta(
        run_id=values.get("run_id") or values.get(DEFAULT_RUN_ID) or stem,
        mode=mode,
        speed_mps=speed,
        distance_m=distance,
        steps=int(steps_f) if steps_f is not None else 1,
        payload_kg=payload or 0.0,
        started_at=started,
        sample_period_s=period or PAPER_SAMPLE_PERIOD_S,
        extra=extra,
    )


def _mode(values: dict[str, str], speed: float | None, file: str, at: Callable[..., str]) -> str:
    """The run's mode (`motion` when a speed is given and no mode), one of `MODES`."""
    mode = values.get("mode", "").strip().lower() or ("motion" if speed is not None else "unknown")
    if mode not in MODES:
        raise LogError(
            f"unknown mode '{values.get('mode')}'",
            file=file,
            where=at("mode"),
            fix=f"use one of: {', '.join(MODES)}",
        )
    return mode


def _check_values(
    values: dict[str, str],
    mode: str,
    speed: float | None,
    distance: float | None,
    steps_f: float | None,
    payload: float | None,
    file: str,
    at: Callable[..., str],
    speed_column: bool = False,
) -> None:
    """A `LogError` for a step count, a motion run's speed or distance, or a payload out of
    range (`at(key)`: where the key was set); a motion run may leave its speed out when the
    log has a speed column (`build_meta`)."""
    if steps_f is not None and (steps_f < 1 or steps_f != int(steps_f)):
        raise LogError(
            f"steps is {values.get('steps')}",
            file=file,
            where=at("steps"),
            fix="steps must be a whole number >= 1",
        )
    if mode == "motion":
        if (speed is None and not speed_column) or (speed is not None and speed <= 0):
            raise LogError(
                f"a motion run with speed_mps {values.get('speed_mps', 'missing')}",
                file=file,
                where=at("speed_mps") if "speed_mps" in values else at("mode"),
                fix="give the commanded speed (> 0 m/s), a speed column (free driving), or "
                "set the mode",
            )
        if distance is not None and distance <= 0:
            raise LogError(
                f"a motion run with distance_m {values.get('distance_m')}",
                file=file,
                where=at("distance_m"),
                fix="give the distance travelled (> 0 m)",
            )
    if payload is not None and payload < 0:
        raise LogError(
            f"payload_kg is {payload}",
            file=file,
            where=at("payload_kg"),
            fix="payload must be >= 0",
        )


def _check_period(period: float | None, file: str, at: Callable[..., str]) -> None:
    """A `LogError` for a sample period [s] <= 0 or outside `SAMPLE_PERIOD_RANGE_S`."""
    if period is not None and period <= 0:
        raise LogError(
            f"sample_period_s is {period}",
            file=file,
            where=at("sample_period_s"),
            fix="give the sample spacing in s (> 0)",
        )
    low_s, high_s = SAMPLE_PERIOD_RANGE_S
    if period is not None and not low_s <= period <= high_s:
        # an N6705 "Sample interval: 1e300", a period typed in ms: no logger samples so
        raise LogError(
            f"sample_period_s is {period:g} s, outside the plausible {low_s:g}-{high_s:g} s",
            file=file,
            where=at("sample_period_s"),
            fix="give the sample spacing in seconds (0.001 for 1 kHz), e.g. with --sample-period",
        )


def _started_at(values: dict[str, str], file: str, at: Callable[..., str]) -> datetime | None:
    """The run's start time from its ISO 8601 `started_at`, or None when not given."""
    if not values.get("started_at"):
        return None
    try:
        return datetime.fromisoformat(values["started_at"].replace("Z", "+00:00"))
    except ValueError:
        raise LogError(
            f"started_at '{values['started_at']}' is not an ISO 8601 time",
            file=file,
            where=at("started_at"),
            fix="write e.g. 2015-06-01T10:00:00Z",
        ) from None


def robot_mass_kg(meta: RunMeta) -> float | None:
    """The mass the robot's drive accelerates [kg]: its `mass_kg` metadata plus its
    `payload_kg` (log-format.md, "Metadata keys"), or None when the log gives no mass_kg.
    The readers refuse a mass_kg that is not a number > 0 (`build_meta`); a `RunMeta` made
    by hand with one gets None, as without it."""
    value = meta.extra.get(MASS_KEY)
    try:  # (a library caller's extra may hold a number, not its text)
        mass = _number({MASS_KEY: str(value)}, MASS_KEY, "", "") if value is not None else None
    except LogError:
        return None
    if mass is None or not mass > 0:
        return None
    return mass + meta.payload_kg


#: The metadata key (as the readers lower-case it) of the most the robot can draw [W].
MAX_POWER_KEY = "max_power_w"


def max_power_W(
    values: dict[str, str], *, file: str, origins: dict[str, str] | None = None
) -> float | None:
    """The `max_power_W` metadata (log-format.md, "Metadata keys") as a number [W], checked
    (> 0), or None when unset. It stays a string in `RunMeta.extra` (shared decision): this is
    its typed access, for the reader's plausible-power check."""
    where = (origins or {}).get(MAX_POWER_KEY, "metadata")
    value = _number(values, MAX_POWER_KEY, file, where)
    if value is not None and value <= 0:
        raise LogError(
            f"max_power_W is {values[MAX_POWER_KEY]}",
            file=file,
            where=where,
            fix="give the most this robot can draw, in W (> 0)",
        )
    return value
