"""The result of `diagnose`: each finding (`Finding`), the notes it carries (`Note`, with
their kind), the verdict, and the diagnosis (`Diagnosis`), with its JSON summary (cli.md)
and a text report of its own (`Diagnosis.report`, as lmfit's `fit_report()`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from wifibot_power.causes import Check, Evidence
from wifibot_power.diagnose.folds import gain_pct

if TYPE_CHECKING:
    import pandas as pd

    from wifibot_power.io import Skipped
    from wifibot_power.model import PowerModel

#: Kinds of note: runs used with their segmentation in doubt (said first, and a warning:
#: cli.md), a candidate rejected by a consequence check (also an unexplained reason), a
#: significant candidate not named (too small a size or gain, or a gain not estimable), and
#: a held-out fold whose causes were chosen otherwise.
KEPT_IN_DOUBT = "kept_in_doubt"
REJECTED = "rejected"
NOT_NAMED = "not_named"
FOLD = "fold"

#: What the diagnosis concludes, by `Diagnosis.verdict`.
VERDICTS = {
    "explained": "the paper's model explains these runs",
    "named": "the named causes explain these runs",
    "unexplained": "no catalogue cause explains what is left",
    "cannot_tell": "cannot tell: too few repeated runs to judge",
}


@dataclass(frozen=True)
class Note:
    """A sentence the diagnosis adds, and its kind (`KEPT_IN_DOUBT`, `REJECTED`,
    `NOT_NAMED`, `FOLD`)."""

    kind: str
    text: str

    def __str__(self) -> str:
        return self.text


@dataclass(frozen=True)
class Finding:
    cause: str
    summary: str
    metric: str
    gain_pct: float
    p_value: float
    estimate: dict[str, object]
    checks: tuple[Check, ...] = ()
    #: the 95% interval of `gain_pct` over fold deals and the runs drawn (`intervals`) [%]
    gain_ci95: tuple[float, float] = (math.nan, math.nan)

    def as_dict(self) -> dict[str, object]:
        return {
            "cause": self.cause,
            "summary": self.summary,
            "metric": self.metric,
            "gain_pct": self.gain_pct,
            "gain_ci95": list(self.gain_ci95),
            "p_value": self.p_value,
            "estimate": self.estimate,
            "checks": [c.as_dict() for c in self.checks],
        }

    def estimate_text(self) -> str:
        """'value unit [low, high]' of its headline parameter."""
        low, high = self.estimate["ci95"]  # type: ignore[misc]
        ci = f"[{low:.4g}, {high:.4g}]" if math.isfinite(low) else "-"
        return f"{self.estimate['value']:.4g} {self.estimate['unit']} {ci}"

    def gain_text(self) -> str:
        """'gain% [low, high]' (`gain_ci95`)."""
        return gain_text(self.gain_pct, self.gain_ci95)


def gain_text(gain: float, ci95: tuple[float, float]) -> str:
    """A held-out gain with its 95% interval: '93.1% [90.2, 95.0]'."""
    low, high = ci95
    ci = f" [{low:.1f}, {high:.1f}]" if math.isfinite(low) else ""
    return f"{gain:.1f}%{ci}"


def verdict_of(named: bool, reasons: list[str], spread_unknown: str | None) -> str:
    """The key of `VERDICTS`: never "explained" while structure is left (cli.md); "cannot
    tell" when the only reason is that the runs' own spread is unknown (`residuals.
    unknown_spread`)."""
    if not reasons:
        return "named" if named else "explained"
    if spread_unknown is not None and reasons == [spread_unknown]:
        return "cannot_tell"
    return "unexplained"


@dataclass(frozen=True)
class Diagnosis:
    """The result of `diagnose`: a JSON summary (cli.md) plus the tables behind it."""

    n_runs: int
    baseline_model: PowerModel
    extended_model: PowerModel
    runs: pd.DataFrame  # a row per motion run: measured, baseline and extended energy
    findings: tuple[Finding, ...]
    evidence: tuple[Evidence, ...]
    baseline_rmse_J: float
    baseline_mape_pct: float
    extended_rmse_J: float
    extended_mape_pct: float
    #: the extended model's held-out RMSE with its causes chosen on all runs, only their fit
    #: held out (not nested; `extended_rmse_J` is): how much choosing on all runs flatters
    extended_fixed_rmse_J: float
    #: the 95% interval of `gain_pct` over fold deals and the runs drawn (`intervals`) [%]
    gain_ci95: tuple[float, float]
    unexplained: bool
    unexplained_reasons: tuple[str, ...]
    patterns: dict[str, object]
    skipped: tuple[Skipped, ...] = ()
    notes: tuple[Note, ...] = field(default_factory=tuple)
    baseline_label: str = "paper (Eq. 1-6) fitted to these logs"
    #: candidates that predicted but failed a consequence check (`rejected_candidates`)
    rejected: tuple[dict[str, object], ...] = ()
    #: every candidate's checks as last run, by cause
    candidate_checks: dict[str, list[Check]] = field(default_factory=dict)
    #: each cause's per-run trace data (`Cause.run_trace`), by cause, then run_id: what
    #: its trace metric and its figure panels read
    traces: dict[str, dict[str, object]] = field(default_factory=dict)
    #: what it concludes: a key of `VERDICTS` (`verdict_of`)
    verdict: str = "explained"

    @property
    def gain_pct(self) -> float:
        return gain_pct(self.baseline_rmse_J, self.extended_rmse_J)

    def gain_text(self) -> str:
        """The overall held-out gain with its 95% interval: '93.1% [90.2, 95.0]'."""
        return gain_text(self.gain_pct, self.gain_ci95)

    @property
    def verdict_text(self) -> str:
        return VERDICTS[self.verdict]

    def summary(self) -> dict[str, object]:
        """The `diagnose --json` document (cli.md)."""
        return {
            "n_runs": self.n_runs,
            "baseline": {
                "model": self.baseline_label,
                "heldout_rmse_J": self.baseline_rmse_J,
                "heldout_mape_pct": self.baseline_mape_pct,
            },
            "findings": [f.as_dict() for f in self.findings],
            "extended": {
                "causes": [f.cause for f in self.findings],
                "heldout_rmse_J": self.extended_rmse_J,
                "heldout_mape_pct": self.extended_mape_pct,
            },
            "gain_pct": self.gain_pct,
            "gain_ci95": list(self.gain_ci95),
            "unexplained": self.unexplained,
            "unexplained_reasons": list(self.unexplained_reasons),
            "candidates": [
                {
                    **evidence_dict(e),
                    "named": e.cause in {f.cause for f in self.findings},
                    "checks": [c.as_dict() for c in self.candidate_checks.get(e.cause, [])],
                }
                for e in self.evidence
            ],
            "rejected": list(self.rejected),
            "patterns": self.patterns,
            "notes": [note.text for note in self.notes],
            "skipped": [s.as_dict() for s in self.skipped],
        }

    def headline(self) -> str:
        """The held-out errors of the baseline and the extended model, and the gain."""
        causes = ", ".join(f.cause for f in self.findings) or "nothing added"
        return (
            f"{self.n_runs} motion runs, K-fold held out by run. Baseline "
            f"({self.baseline_label}): RMSE {self.baseline_rmse_J:.3g} J, MAPE "
            f"{self.baseline_mape_pct:.3g}%. Extended ({causes}; chosen and fitted without "
            f"each held-out fold): RMSE {self.extended_rmse_J:.3g} J, MAPE "
            f"{self.extended_mape_pct:.3g}%. Gain {gain_text(self.gain_pct, self.gain_ci95)} "
            "(95% interval over fold deals and runs)."
        )

    def report(self) -> str:
        """A text report: the verdict, each finding with its estimate, p-value, gain and
        the checks it passed, the held-out errors, what is left unexplained and the
        notes (those not already given as a reason)."""
        lines = [f"[[Diagnosis]] {self.verdict_text}"]
        for f in self.findings:
            lines.append(
                f"    {f.cause}: {f.estimate_text()}, p = {f.p_value:.2g}, gain "
                f"{f.gain_text()} ({f.metric})"
            )
            lines.append(f"        {f.summary}")
            passed = ", ".join(c.check for c in f.checks if c.passed)
            lines.append(f"        checks passed: {passed}")
        lines.append(self.headline())
        lines += [f"unexplained: {reason}" for reason in self.unexplained_reasons]
        lines += [f"note: {note.text}" for note in self.notes if note.kind != REJECTED]
        return "\n".join(lines)


def evidence_dict(e: Evidence) -> dict[str, object]:
    return {
        "cause": e.cause,
        "testable": e.testable,
        "p_value": e.p_value,
        "estimate": e.estimate,
        "ci95": list(e.ci95),
        "significant": e.significant,
        "summary": e.summary,
    }
