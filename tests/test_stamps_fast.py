"""The time checks' short cut for a clocked logger that drops samples gives what the plain
computation gives (io/stamps.py `_regular_spread_s`).

Its gaps' steps made the steps' whole spread, so every such log had its steps' quartiles and
mean taken to find a logger stamping on arrival, or uneven stamps, that cannot be there
when the steps between its gaps lie within half the band. The short cut must give the same
period and problems on any stamps (clocked with gaps, jittered around the bands, stamped on
arrival) and be taken on a clocked log with gaps (else it saves nothing).

A gap's message is written when first read (`GapProblem`: its line number takes a scan of
the file): the same message, fields and equality as before, in the reading process and in
the one a worker sends it to.
"""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wifibot_power.errors import LogError
from wifibot_power.io import stamps
from wifibot_power.io.reader import read_log
from wifibot_power.run import Problem


def _checked(time_s: np.ndarray, period_s: float):
    """`_check_time`'s period, problems (as tuples) and gaps, or the error's message."""
    try:
        found, problems, gaps = stamps._check_time("x.csv", time_s, lambda i: i + 2, period_s)
    except LogError as error:
        return str(error)
    listed = [(p.kind, p.message, p.t_start_s, p.duration_s) for p in problems]
    return found, listed, None if gaps is None else gaps.tolist()


def _plain_spread(step_s, gaps, low_s, high_s, spacing_s):
    return float(high_s - low_s)


@settings(max_examples=300, deadline=None)
@given(
    n=st.integers(50, 3000),
    period_s=st.sampled_from([0.05, 1e-3, 0.153, 1.024e-4]),
    jitter_pct=st.sampled_from([0.0, 0.1, 0.24, 0.26, 0.4, 0.6, 1.0, 2.0, 5.0, 30.0]),
    gaps=st.lists(st.tuples(st.integers(1, 2999), st.integers(1, 3)), max_size=12),
    decimals=st.integers(3, 9),
    seed=st.integers(0, 2**16),
)
def test_the_short_cut_finds_what_the_plain_checks_find(
    n, period_s, jitter_pct, gaps, decimals, seed
):
    rng = np.random.default_rng(seed)
    step = period_s * (1.0 + jitter_pct / 100.0 * rng.uniform(-0.5, 0.5, n - 1))
    for at, dropped in gaps:
        if at < n - 1:
            step[at] += dropped * period_s
    time_s = np.round(np.concatenate(([0.0], np.cumsum(step))), decimals)
    if not (np.diff(time_s) > 0).all():
        return
    fast = _checked(time_s, period_s)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(stamps, "_regular_spread_s", _plain_spread)
        assert _checked(time_s, period_s) == fast


def test_the_short_cut_is_taken_on_a_clocked_log_with_gaps(monkeypatch):
    # an hour at 20 Hz written to 2 decimals (float noise in the steps), 100 dropped samples
    index = np.arange(72_000, dtype=np.float64)
    for at in range(500, 72_000, 700):
        index[at:] += 1
    time_s = np.round(index * 0.05, 2)

    def not_needed(*args):
        raise AssertionError("the steps' quartiles were taken")

    monkeypatch.setattr(stamps, "_stamped_on_arrival", not_needed)
    period_s, problems, gaps = stamps._check_time("x.csv", time_s, lambda i: i + 2, 0.05)
    assert period_s == 0.05 and gaps is None
    assert [p.kind for p in problems] == ["gap"] * 103
    # a step 0.6% long between the gaps is beyond half the band: looked at as before
    time_s[1000:] += 0.05 * 0.006
    with pytest.raises(AssertionError, match="quartiles"):
        stamps._check_time("x.csv", time_s, lambda i: i + 2, 0.05)


def _log_with_gaps(tmp_path):
    """A 20 Hz log of 1000 samples with 2 dropped samples after t = 5 s and 1 after
    t = 12 s, by hand: the rows after its gaps are data rows 102 and 240 (1-based), on
    lines 104 and 242 (after 2 header lines)."""
    index = np.arange(1000, dtype=np.float64)
    index[101:] += 2
    index[239:] += 1
    rows = "".join(f"{0.05 * k:.2f},{10.0 + (j % 7):.1f}\n" for j, k in enumerate(index))
    path = tmp_path / "gaps.csv"
    path.write_text("# run_id: gaps\ntime_s,power_W\n" + rows)
    return path


EXPECTED_GAPS = [
    ("gap", "line 104: 100 ms of samples dropped after t = 5 s", 5.05, 0.1),
    ("gap", "line 242: 50 ms of samples dropped after t = 12 s", 12.05, 0.05),
]


def _listed(problems):
    return [(p.kind, p.message, round(p.t_start_s, 9), round(p.duration_s, 9)) for p in problems]


def test_gap_messages_are_written_when_read_and_survive_a_worker(tmp_path):
    path = _log_with_gaps(tmp_path)
    run = read_log(path)
    gaps = [p for p in run.problems if p.kind == "gap"]
    # read, nothing scanned the file for line numbers yet (the saving)
    line_map = gaps[0]._line_of.__self__
    assert line_map._plain is None and line_map._rows is None
    # as a worker sends them back: the line map goes along, and finds the lines there
    sent = pickle.loads(pickle.dumps(run.problems))
    assert all(isinstance(p, stamps.GapProblem) for p in sent)
    assert _listed(sent) == EXPECTED_GAPS
    assert line_map._plain is None  # (the worker's own map still unscanned)
    # as the reader's own problems: the same, and equal (and hashed) as plain problems
    assert _listed(gaps) == EXPECTED_GAPS
    plain = [Problem(p.kind, p.message, p.t_start_s, p.duration_s) for p in gaps]
    assert gaps == plain and plain == gaps and hash(gaps[0]) == hash(plain[0])
    assert dataclasses.asdict(gaps[1])["message"] == EXPECTED_GAPS[1][1]
    # once written, a gap goes as the plain problem it reads as
    assert type(pickle.loads(pickle.dumps(gaps[0]))) is Problem


def test_gaps_of_bytes_in_memory_are_sent_written(tmp_path):
    path = _log_with_gaps(tmp_path)
    run = read_log(path, data=path.read_bytes())
    sent = pickle.loads(pickle.dumps(run.problems))
    assert [type(p) for p in sent] == [Problem, Problem]
    assert _listed(sent) == EXPECTED_GAPS


def test_a_gap_whose_file_is_gone_names_its_data_row(tmp_path):
    path = _log_with_gaps(tmp_path)
    sent = pickle.loads(pickle.dumps(read_log(path).problems))
    path.unlink()
    assert sent[0].message == (
        "data row 102 (the file could not be read again): 100 ms of samples dropped after t = 5 s"
    )


def test_a_gap_whose_file_changed_since_names_its_data_row(tmp_path):
    """A line inserted after the header between the read and the message (a worker's gaps
    are written in the parent, at the end of a batch): the line number would be the new
    file's (105 for 104); the message names the data row instead."""
    path = _log_with_gaps(tmp_path)
    sent = pickle.loads(pickle.dumps(read_log(path).problems))
    text = path.read_text().replace("time_s,power_W\n", "time_s,power_W\n\n", 1)
    path.write_text(text)
    assert sent[0].message.startswith("data row 102 (the file could not be read again)")
