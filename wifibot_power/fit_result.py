"""What `fit` returns: every model family's fit of one batch, its tables, what was left out.

`FitResult` holds each family's `FittedModel` by name (`fits`, registry order; the paper's
always), the batch's per-run and per-phase tables (made when first asked for: a command
that only prints the model, e.g. a warm `fit --cache --json`, never loads pandas), the
inputs left out and the batch's own warnings (runs used in doubt). The paper family's
fields read through (`model`, `idle`, `stop_and_go`, ...), as before families.

The `fit --json` document (`summary`) is the paper's section at the top level, then each
other family's under its name; `to_json`/`from_json` are what `fit --cache` keeps of it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from wifibot_power.io import Skipped
from wifibot_power.model import PowerModel
from wifibot_power.models.paper_table import format_number, table_rows, to_markdown
from wifibot_power.outputs import json_safe

if TYPE_CHECKING:
    import pandas as pd

    from wifibot_power.models.base import FittedModel
    from wifibot_power.models.paper import PaperFit
    from wifibot_power.models.paper_fit import MeanEstimate
    from wifibot_power.overhead import StopAndGo

__all__ = ["FitResult", "format_number"]

#: The paper family's name: its section is the top level of `fit --json` and model.json.
PAPER = "paper"


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

    # -- the paper family's fit, read through ------------------------------------------
    @property
    def paper_fit(self) -> PaperFit:
        return self.fits[PAPER]  # type: ignore[return-value]

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
        """Runs the paper's fit used."""
        return self.paper_fit.n_runs

    @property
    def notes(self) -> tuple[str, ...]:
        return self.paper_fit.notes

    @property
    def stop_and_go(self) -> tuple[StopAndGo, ...]:
        return self.paper_fit.stop_and_go

    @property
    def paper(self) -> PowerModel:
        """The paper's own coefficients."""
        return self.paper_fit.reference

    @property
    def model_complete(self) -> bool:
        """Whether every coefficient `energy`/`lifetime` need was fitted (model.json loads)."""
        return self.paper_fit.model_complete

    @property
    def warnings(self) -> tuple[str, ...]:
        """Why the result is weak, implausible or not all there (cli.md `fit --json`
        `warnings`): the batch's, then the paper fit's."""
        return (*self.batch_warnings, *self.paper_fit.warnings)

    # -- the tables --------------------------------------------------------------------
    @functools.cached_property
    def _frames(self) -> tuple[pd.DataFrame, pd.DataFrame]:
        return self.tables()

    @property
    def runs(self) -> pd.DataFrame:
        """A row per readable run (runs.parquet, `runtable.runs_frame`)."""
        return self._frames[0]

    @property
    def phases(self) -> pd.DataFrame:
        """A row per phase of every run (phases.parquet: `Segmentation.frame`'s columns, and
        the run's `file` after its `run_id`)."""
        return self._frames[1]

    # -- said ----------------------------------------------------------------------------
    def summary(self) -> dict[str, object]:
        """The `fit --json` document (cli.md), JSON-safe (NaN -> null): the paper's section
        with the inputs left out and the batch's warnings, then each other family's."""
        section = dict(self.paper_fit.summary())
        tail = {"notes": section.pop("notes"), "warnings": list(self.warnings)}
        del section["warnings"]
        out = {**section, "skipped": [s.as_dict() for s in self.skipped], **tail}
        for name, fitted in self.fits.items():
            if name != PAPER:
                out[name] = fitted.summary()
        return json_safe(out)  # type: ignore[return-value]

    def table_rows(self) -> list[dict[str, object]]:
        """The paper table (`models.paper_table.table_rows`)."""
        return table_rows(self.paper_fit)

    def to_markdown(self) -> str:
        """The paper table as Markdown."""
        return to_markdown(self.paper_fit)

    def model_json(self) -> dict[str, object]:
        """model.json: the paper's model at the top level, each other family's section
        under its name."""
        out = dict(self.paper_fit.to_json())
        for name, fitted in self.fits.items():
            if name != PAPER:
                out[name] = fitted.to_json()
        return out

    # -- kept by `fit --cache` -----------------------------------------------------------
    def to_json(self) -> dict[str, object]:
        """All but the tables as JSON values (`from_json` is the exact round trip)."""
        return {
            "fits": {name: fitted.to_cache() for name, fitted in self.fits.items()},
            "skipped": [s.as_dict() for s in self.skipped],
            "batch_warnings": list(self.batch_warnings),
        }

    @classmethod
    def from_json(
        cls, kept: object, tables: Callable[[], tuple[pd.DataFrame, pd.DataFrame]]
    ) -> FitResult:
        """The result `to_json` kept, with `tables()` making its tables when asked for;
        KeyError, TypeError or ValueError on another layout (or a family not registered)."""
        from wifibot_power.models import FAMILIES

        fits = {name: FAMILIES[name].from_cache(v) for name, v in kept["fits"].items()}  # type: ignore[index]
        if PAPER not in fits:
            raise KeyError(PAPER)
        return cls(
            fits=fits,
            tables=tables,
            skipped=tuple(Skipped(**s) for s in kept["skipped"]),  # type: ignore[index]
            batch_warnings=tuple(kept["batch_warnings"]),  # type: ignore[index]
        )
