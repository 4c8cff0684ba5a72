"""The fitted power model of a robot: what `fit` writes and `energy`, `lifetime`, `diagnose` read.

`PowerModel` holds the paper's linear models (Eq. 1-4 of [1]) and, once `diagnose` has
extended it, the extra terms of the named causes (shared/spec/causes.md), keyed by cause.
`model.json` carries a format version and loads back to an equal object.

References
----------
[1] D. Zorbas, T. Razafindralambo, "Modeling the power consumption of a Wifibot and
    studying the role of communication cost in operation time", arXiv:1512.04380.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

from wifibot_power.errors import UsageError

MODEL_FORMAT = "wbpower-model"
MODEL_FORMAT_VERSION = 1


@dataclass(frozen=True, eq=False)
class LinearFit:
    """`y = intercept + slope * speed_mps`, with 95% intervals and R² (NaN where not fitted)."""

    intercept: float
    slope: float
    intercept_ci95: tuple[float, float] = (float("nan"), float("nan"))
    slope_ci95: tuple[float, float] = (float("nan"), float("nan"))
    r2: float = float("nan")
    n_runs: int = 0

    def at(self, speed_mps: float) -> float:
        return self.intercept + self.slope * speed_mps

    def _key(self) -> tuple[object, ...]:
        # NaN marks "not fitted": two unfitted intervals are the same interval
        return tuple(
            "nan" if isinstance(x, float) and math.isnan(x) else x
            for x in (
                self.intercept,
                self.slope,
                *self.intercept_ci95,
                *self.slope_ci95,
                self.r2,
                self.n_runs,
            )
        )

    def __eq__(self, other: object) -> bool:
        return isinstance(other, LinearFit) and self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())


@dataclass(frozen=True)
class PowerModel:
    """Power of the robot by phase, as functions of speed (units in every name).

    - acceleration power `P_acc(v) = accel.intercept [W] + accel.slope [W/(m/s)] * v`
      (paper Eq. 1-2)
    - cruise power `P_v(v) = cruise.intercept [W] + cruise.slope [W/(m/s)] * v` (paper Eq. 3-4)
    - acceleration time `t_acc(v) = t_acc.intercept [s] + t_acc.slope [s/(m/s)] * v`
    - idle power `idle_W` and component powers net of idle (paper Table 1)
    - `extensions`: cause name -> its parameters (causes.md), added by `diagnose`
    """

    accel: LinearFit
    cruise: LinearFit
    idle_W: float
    t_acc: LinearFit
    components_W: dict[str, float | None] = field(default_factory=dict)
    extensions: dict[str, dict[str, float]] = field(default_factory=dict)
    source: str = "fit"
    #: (lowest, highest) speed of the motion runs the lines were fitted on [m/s]; None when
    #: unknown (a model.json written before wbpower recorded it)
    speed_range_mps: tuple[float, float] | None = None
    #: why the fit that made the model was weak or implausible (`fit.fit_warnings`), kept
    #: so that whatever uses the model later says so too
    fit_warnings: tuple[str, ...] = ()

    def warnings_at(self, speed_mps: float) -> list[str]:
        """Everything a user of the model's answer at `speed_mps` should be told: the fit's
        own warnings and an extrapolation beyond its speeds."""
        own = [
            f"the model ({self.source}) was fitted with a warning: {w}" for w in self.fit_warnings
        ]
        return own + self.extrapolation_warnings(speed_mps)

    def fitted_at(self, speed_mps: float) -> bool:
        """Whether `speed_mps` lies within the speeds the lines were fitted on (float slack
        at the ends); True when the range is unknown."""
        if self.speed_range_mps is None:
            return True
        low, high = self.speed_range_mps
        slack = 1e-9 * max(abs(low), abs(high), 1.0)
        return bool(low - slack <= speed_mps <= high + slack)

    def extrapolation_warnings(self, speed_mps: float) -> list[str]:
        """Why the model's answer at `speed_mps` is an extrapolation (empty when it is not):
        the speed lies outside the speeds the lines were fitted on."""
        if self.speed_range_mps is None or not math.isfinite(speed_mps):
            return []
        if self.fitted_at(speed_mps):
            return []
        low, high = self.speed_range_mps
        return [
            f"speed {speed_mps:g} m/s is outside the {low:g}-{high:g} m/s the model "
            f"({self.source}) was fitted on: its linear P_acc, P_v and t_acc are extrapolated"
        ]

    def accel_power_W(self, speed_mps: float) -> float:
        """Mean power over the acceleration phase [W] (paper: 23.9 + 14.8 v)."""
        return self.accel.at(speed_mps)

    def cruise_power_W(self, speed_mps: float) -> float:
        """Mean power at constant speed [W] (paper: 23.9 + 11.2 v)."""
        return self.cruise.at(speed_mps)

    def t_acc_s(self, speed_mps: float) -> float:
        """Acceleration time to reach `speed_mps` [s]."""
        return max(self.t_acc.at(speed_mps), 0.0)

    def with_extensions(self, extensions: dict[str, dict[str, float]], source: str) -> PowerModel:
        return replace(self, extensions=dict(extensions), source=source)

    def to_json(self) -> dict[str, object]:
        out = asdict(self)
        return {"format": MODEL_FORMAT, "format_version": MODEL_FORMAT_VERSION, **out}

    @classmethod
    def from_json(cls, data: dict[str, object], *, file: str = "model.json") -> PowerModel:
        if data.get("format") != MODEL_FORMAT:
            raise UsageError(
                "not a wbpower model file",
                file=file,
                fix="give a model.json written by 'wbpower fit -o' or 'diagnose -o'",
            )
        version = data.get("format_version")
        if version != MODEL_FORMAT_VERSION:
            raise UsageError(
                f"model format version {version}, this wbpower reads {MODEL_FORMAT_VERSION}",
                file=file,
                fix="re-run 'wbpower fit -o' with this version",
            )
        try:
            return cls(
                accel=_linear(data["accel"]),
                cruise=_linear(data["cruise"]),
                idle_W=_number(data["idle_W"]),
                t_acc=_linear(data["t_acc"]),
                components_W={
                    k: (None if v is None else float(v))
                    for k, v in (data.get("components_W") or {}).items()
                },
                extensions={
                    k: {p: float(x) for p, x in v.items()}
                    for k, v in (data.get("extensions") or {}).items()
                },
                source=str(data.get("source", "fit")),
                speed_range_mps=_range(data.get("speed_range_mps")),
                fit_warnings=tuple(str(w) for w in data.get("fit_warnings") or ()),
            )
        except (KeyError, TypeError, ValueError) as exc:
            if "accel" not in data and isinstance(data.get("drive"), dict):
                # `fit -o` on logs without usable step runs writes the drive model alone
                # (fit_result.py `model_json`): re-running it gives the same file
                raise UsageError(
                    "holds the drive model only: the paper's model (P_acc, P_v, t_acc, idle) "
                    "was incomplete or not fitted (it needs step runs at 2 speeds or more; "
                    "'wbpower fit' said why)",
                    file=file,
                    fix="for a route's energy use its drive model ('wbpower energy --profile "
                    "ROUTE.csv --model FILE'; in Python wifibot_power.drive.profile."
                    "load_drive_model), or fit step runs for the paper's",
                ) from None
            raise UsageError(
                f"model file is incomplete ({exc})", file=file, fix="re-run 'wbpower fit -o'"
            ) from None


def _number(value: object) -> float:
    """A float from JSON, where NaN was written as null."""
    return float("nan") if value is None else float(value)


def _pair(value: object) -> tuple[float, float]:
    if value is None:
        return (float("nan"), float("nan"))
    low, high = value
    return (_number(low), _number(high))


def _range(value: object) -> tuple[float, float] | None:
    if value is None:
        return None
    low, high = value
    return (float(low), float(high))


def _linear(d: dict) -> LinearFit:
    return LinearFit(
        intercept=_number(d["intercept"]),
        slope=_number(d["slope"]),
        intercept_ci95=_pair(d.get("intercept_ci95")),
        slope_ci95=_pair(d.get("slope_ci95")),
        r2=_number(d.get("r2")),
        n_runs=int(d.get("n_runs") or 0),
    )


def paper_model() -> PowerModel:
    """The paper's coefficients [1]: P_acc = 23.9 + 14.8 v, P_v = 23.9 + 11.2 v, idle 23.3 W,
    Table 1 components (network 4.4 W, video 2.5 W, CPU 2.1 W net of idle).

    The paper gives no t_acc(v) table we could use; wbpower assumes t_acc = 1 s at every
    speed for `--model paper` (override with `--t-acc`). See docs/paper-reproduction.md.
    """
    return PowerModel(
        accel=LinearFit(23.9, 14.8),
        cruise=LinearFit(23.9, 11.2),
        idle_W=23.3,
        t_acc=LinearFit(1.0, 0.0),
        components_W={"network": 4.4, "video": 2.5, "cpu": 2.1},
        source="paper",
        speed_range_mps=(0.1, 0.9),  # the paper's experiments (its Figures 2-5)
    )


def load_model(spec: str | Path) -> PowerModel:
    """`paper` -> the paper's model; otherwise a model.json path, validated as a log is
    (`read_model_document`, `check_model_values`) before anything is computed from it."""
    if str(spec) == "paper":
        return paper_model()
    path = Path(spec)
    data = read_model_document(path)
    if not isinstance(data, dict):
        raise UsageError(
            "not a wbpower model file", file=path, fix="give a model.json from 'wbpower fit -o'"
        )
    if data.get("format") == MODEL_FORMAT and data.get("format_version") == MODEL_FORMAT_VERSION:
        check_model_values(data, file=str(path))
    return PowerModel.from_json(data, file=str(path))


# -- a model file is input: validated like a log (issue 29) ------------------------------

#: Largest model.json read [bytes]: a fitted model is ~1.5 kB, one extended by every cause
#: a few kB; anything near this is not a model.
MODEL_MAX_BYTES = 1 << 20
#: Deepest nesting of lists and objects a model.json may have: the model's own is 3
#: (document > line > interval); JSON nested deeper is not a model (and 100,000 nested
#: `[` would exhaust Python's recursion).
MODEL_MAX_DEPTH = 8
#: The plausible range of each coefficient, by its unit: a power no robot of this kind
#: draws (`validate.ABSURD_POWER_W`: 1 kW), a time over an hour to reach cruise speed, a
#: speed over `validate.ABSURD_SPEED_MPS` (50 m/s) is no model's. Intervals may be wider
#: than the values (two runs give a t-interval of 12.7 standard errors): finite and within
#: `_CI_LIMIT`. Extension parameters (causes.md) are in their causes' own units: finite and
#: within `_CI_LIMIT`, each cause checks its own (`energy._extension`).
_POWER_LIMIT_W = 1000.0
_TIME_LIMIT_S = 3600.0
_SPEED_LIMIT_MPS = 50.0
_CI_LIMIT = 1e6
_MODEL_FIX = "give 'paper' or a model.json from 'wbpower fit -o' (re-run it to remake the file)"


def read_model_document(path: Path) -> object:
    """The JSON document of a model file, read as hostile input: a regular file (a FIFO
    would block forever), at most `MODEL_MAX_BYTES`, UTF-8, numbers finite (`NaN`,
    `Infinity` and `1e400` are refused: JSON has no such numbers, Python's reader accepts
    them), at most `MODEL_MAX_DEPTH` levels deep. Each failure is one `UsageError` line."""

    def refuse(why: str) -> UsageError:
        return UsageError(why, file=path, fix=_MODEL_FIX)

    def constant(name: str) -> float:
        raise ValueError(f"{name} is not a JSON number")

    def finite(text: str) -> float:
        value = float(text)
        if not math.isfinite(value):
            raise ValueError(f"{text} is beyond a float")
        return value

    import stat

    try:
        info = path.stat()
    except FileNotFoundError:
        raise UsageError(
            "no such model file",
            file=path,
            fix="give 'paper' or a model.json from 'wbpower fit -o'",
        ) from None
    except OSError as exc:
        raise refuse(f"cannot read the model ({exc.__class__.__name__})") from None
    if not stat.S_ISREG(info.st_mode):
        raise refuse("cannot read the model (not a regular file: a folder, FIFO or device)")
    if info.st_size > MODEL_MAX_BYTES:
        raise refuse(f"not a model file ({info.st_size} bytes, over {MODEL_MAX_BYTES})")
    try:
        with open(path, "rb") as handle:
            raw = handle.read(MODEL_MAX_BYTES + 1)
        if len(raw) > MODEL_MAX_BYTES:
            raise refuse(f"not a model file (over {MODEL_MAX_BYTES} bytes)")
        text = raw.decode("utf-8")
        depth = _nesting_depth(text)
        if depth > MODEL_MAX_DEPTH:
            raise refuse(
                f"not a model file (nested {depth} deep, a model at most {MODEL_MAX_DEPTH})"
            )
        return json.loads(text, parse_constant=constant, parse_float=finite)
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        what = str(exc).splitlines()[0][:80] if isinstance(exc, ValueError) else ""
        raise refuse(
            f"cannot read the model ({exc.__class__.__name__}{': ' + what if what else ''})"
        ) from None


def _nesting_depth(text: str) -> int:
    """How deep `[` and `{` nest in JSON `text` (brackets inside strings do not count),
    without recursion: counted on the text with its strings removed."""
    import re

    import numpy as np

    bare = re.sub(r'"(?:[^"\\]|\\.)*"', '""', text).encode()
    codes = np.frombuffer(bare, dtype=np.uint8)
    steps = (codes == ord("[")).astype(np.int64) + (codes == ord("{"))
    steps -= (codes == ord("]")).astype(np.int64) + (codes == ord("}"))
    return int(np.cumsum(steps).max(initial=0))


def check_model_values(data: dict[str, object], *, file: str) -> None:
    """Every coefficient of a model document (format version 1) of the right type and within
    its plausible range (`_POWER_LIMIT_W`, ...): a number (not `true`, not a string),
    finite, within range; an interval or R² may be null (NaN, "not fitted"). Else one line
    naming the key, so nothing is computed on a NaN or an absurd value."""

    def refuse(key: str, value: object, why: str) -> UsageError:
        shown = json.dumps(value)[:40]
        return UsageError(f"model value {key} = {shown}: {why}", file=file, fix=_MODEL_FIX)

    def number(key: str, value: object, limit: float, *, nullable: bool = False) -> None:
        if value is None and nullable:
            return
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise refuse(key, value, "not a number")
        if not -limit <= value <= limit:
            raise refuse(key, value, f"outside the plausible -{limit:g}..{limit:g}")

    def pair(key: str, value: object, limit: float) -> None:
        if value is None:
            return
        if not isinstance(value, list) or len(value) != 2:
            raise refuse(key, value, "not a pair [low, high]")
        for k, item in enumerate(value):
            number(f"{key}[{k}]", item, limit, nullable=True)

    for line, limit in (
        ("accel", _POWER_LIMIT_W),
        ("cruise", _POWER_LIMIT_W),
        ("t_acc", _TIME_LIMIT_S),
    ):
        if line not in data:
            continue  # missing: `from_json` says the file is incomplete
        fit = data[line]
        if not isinstance(fit, dict):
            raise refuse(line, fit, "not a fitted line {intercept, slope, ...}")
        for key in ("intercept", "slope"):
            if key in fit:
                number(f"{line}.{key}", fit[key], limit)
        pair(f"{line}.intercept_ci95", fit.get("intercept_ci95"), _CI_LIMIT)
        pair(f"{line}.slope_ci95", fit.get("slope_ci95"), _CI_LIMIT)
        number(f"{line}.r2", fit.get("r2"), 1.0, nullable=True)
        runs = fit.get("n_runs", 0)
        if runs is not None and (isinstance(runs, bool) or not isinstance(runs, int) or runs < 0):
            raise refuse(f"{line}.n_runs", runs, "not a count of runs")
    if "idle_W" in data:
        number("idle_W", data["idle_W"], _POWER_LIMIT_W)
        if data["idle_W"] < 0:  # (a number by now)
            raise refuse("idle_W", data["idle_W"], "a negative idle power")
    for key, kind in (("components_W", dict), ("extensions", dict), ("fit_warnings", list)):
        if data.get(key) is not None and not isinstance(data.get(key), kind):
            raise refuse(key, data.get(key), f"not a{'n object' if kind is dict else ' list'}")
    for name, value in (data.get("components_W") or {}).items():
        number(f"components_W.{name}", value, _POWER_LIMIT_W, nullable=True)
    for cause, params in (data.get("extensions") or {}).items():
        if not isinstance(params, dict):
            raise refuse(f"extensions.{cause}", params, "not an object of parameters")
        for name, value in params.items():
            number(f"extensions.{cause}.{name}", value, _CI_LIMIT)
    speeds = data.get("speed_range_mps")
    if speeds is not None:
        pair("speed_range_mps", speeds, _SPEED_LIMIT_MPS)
        if None in speeds or not 0 <= speeds[0] <= speeds[1]:
            raise refuse("speed_range_mps", speeds, "not 0 <= lowest <= highest")
