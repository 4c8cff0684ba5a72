"""The one in-memory form of a run that every stage after reading uses.

A `Run` is the samples of one log (time and power, SI units) plus its metadata.
Readers in `wifibot_power.io` build it; nothing after them knows file formats.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # numpy loads with the samples (a warm `fit --cache` holds none)
    import numpy as np

#: Run modes of log-format.md ("Metadata keys").
MODES = ("motion", "idle", "network", "video", "cpu", "unknown")

#: The reference analyser's sample period: one value every 0.1024 ms.
PAPER_SAMPLE_PERIOD_S = 0.1024e-3


@dataclass(frozen=True)
class RunMeta:
    """Metadata of a run, with units in the names (log-format.md, "Metadata keys")."""

    run_id: str
    mode: str = "unknown"
    speed_mps: float | None = None
    distance_m: float | None = None
    steps: int = 1
    payload_kg: float = 0.0
    started_at: datetime | None = None
    sample_period_s: float = PAPER_SAMPLE_PERIOD_S
    #: the other metadata, by key in lower case: a log's '#' lines are read so (their keys
    #: are case-insensitive: io/formats/canonical.py), and a run made by hand is kept alike,
    #: so that `voltage_assumed_V` is found however it was written
    extra: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if any(key != key.lower() for key in self.extra):
            object.__setattr__(self, "extra", {k.lower(): v for k, v in self.extra.items()})

    def as_dict(self) -> dict[str, object]:
        """JSON-safe form (for `inspect --json`)."""
        out: dict[str, object] = {
            "run_id": self.run_id,
            "mode": self.mode,
            "speed_mps": self.speed_mps,
            "distance_m": self.distance_m,
            "steps": self.steps,
            "payload_kg": self.payload_kg,
            "started_at": self.started_at.isoformat() if self.started_at else None,
            "sample_period_s": self.sample_period_s,
        }
        out.update(self.extra)
        return out


@dataclass(frozen=True)
class Problem:
    """Something odd found in a log that did not stop it being read (a short gap, a spike)."""

    kind: str
    message: str
    t_start_s: float | None = None
    duration_s: float | None = None


@dataclass(frozen=True, eq=False)
class Run:
    """Samples of one log: `power_W[i]` is the mean power over sample i, from `time_s[i]`."""

    file: str
    format: str
    meta: RunMeta
    #: the log's own time stamps [s], or None for a log without a time column, whose
    #: samples are evenly spaced from 0 at `sample_period_s`: `time_s` makes that axis
    #: only when asked for it (segmentation, the fit and diagnosis need only the period,
    #: and making it was a tenth of parsing a power-only log)
    stamps_s: np.ndarray | None
    power_W: np.ndarray
    problems: tuple[Problem, ...] = ()
    #: the robot's speed at each sample [m/s] when the log has a speed column
    #: (log-format.md, "Speed"), else None
    speed_mps: np.ndarray | None = None
    #: the robot's rate of turn at each sample [rad/s] (counter-clockwise positive) when the log
    #: has a turning column (log-format.md, "Turning"), else None
    yaw_rate_radps: np.ndarray | None = None
    #: each channel's power [W] when `power_W` is the sum of several (two motors; log-format.md
    #: "Several channels"), by channel name; empty when the log has one
    channels_W: dict[str, np.ndarray] = field(default_factory=dict)
    #: the surface under the robot at each sample, when the log has a `surface` column
    #: (log-format.md, "Metadata keys"): an index into `surface_names` (-1 where the column is
    #: empty), else None (then the `surface` metadata, if any, holds for the whole run)
    surface_index: np.ndarray | None = None
    surface_names: tuple[str, ...] = ()

    @property
    def samples(self) -> int:
        return int(self.power_W.size)

    @property
    def time_s(self) -> np.ndarray:
        """When each sample starts [s]: the log's stamps, or index x `sample_period_s`
        (made once, on first use)."""
        if self.stamps_s is not None:
            return self.stamps_s
        made = self.__dict__.get("_even_time_s")
        if made is None:
            import numpy as np

            made = np.arange(self.samples, dtype=np.float64)
            made *= self.sample_period_s  # in place: one array, the same floats as i x period
            object.__setattr__(self, "_even_time_s", made)  # a cache, not a field
        return made

    def time_at(self, index: int) -> float:
        """`time_s[index]` (negative from the end) without making the whole axis [s]."""
        if self.stamps_s is not None:
            return float(self.stamps_s[index])
        if not -self.samples <= index < self.samples:
            raise IndexError(f"sample {index} of {self.samples}")
        return float((index % self.samples) * self.sample_period_s)

    @property
    def sample_period_s(self) -> float:
        return self.meta.sample_period_s

    @property
    def duration_s(self) -> float:
        return self.samples * self.sample_period_s

    @property
    def mean_power_W(self) -> float:
        return self.energy_and_mean()[1]

    @property
    def energy_J(self) -> float:
        return self.energy_and_mean()[0]

    def energy_and_mean(self) -> tuple[float, float]:
        """The run's energy [J] (`energy_J`, Eq. 1's integral by the rectangle rule) and mean
        power [W] (NaN without samples) from one sum of the samples: what `energy_J` and
        `mean_power_W` give (numpy's mean is the same pairwise sum over the count). Made once,
        on first use: the run table's row and the drive model's statistics both read it (a
        pass over every sample, ~0.1 ms a 10 kHz step run; the samples are not changed once
        a run is made)."""
        made = self.__dict__.get("_energy_and_mean")
        if made is None:
            import numpy as np

            total_W = np.sum(self.power_W, dtype=np.float64)
            mean_W = float(total_W / self.samples) if self.samples else float("nan")
            made = (float(total_W * self.sample_period_s), mean_W)
            object.__setattr__(self, "_energy_and_mean", made)  # a cache, not a field
        return made


def energy_J(power_W: np.ndarray, sample_period_s: float) -> float:
    """Energy of evenly spaced samples, each the mean power over its period [J].

    The rectangle rule keeps energy exactly additive over any split into phases,
    which is what the per-phase tables rely on.
    """
    import numpy as np

    return float(np.sum(power_W, dtype=np.float64) * sample_period_s)
