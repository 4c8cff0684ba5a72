"""Typed result of segmentation: the phases of one run (shared by segment, fit, diagnose).

Phase names: `idle`, `accel`, `cruise`, `decel` for motion runs (steps numbered from 1;
an idle phase carries the number of the step it follows, 0 before the first step), `turn`
where a robot with a turning column turns while its linear speed is ~0 (spinning in place;
numbered as the idle it interrupts), and
`level` for steady segments of a log without motion metadata (step = level index from 1).
Sample ranges are half-open `[i_start, i_end)`; phases cover every sample exactly once.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pandas (~0.45 s to import) loads only when a table is asked for
    import pandas as pd


PHASE_NAMES = ("idle", "accel", "cruise", "decel", "turn", "level")


@dataclass(frozen=True)
class Phase:
    step: int
    phase: str
    i_start: int
    i_end: int
    t_start_s: float
    t_end_s: float
    mean_power_W: float
    energy_J: float
    #: mean speed over the phase [m/s]: from the log's speed column, else the run's commanded
    #: speed for cruise; None where unknown (cli.md, `segment --json`)
    speed_mps: float | None = None
    #: mean |yaw rate| over the phase [rad/s] from the log's turning column; None where the
    #: log has none (cli.md, `segment --json`)
    yaw_rate_radps: float | None = None

    @property
    def duration_s(self) -> float:
        return self.t_end_s - self.t_start_s

    def as_dict(self) -> dict[str, object]:
        """The `segment --json` object of a phase (cli.md)."""
        return {
            "step": self.step,
            "phase": self.phase,
            "t_start_s": self.t_start_s,
            "t_end_s": self.t_end_s,
            "duration_s": self.duration_s,
            "mean_power_W": self.mean_power_W,
            "energy_J": self.energy_J,
            "speed_mps": self.speed_mps,
            "yaw_rate_radps": self.yaw_rate_radps,
        }


@dataclass(frozen=True)
class Spike:
    """A short start-up spike (inrush, overshoot) kept inside the phase it starts."""

    t_start_s: float
    duration_s: float
    peak_W: float
    energy_above_level_J: float


@dataclass(frozen=True)
class Segmentation:
    run_id: str
    phases: tuple[Phase, ...]
    spikes: tuple[Spike, ...] = ()
    #: reasons (plain sentences) why these phases may not describe the run; empty when the
    #: segmentation fits (cli.md, `segment --json`)
    doubts: tuple[str, ...] = ()

    def of(self, name: str) -> list[Phase]:
        return [p for p in self.phases if p.phase == name]

    def rows(self, file: str) -> list[dict[str, object]]:
        """A row per phase as plain values (small to send back from a worker): `PHASE_COLUMNS`,
        the `segment` columns after the run's `run_id` and its log's `file`."""
        return [{"run_id": self.run_id, "file": file, **p.as_dict()} for p in self.phases]

    def frame(self, file: str = "") -> pd.DataFrame:
        """A row per phase (phases.parquet of `fit -o` and `segment -o`): `rows`; `file`:
        the run's log, for its column (empty by default)."""
        return phase_frame(self.rows(file))


#: phases.parquet's columns: the `segment` columns after the run's `run_id` and its log's
#: `file` (cli.md: "the segment columns plus run_id"; more keys may be added)
PHASE_COLUMNS = (
    "run_id",
    "file",
    "step",
    "phase",
    "t_start_s",
    "t_end_s",
    "duration_s",
    "mean_power_W",
    "energy_J",
    "speed_mps",
    "yaw_rate_radps",
)


def phase_frame(rows: list[dict[str, object]]) -> pd.DataFrame:
    """The phases table from `Segmentation.rows` of any number of runs (`yaw_rate_radps`
    as float64, NaN where unknown: never a column of None)."""
    import pandas as pd

    frame = pd.DataFrame(rows, columns=list(PHASE_COLUMNS))
    frame["yaw_rate_radps"] = frame["yaw_rate_radps"].astype("float64")
    return frame
