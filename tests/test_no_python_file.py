"""The path of the unexplained `.gz` segfault is kept impossible (issue 29): an xdist worker
crashed twice while a `.gz` was read through `pa.PythonFile`, a Python file object that
pyarrow's own threads called back into. The reader gives pyarrow paths, native streams and
buffers only; a compressed or cut log is parsed from buffers of whole lines (`_Pieces`).
The stress test that would catch a crash on the path used now: benchmarks/stress_gz.py.
"""

from __future__ import annotations

import ast
import gzip
from pathlib import Path

import pyarrow as pa
import pyarrow.csv as pacsv
import pytest

from wifibot_power.io import read_log

PACKAGE = Path(__file__).resolve().parents[1] / "wifibot_power"
LOG = "time_s,power_W\n" + "".join(f"{k * 0.01:.2f},{23 + k % 7 * 0.1:.1f}\n" for k in range(5000))


def test_no_module_names_python_file():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            name = getattr(node, "attr", None) or getattr(node, "id", None)
            if name == "PythonFile":
                found.append(f"{path.relative_to(PACKAGE)}:{node.lineno}")
    assert found == []


@pytest.mark.parametrize("name", ["plain.csv", "log.csv.gz", "log.csv.zst", "cut.csv.gz"])
def test_pyarrow_is_given_native_streams_and_buffers_only(tmp_path, monkeypatch, name):
    """Every source the CSV parser gets is a path or a pyarrow NativeFile that is not a
    PythonFile: nothing pyarrow's threads read calls back into Python."""
    text = LOG if not name.startswith("cut") else LOG + "51.00,23"  # a cut last line
    path = tmp_path / name
    if name.endswith(".gz"):
        path.write_bytes(gzip.compress(text.encode()))
    elif name.endswith(".zst"):
        with pa.output_stream(str(path), compression="zstd") as out:
            out.write(text.encode())
    else:
        path.write_text(text)
    seen = []
    real = pacsv.read_csv

    def checked(source, *args, **kwargs):
        seen.append(type(source).__name__)
        assert isinstance(source, pa.NativeFile | str), type(source)
        assert not isinstance(source, pa.PythonFile)
        return real(source, *args, **kwargs)

    monkeypatch.setattr(pacsv, "read_csv", checked)
    if name.startswith("cut"):
        with pytest.raises(Exception, match="no line end"):
            read_log(path)
    else:
        assert read_log(path).power_W.size == 5000
    assert seen, "the parse did not go through pyarrow.csv.read_csv: the check saw nothing"
