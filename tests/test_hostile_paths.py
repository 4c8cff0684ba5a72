"""Inputs that are not log files, and manifests that point elsewhere (issue 29): a FIFO named
`x.csv` blocked `open()` forever; a FIFO or a dangling link in a folder was skipped in
silence; a runs.csv read `../../outside.csv` and opened `/etc/shadow`.

Every command here runs under a watchdog (`_run`): a hang fails the test instead of
blocking the suite.
"""

from __future__ import annotations

import gzip
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from wifibot_power.errors import LogError
from wifibot_power.io import find_logs, read_log

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs (POSIX)")

LOG = "# wbpower-log: 1\n# mode: idle\ntime_s,power_W\n" + "".join(
    f"{k * 0.01:.2f},23.{k % 10}\n" for k in range(200)
)
WBPOWER = [sys.executable, "-m", "wifibot_power.cli"]


def _run(*args: object) -> subprocess.CompletedProcess[str]:
    """`wbpower ARGS` with a time limit: the FIFO bug was a hang."""
    return subprocess.run([*WBPOWER, *map(str, args)], capture_output=True, text=True, timeout=60)


def test_a_fifo_named_as_a_log_is_refused_not_waited_on(tmp_path):
    fifo = tmp_path / "x.csv"
    os.mkfifo(fifo)
    result = _run("inspect", fifo)
    assert result.returncode == 2, result.stderr
    assert result.stderr == (
        f"wbpower: error: {fifo}: a FIFO (named pipe), not a regular file (give a file; copy "
        "a stream first)\n"
    )
    with pytest.raises(LogError, match="not a regular file"):
        read_log(fifo)  # the reader itself refuses it too, before open()
    with pytest.raises(LogError, match="not a regular file"):
        read_log(Path("/dev/zero"))  # a device never ends


@pytest.mark.parametrize("name", ["x.jls", "x.bag", "x.mcap"])
def test_a_fifo_named_as_a_recording_is_refused_by_the_reader(tmp_path, name):
    # bags and recordings are opened by their own library (`io/formats/files.py`), not by
    # the CSV transport: the reader refuses what is not a regular file before that too
    fifo = tmp_path / name
    os.mkfifo(fifo)
    with pytest.raises(LogError, match="not a regular file"):
        read_log(fifo)


def test_a_fifo_and_a_dangling_link_in_a_folder_are_listed_as_skipped(tmp_path):
    folder = tmp_path / "logs"
    folder.mkdir()
    (folder / "good.csv").write_text(LOG)
    os.mkfifo(folder / "y.csv")
    (folder / "gone.csv.gz").symlink_to(tmp_path / "nowhere.csv.gz")
    (folder / "notes.txt").write_text("not a log: not looked at")
    result = _run("inspect", folder, "--json")
    assert result.returncode == 1, result.stderr  # skipped inputs: exit 1 (cli.md)
    lines = result.stderr.strip().splitlines()
    assert lines == [
        f"wbpower: skipped: {folder / 'gone.csv.gz'}: not a log: a link to nothing "
        f"({tmp_path / 'nowhere.csv.gz'}) (fix the link or remove it)",
        f"wbpower: skipped: {folder / 'y.csv'}: not a log: a FIFO (named pipe), not a regular "
        "file (give a file; copy a stream first)",
    ]
    assert '"run_id": "good"' in result.stdout


def _manifest_folder(tmp_path: Path) -> tuple[Path, Path]:
    folder = tmp_path / "data" / "logs"
    (folder / "sub").mkdir(parents=True)
    (folder / "sub" / "in.csv").write_text(LOG)
    outside = tmp_path / "outside.csv"
    outside.write_text(LOG)
    with gzip.open(tmp_path / "data" / "secret.csv.gz", "wt") as handle:
        handle.write(LOG)
    manifest = folder / "runs.csv"
    manifest.write_text(
        "file,run_id,mode\n"
        "../../outside.csv,o,idle\n"
        "/etc/shadow,s,idle\n"
        "../secret.csv.gz,x,idle\n"
        "sub/../sub/in.csv,i,idle\n"
    )
    return folder, manifest


@pytest.mark.parametrize("named", ["manifest", "folder"])
def test_manifest_rows_outside_its_folder_are_refused_and_said(tmp_path, named):
    folder, manifest = _manifest_folder(tmp_path)
    sources, skipped = find_logs([manifest if named == "manifest" else folder])
    assert [s.path.name for s in sources] == ["in.csv"]
    assert sources[0].overrides["run_id"] == "i"  # `sub/../sub/in.csv` stays inside
    refused = {s.reason.split("names ")[1].split(",")[0] for s in skipped}
    assert refused == {"'../../outside.csv'", "'/etc/shadow'", "'../secret.csv.gz'"}
    assert all("outside the manifest's folder: not read" in s.reason for s in skipped)
    result = _run("inspect", manifest if named == "manifest" else folder, "--json")
    assert result.returncode == 1
    document = json.loads(result.stdout)  # one document (cli.md): the logs and the skipped
    assert len(document["logs"]) == 1  # one log read
    assert sum("outside the manifest's folder" in s["reason"] for s in document["skipped"]) == 3
    assert result.stderr.count("outside the manifest's folder") == 3


def test_a_manifest_row_naming_a_fifo_says_what_it_is(tmp_path):
    folder = tmp_path / "logs"
    folder.mkdir()
    os.mkfifo(folder / "pipe.csv")
    (folder / "sub").mkdir()
    (folder / "runs.csv").write_text("file,run_id\npipe.csv,p\nmissing.csv,m\nsub,s\n")
    result = _run("inspect", folder / "runs.csv")
    assert result.returncode == 1
    assert "line 2: names 'pipe.csv', which is a FIFO (named pipe)" in result.stderr
    assert "line 3: names 'missing.csv', which does not exist" in result.stderr
    assert "line 4: names 'sub', which is a folder, not a log" in result.stderr
