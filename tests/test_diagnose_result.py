"""The result of `diagnose` (`diagnose/result.py`): the verdict is decided from the reasons
as data (never from their wording), the notes carry their kind, and `Diagnosis.report()` is
a text report of its own (as lmfit's `fit_report()`), with what the CLI prints."""

from __future__ import annotations

import json

import pytest
from test_diagnose import GRID

from wifibot_power.diagnose import (
    FOLD,
    NOT_NAMED,
    VERDICTS,
    Note,
    diagnose_runs,
    verdict_of,
)
from wifibot_power.simulate import SimConfig, simulate_runs

SPREAD = "the runs' own spread is unknown: 15 runs in 15 configurations"


@pytest.mark.parametrize(
    ("named", "reasons", "spread_unknown", "verdict"),
    [
        (False, [], None, "explained"),
        (True, [], None, "named"),
        (False, [SPREAD], SPREAD, "cannot_tell"),
        (True, [SPREAD], SPREAD, "cannot_tell"),
        (False, ["the error depends on speed", SPREAD], SPREAD, "unexplained"),
        (False, ["decel_phase: its signature is there ...: not named"], None, "unexplained"),
        # a reason worded like the spread's but not it: the verdict reads data, not words
        (False, [SPREAD + " (another)"], SPREAD, "unexplained"),
    ],
)
def test_the_verdict_never_says_explained_while_structure_is_left(
    named, reasons, spread_unknown, verdict
):
    assert verdict_of(named, reasons, spread_unknown) == verdict
    assert verdict in VERDICTS


@pytest.fixture(scope="module")
def named():
    """A batch with a stopping phase the paper's model lacks: decel_phase is named."""
    sims = simulate_runs(SimConfig(**GRID, effects={"decel_phase": 0.5}, seed=11))
    return diagnose_runs([s.run for s in sims])


def test_a_named_diagnosis_reports_itself(named):
    assert [f.cause for f in named.findings] == ["decel_phase"]
    assert named.verdict == ("unexplained" if named.unexplained else "named")
    report = named.report()
    lines = report.splitlines()
    assert lines[0] == f"[[Diagnosis]] {named.verdict_text}"
    (finding,) = named.findings
    assert any(line.strip().startswith("decel_phase: ") for line in lines)
    assert f"gain {finding.gain_pct:.1f}%" in report
    assert "checks passed: a stopping phase visible after each cruise" in report
    assert named.headline() in lines
    assert f"RMSE {named.extended_rmse_J:.3g} J" in named.headline()
    for reason in named.unexplained_reasons:
        assert f"unexplained: {reason}" in lines


def test_notes_carry_their_kind_and_the_json_their_text(named):
    assert all(isinstance(n, Note) for n in named.notes)
    assert {n.kind for n in named.notes} <= {FOLD, NOT_NAMED, "kept_in_doubt", "rejected"}
    document = json.loads(json.dumps(named.summary()))
    assert document["notes"] == [n.text for n in named.notes]
    assert "verdict" not in document  # the --json contract (cli.md) is unchanged
