"""A compressed log is read in pieces of whole lines (`pieces._Pieces`); wherever the
reads end (inside a number, between \\r and \\n, inside a line longer than a read), the
samples, problems and errors are those of the same text read as a plain file (which pyarrow
reads itself, without pieces). Reads of 1-60 bytes here stand in for the 1 MiB of a real read.
"""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from wifibot_power.errors import LogError
from wifibot_power.io import pieces as pieces_module
from wifibot_power.io import read_log

HEAD = "# wbpower-log: 1\n# run_id: p\n# mode: idle\n# sample_period_s: 0.001\ntime_s,power_W\n"


def _read(path: Path) -> tuple[str, object]:
    """What reading gives: the samples and problems, or the error with the path left out."""
    try:
        run = read_log(path)
    except LogError as exc:
        return "error", exc.one_line().replace(str(path), "LOG")
    return "run", (run.time_s.tolist(), run.power_W.tolist(), [p.message for p in run.problems])


def _both(tmp_path: Path, text: str, piece: int, search: int) -> tuple[object, object]:
    plain = tmp_path / "plain" / "log.csv"
    packed = tmp_path / "packed" / "log.csv.gz"
    for path in (plain, packed):
        path.parent.mkdir(exist_ok=True)
    plain.write_bytes(text.encode())
    packed.write_bytes(gzip.compress(text.encode()))
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(pieces_module, "_PIECE_BYTES", piece)
        patch.setattr(pieces_module, "_LINE_END_SEARCH", search)
        return _read(plain), _read(packed)


_BAD = ("x", "", "23.3,1")
_CELLS = st.sampled_from(["23.3", "23.45", "1e1", "24", "-0.5", *_BAD])


@settings(max_examples=150, deadline=None)
@given(
    cells=st.lists(_CELLS, min_size=0, max_size=25),
    end=st.sampled_from(["\n", "\r\n", "\r"]),
    last_end=st.booleans(),
    piece=st.integers(1, 60),
    search=st.integers(1, 9),
)
def test_pieces_read_as_the_plain_file(tmp_path_factory, cells, end, last_end, piece, search):
    # one bad line at most: with two, which pyarrow names first depends on how the lines fall
    # into parse blocks (a field count is checked before a value is converted), for a plain
    # file as much as for pieces
    assume(sum(cell in _BAD for cell in cells) <= 1)
    rows = [f"{k * 0.001:.3f},{cell}" for k, cell in enumerate(cells)]
    text = HEAD.replace("\n", end) + end.join(rows) + (end if last_end or not rows else "")
    plain, packed = _both(tmp_path_factory.mktemp("p"), text, piece, search)
    assert packed == plain


@pytest.mark.parametrize("piece", [3, 17, 64])
def test_many_pieces_of_a_good_log(tmp_path, piece):
    # 2000 samples with a 5-sample gap after sample 999; every value known by construction
    index = np.arange(2000, dtype=np.float64)
    index[1000:] += 5
    power_W = 23.0 + (index % 7) / 10
    rows = zip(index * 1e-3, power_W, strict=True)
    text = HEAD + "".join(f"{t:.3f},{p:.1f}\r\n" for t, p in rows)
    plain, packed = _both(tmp_path, text, piece, 8)
    assert packed == plain
    kind, (time_s, read_W, problems) = packed
    assert kind == "run" and read_W == power_W.tolist() and len(problems) == 1
