"""What `fit` returns: every model family's fit of one batch, its tables, what was left out.

`FitResult` holds each family's `FittedModel` by name (`fits`, registry order), the batch's
per-run and per-phase tables (made when first asked for: a command that only prints the
model, e.g. a warm `fit --cache --json`, never loads pandas), the inputs left out and the
batch's own warnings (runs used in doubt) and notes. The paper family's fields read through
(`model`, `idle`, `stop_and_go`, ...), as before families.

The paper's fit is there unless no run is a step run (free driving only: `has_paper` False,
cli.md "The drive model"); then its keys of `fit --json` are null (`PaperFit.null_summary`)
and model.json holds the other families alone.

The `fit --json` document (`summary`) is the paper's section at the top level, then each
other family's under its name (`drive`: null when no family of that name fitted);
`to_json`/`from_json` are what `fit --cache` keeps of it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from wifibot_power.io import Skipped
from wifibot_power.model import PowerModel
from wifibot_power.models.paper_table import format_number, table_rows, to_markdown
from wifibot_power.outputs import gc_paused, json_safe

if TYPE_CHECKING:
    import pandas as pd

    from wifibot_power.drive.model import DriveModel
    from wifibot_power.models.base import FittedModel
    from wifibot_power.models.drive import KeptDrive
    from wifibot_power.models.paper import PaperFit
    from wifibot_power.models.paper_fit import MeanEstimate
    from wifibot_power.overhead import StopAndGo

__all__ = ["FitResult", "format_number"]

#: The paper family's name: its section is the top level of `fit --json` and model.json.
PAPER = "paper"
#: The drive model family's name (cli.md, "The drive model"): its `fit --json` key.
DRIVE = "drive"


@dataclass(frozen=True)
class DriveVsPaper:
    """At one speed: the paper's fitted P_acc(v), P_v(v) and the drive model's mean powers
    over the same phases [W], each with its 95% interval (`FitResult.drive_vs_paper`)."""

    speed_mps: float
    paper_accel_W: float
    paper_accel_ci95: tuple[float, float]
    accel_W: float
    accel_ci95: tuple[float, float]
    paper_cruise_W: float
    paper_cruise_ci95: tuple[float, float]
    cruise_W: float
    cruise_ci95: tuple[float, float]

    @property
    def accel_agree(self) -> bool:
        """Whether the two intervals of the acceleration phase overlap."""
        return _overlap(self.paper_accel_ci95, self.accel_ci95)

    @property
    def cruise_agree(self) -> bool:
        """Whether the two intervals of the cruise overlap."""
        return _overlap(self.paper_cruise_ci95, self.cruise_ci95)


def _overlap(a: tuple[float, float], b: tuple[float, float]) -> bool:
    return a[0] <= b[1] and b[0] <= a[1]


@dataclass(frozen=True, eq=False)
class FitResult:
    """What `fit` found (module docstring)."""

    #: family name -> its fit, in registry order
    fits: dict[str, FittedModel]
    #: makes `(runs, phases)`
    tables: Callable[[], tuple[pd.DataFrame, pd.DataFrame]] = field(repr=False)
    skipped: tuple[Skipped, ...] = ()
    #: the batch's warnings, said before the families' (runs used in doubt)
    batch_warnings: tuple[str, ...] = ()
    #: the batch's notes, said before the paper's (why a family is missing)
    batch_notes: tuple[str, ...] = ()
    #: every readable run's run_id when the maker has them without the tables (`run_ids`)
    given_run_ids: tuple[str, ...] | None = None

    # -- the paper family's fit, read through ------------------------------------------
    @property
    def has_paper(self) -> bool:
        """Whether the paper's models were fitted (some run is a usable step run)."""
        return PAPER in self.fits

    @property
    def paper_fit(self) -> PaperFit:
        return self.fits[PAPER]  # type: ignore[return-value]

    @property
    def drive(self) -> DriveModel | KeptDrive | None:
        """The drive model (cli.md, "The drive model"); None when no run had a speed."""
        return self.fits.get(DRIVE)  # type: ignore[return-value]

    @property
    def model(self) -> PowerModel:
        return self.paper_fit.model

    @property
    def idle(self) -> MeanEstimate:
        return self.paper_fit.idle

    @property
    def idle_source(self) -> str:
        return self.paper_fit.idle_source

    @property
    def components(self) -> dict[str, MeanEstimate | None]:
        return self.paper_fit.components

    @property
    def n_runs(self) -> int:
        """Runs the paper's fit used (0 without it)."""
        return self.paper_fit.n_runs if self.has_paper else 0

    @property
    def notes(self) -> tuple[str, ...]:
        return (*self.batch_notes, *(self.paper_fit.notes if self.has_paper else ()))

    @property
    def stop_and_go(self) -> tuple[StopAndGo, ...]:
        return self.paper_fit.stop_and_go if self.has_paper else ()

    @property
    def paper(self) -> PowerModel:
        """The paper's own coefficients."""
        return self.paper_fit.reference

    @property
    def model_complete(self) -> bool:
        """Whether every coefficient `energy`/`lifetime` need was fitted (model.json loads
        them); False without the paper's fit."""
        return self.has_paper and self.paper_fit.model_complete

    @property
    def writes_model(self) -> bool:
        """Whether `fit -o` writes model.json: the paper's model complete, or another
        family's model fitted (the drive model of free driving, or beside a paper model that
        is incomplete: cli.md, "model.json carries both models"). Without a complete paper
        model the file holds its format and the other families' sections, not the paper's
        (`model_json`); a paper model incomplete and nothing else fitted writes none."""
        return self.model_complete or any(name != PAPER for name in self.fits)

    @property
    def warnings(self) -> tuple[str, ...]:
        """Why the result is weak, implausible or not all there (cli.md `fit --json`
        `warnings`): the batch's, then the paper fit's."""
        paper = self.paper_fit.warnings if self.has_paper else ()
        return (*self.batch_warnings, *paper)

    # -- the tables --------------------------------------------------------------------
    @functools.cached_property
    def _frames(self) -> tuple[pd.DataFrame, pd.DataFrame]:
        return self.tables()

    @property
    def runs(self) -> pd.DataFrame:
        """A row per readable run (runs.parquet, `runtable.runs_frame`)."""
        return self._frames[0]

    @property
    def run_ids(self) -> tuple[str, ...]:
        """Every readable run's run_id, in the runs table's order: what tells a held-out trip
        of a log from a run held out whole (`drive.heldout.trip_log`). Without the tables
        when the maker gave them (a warm `fit` table never loads pandas)."""
        if self.given_run_ids is not None:
            return self.given_run_ids
        return tuple(str(run_id) for run_id in self.runs["run_id"].tolist())

    @property
    def phases(self) -> pd.DataFrame:
        """A row per phase of every run (phases.parquet: `Segmentation.frame`'s columns, and
        the run's `file` after its `run_id`)."""
        return self._frames[1]

    # -- said ----------------------------------------------------------------------------
    def summary(self) -> dict[str, object]:
        """The `fit --json` document (cli.md), JSON-safe (NaN -> null): the paper's section
        with the inputs left out and the batch's warnings, then each other family's (null
        when it did not fit: cli.md's `drive` is null when no log has a speed)."""
        with gc_paused():  # (a dict per held-out trip: outputs.py `gc_paused`)
            return self._summary()

    def _summary(self) -> dict[str, object]:
        from wifibot_power.models import FAMILIES
        from wifibot_power.models.paper import PaperFit

        section = dict(self.paper_fit.summary() if self.has_paper else PaperFit.null_summary())
        tail = {"notes": list(self.notes), "warnings": list(self.warnings)}
        del section["notes"], section["warnings"]
        out = {**section, "skipped": [s.as_dict() for s in self.skipped], **tail}
        for name in FAMILIES:
            if name != PAPER:
                fitted = self.fits.get(name)
                out[name] = fitted.summary() if fitted is not None else None
        return json_safe(out)  # type: ignore[return-value]

    def table_rows(self) -> list[dict[str, object]]:
        """The paper table (`models.paper_table.table_rows`); none without the paper's fit."""
        return table_rows(self.paper_fit) if self.has_paper else []

    def to_markdown(self) -> str:
        """The paper table as Markdown (empty without the paper's fit)."""
        return to_markdown(self.paper_fit) if self.has_paper else ""

    def model_json(self) -> dict[str, object]:
        """model.json: the paper's model at the top level (when complete: else only the
        file's format, and `energy --model` says the paper's model is incomplete), each other
        family's section under its name."""
        from wifibot_power.model import MODEL_FORMAT, MODEL_FORMAT_VERSION

        if self.model_complete:
            out = dict(self.paper_fit.to_json())
        else:
            out = {"format": MODEL_FORMAT, "format_version": MODEL_FORMAT_VERSION}
        for name, fitted in self.fits.items():
            if name != PAPER:
                out[name] = fitted.to_json()
        return out

    def drive_vs_paper(self) -> tuple[DriveVsPaper, ...]:
        """On the paper's step runs, at each speed the batch's usable motion runs hold: the
        fitted P_acc(v) and P_v(v) with the 95% interval of the line's mean at v (the
        textbook interval of a mean response, Montgomery & Runger Eq. 11-31, over the runs'
        phase means) beside the drive model's mean phase powers with their 95% intervals
        (`drive.profile.step_phase_powers`, the acceleration a ramp over the fitted t_acc(v)).
        Empty without both models. Reads the runs table (pandas)."""
        drive = self.drive
        if drive is None or not self.model_complete:
            return ()
        import numpy as np

        from wifibot_power.drive.profile import step_phase_powers
        from wifibot_power.figures.power_speed import mean_band

        def _band_at(x: np.ndarray, y: object, line: object, v: float) -> tuple[float, float]:
            low, high = mean_band(x, np.asarray(y, dtype=np.float64), line, np.array([v]))
            return (float(low[0]), float(high[0]))

        runs = self.runs
        motion = runs[(runs["mode"] == "motion") & runs["usable"].astype(bool)]
        speeds = np.asarray(motion["speed_mps"], dtype=np.float64)
        out = []
        for v in sorted(set(speeds[np.isfinite(speeds)].tolist())):
            t_acc_s = self.model.t_acc.at(v)
            if not (t_acc_s > 0):
                continue
            powers = step_phase_powers(drive, v, t_acc_s)
            acc = _band_at(speeds, motion["accel_mean_power_W"], self.model.accel, v)
            cruise = _band_at(speeds, motion["cruise_mean_power_W"], self.model.cruise, v)
            out.append(
                DriveVsPaper(
                    speed_mps=v,
                    paper_accel_W=self.model.accel.at(v),
                    paper_accel_ci95=acc,
                    accel_W=powers["accel"][0],
                    accel_ci95=powers["accel"][1],
                    paper_cruise_W=self.model.cruise.at(v),
                    paper_cruise_ci95=cruise,
                    cruise_W=powers["cruise"][0],
                    cruise_ci95=powers["cruise"][1],
                )
            )
        return tuple(out)

    # -- kept by `fit --cache` -----------------------------------------------------------
    def to_json(self) -> dict[str, object]:
        """All but the tables as JSON values (`from_json` is the exact round trip)."""
        return {
            "fits": {name: fitted.to_cache() for name, fitted in self.fits.items()},
            "skipped": [s.as_dict() for s in self.skipped],
            "batch_warnings": list(self.batch_warnings),
            "batch_notes": list(self.batch_notes),
        }

    @classmethod
    def from_json(
        cls,
        kept: object,
        tables: Callable[[], tuple[pd.DataFrame, pd.DataFrame]],
        run_ids: tuple[str, ...] | None = None,
    ) -> FitResult:
        """The result `to_json` kept, with `tables()` making its tables when asked for and
        `run_ids` its runs' (`run_ids`; None: from the tables); KeyError, TypeError or
        ValueError on another layout (or a family not registered)."""
        from wifibot_power.models import FAMILIES

        fits = {name: FAMILIES[name].from_cache(v) for name, v in kept["fits"].items()}  # type: ignore[index]
        if not fits:
            raise KeyError(PAPER)
        return cls(
            fits=fits,
            tables=tables,
            skipped=tuple(Skipped(**s) for s in kept["skipped"]),  # type: ignore[index]
            batch_warnings=tuple(kept["batch_warnings"]),  # type: ignore[index]
            batch_notes=tuple(kept["batch_notes"]),  # type: ignore[index]
            given_run_ids=run_ids,
        )
