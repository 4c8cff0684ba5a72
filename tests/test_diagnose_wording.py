"""A candidate's summary is worded from its estimate's sign and size (issue 27: no "curves
upward" beside a negative k2)."""

from __future__ import annotations

from test_diagnose import _diagnose


def test_a_negative_k2_is_never_said_to_curve_upward():
    """Phase power that curves downward with speed (k2 < 0, a size no drag has): the
    speed_quadratic candidate's summary says downward, and its estimate is negative."""
    result, _ = _diagnose({"speed_quadratic": -5.0}, 41)
    (e,) = [e for e in result.evidence if e.cause == "speed_quadratic"]
    assert e.estimate < 0 and e.ci95[1] < 0
    assert "upward" not in e.summary
    assert "curves downward" in e.summary
    assert "speed_quadratic" not in [f.cause for f in result.findings]


def test_a_positive_k2_curves_upward():
    result, _ = _diagnose({"speed_quadratic": 5.0}, 41)
    (e,) = [e for e in result.evidence if e.cause == "speed_quadratic"]
    assert e.ci95[0] > 0 and "curves upward" in e.summary
