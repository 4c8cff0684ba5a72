"""Outputs are written atomically: a crash or a SIGKILL mid-write leaves the previous file intact.

The kill tests run a child process that rewrites one output over and over (each version
self-consistent: every value equals the version number) and SIGKILL it at random moments;
after every kill the file must be one complete version, never a mixture or a stub.
"""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from wifibot_power.outputs import (
    dumps_indented,
    json_safe,
    write_atomic,
    write_json,
    write_parquet,
)

CHILD = r"""
import os, sys, time
from pathlib import Path
import numpy as np, pandas as pd
from wifibot_power.outputs import write_atomic, write_json, write_parquet

kind, path = sys.argv[1], Path(sys.argv[2])
rows = 200_000
version = 1
while True:
    if kind == "json":
        write_json(path, {"version": version, "values": [version] * rows})
    elif kind == "parquet":
        write_parquet(path, pd.DataFrame({"version": np.full(rows, version, dtype=np.int64)}))
    else:  # raw write_atomic in chunks, saying when it is half-way, so the kill lands mid-write
        def write(tmp, version=version):
            with open(tmp, "w") as out:
                out.write(f"{version}\n" * rows)
                out.flush()
                print("half", flush=True)
                time.sleep(0.02)
                out.write(f"{version}\n" * rows)
        write_atomic(path, write)
    print("done", version, flush=True)
    version += 1
"""


def _check_complete(kind: str, path: Path) -> int:
    """The version held by the file, asserting it is one complete, self-consistent version."""
    if kind == "json":
        data = json.loads(path.read_text())
        assert len(data["values"]) == 200_000 and set(data["values"]) == {data["version"]}
        return data["version"]
    if kind == "parquet":
        versions = pd.read_parquet(path)["version"]
        assert len(versions) == 200_000 and versions.nunique() == 1
        return int(versions.iloc[0])
    lines = path.read_text().splitlines()
    assert len(lines) == 400_000 and len(set(lines)) == 1
    return int(lines[0])


def _wait_for(child: subprocess.Popen, word: str) -> None:
    while True:
        line = child.stdout.readline()
        assert line, "the writer died on its own"
        if line.startswith(word):
            return


@pytest.mark.parametrize(("kind", "kills"), [("raw", 6), ("json", 4), ("parquet", 4)])
def test_sigkill_mid_write_leaves_the_previous_output_intact(tmp_path, kind, kills):
    rng = np.random.default_rng(7)
    path = tmp_path / f"out.{kind}"
    seen = 0
    for _ in range(kills):
        child = subprocess.Popen(
            [sys.executable, "-c", CHILD, kind, str(path)],
            stdout=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        try:
            _wait_for(child, "done")  # at least one complete version exists
            if kind == "raw":
                _wait_for(child, "half")  # mid-write for sure
                time.sleep(rng.uniform(0.0, 0.015))
            else:
                time.sleep(rng.uniform(0.0, 0.3))  # anywhere in the write loop
            child.send_signal(signal.SIGKILL)
        finally:
            child.kill()
            child.wait(timeout=30)
            child.stdout.close()
        version = _check_complete(kind, path)
        assert version >= 1
        seen += 1
    assert seen == kills
    if kind == "raw":
        # the kills did land mid-write: their temporary files are what is left beside the output
        assert list(tmp_path.glob(".out.raw.*.tmp"))


def test_a_failing_write_keeps_the_old_file_and_leaves_no_temp(tmp_path):
    path = write_json(tmp_path / "model.json", {"version": 1})

    def half_then_crash(tmp: Path) -> None:
        tmp.write_text('{"version": 2, "trunc')
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        write_atomic(path, half_then_crash)
    assert json.loads(path.read_text()) == {"version": 1}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json"]


def test_outputs_get_ordinary_permissions(tmp_path):
    path = write_json(tmp_path / "a.json", {"a": 1})
    mask = os.umask(0)
    os.umask(mask)
    # what open() would have made: 0666 less the umask (mkstemp alone would give 0600)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~mask


def test_parquet_and_json_round_trip(tmp_path):
    frame = pd.DataFrame({"run_id": ["a", "b"], "energy_J": [1.5, np.nan]})
    back = pd.read_parquet(write_parquet(tmp_path / "runs.parquet", frame))
    pd.testing.assert_frame_equal(back, frame)
    data = {
        "x_W": np.float64(2.5),
        "n": np.int64(3),
        "bad": float("inf"),
        "arr": np.array([1, 2]),
        "when": datetime(2015, 6, 1, tzinfo=UTC),
        "file": Path("a/b.csv"),
        "t": (1, 2),
    }
    written = json.loads(write_json(tmp_path / "d.json", data).read_text())
    assert written == {
        "x_W": 2.5,
        "n": 3,
        "bad": None,
        "arr": [1, 2],
        "when": "2015-06-01T00:00:00+00:00",
        "file": "a/b.csv",
        "t": [1, 2],
    }


def test_json_safe_nested_nan_becomes_null():
    assert json_safe({"a": [np.nan, {"b": np.float32(1.5)}]}) == {"a": [None, {"b": 1.5}]}


# -- write_set: the files of one `-o DIR`, all new or all as they were ---------------------


def _old_set(folder: Path) -> dict[str, str]:
    folder.mkdir()
    old = {"a.json": "old a", "b.json": "old b", "model.json": "old model"}
    for name, text in old.items():
        (folder / name).write_text(text)
    return old


def _contents(folder: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in sorted(folder.iterdir())}


@pytest.mark.parametrize("stop", [OSError(28, "No space left on device"), KeyboardInterrupt()])
def test_write_set_stopped_part_way_leaves_the_old_set(tmp_path, stop):
    from wifibot_power.outputs import json_file, write_set

    folder = tmp_path / "out"
    old = _old_set(folder)

    def fails(path: Path) -> None:
        path.write_text("half")
        raise stop

    with pytest.raises(type(stop)):
        write_set(folder, {"a.json": json_file("new a"), "b.json": fails}, remove=["model.json"])
    # nothing replaced, nothing removed (model.json included), no temporary file left
    assert _contents(folder) == old


def test_write_set_replaces_and_removes_together(tmp_path):
    from wifibot_power.outputs import json_file, write_set

    folder = tmp_path / "out"
    _old_set(folder)
    written = write_set(
        folder, {"a.json": json_file("new a"), "c.json": json_file([1])}, remove=["model.json"]
    )
    assert written == [folder / "a.json", folder / "c.json"]
    assert _contents(folder) == {"a.json": '"new a"\n', "b.json": "old b", "c.json": "[\n  1\n]\n"}


def test_write_set_into_a_new_folder_stopped_leaves_no_folder(tmp_path):
    from wifibot_power.outputs import write_set

    def fails(path: Path) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_set(tmp_path / "new" / "out", {"a.json": fails})
    assert list(tmp_path.iterdir()) == []


@pytest.fixture
def sigint_as_in_a_terminal():
    """SIGINT raising KeyboardInterrupt, as Python sets it up in a foreground job, whatever
    this test process inherited: a background job (`make test &`, a CI wrapper) starts with
    SIGINT ignored, and Python then leaves it ignored (issue 28)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_ctrl_c_during_the_renames_comes_after_them(tmp_path, sigint_as_in_a_terminal):
    from wifibot_power.outputs import hold_ctrl_c

    done = []
    with pytest.raises(KeyboardInterrupt):
        with hold_ctrl_c():
            signal.raise_signal(signal.SIGINT)  # as a Ctrl-C between two renames
            done.append("the rest of the renames")
    assert done == ["the rest of the renames"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_process_that_ignores_ctrl_c_still_ignores_it_after_the_renames(tmp_path):
    """Started with SIGINT ignored (a background job): the held Ctrl-C is not turned into
    a KeyboardInterrupt, and SIGINT is left ignored, as it was."""
    from wifibot_power.outputs import hold_ctrl_c

    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with hold_ctrl_c():
            signal.raise_signal(signal.SIGINT)
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


def test_diagnose_out_is_written_as_one_set(tmp_path, monkeypatch):
    # diagnose -o wrote its three files one at a time: stopped at the third, the first two
    # were the new run's beside the old model.json (cli.md: "writes nothing partial")
    from types import SimpleNamespace

    import pandas as pd

    from wifibot_power.diagnose import write_diagnosis

    folder = tmp_path / "out"
    folder.mkdir()
    old = {"discrepancy.parquet": "old", "findings.json": "old", "model.json": "old"}
    for name, text in old.items():
        (folder / name).write_text(text)
    result = SimpleNamespace(
        runs=pd.DataFrame({"run_id": ["a"], "measured_energy_J": [1.0]}),
        summary=lambda: {"findings": []},
        extended_model=SimpleNamespace(to_json=lambda: {"model": "new"}),
    )
    real_write_text = Path.write_text

    def write_text(path: Path, *args, **kwargs):
        if "model.json" in path.name:  # Ctrl-C while model.json (or its temporary) is written
            raise KeyboardInterrupt
        return real_write_text(path, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", write_text)
    with pytest.raises(KeyboardInterrupt):
        write_diagnosis(result, folder)
    monkeypatch.undo()
    assert {p.name: p.read_bytes() for p in sorted(folder.iterdir())} == {
        name: text.encode() for name, text in old.items()
    }
    written = write_diagnosis(result, folder)
    assert [p.name for p in written] == list(old)
    assert json.loads((folder / "model.json").read_text()) == {"model": "new"}


def test_a_staged_folder_put_in_place_has_the_modes_mkdir_gives(tmp_path):
    # mkdtemp's 0700 came along with the rename: `report -o NEW` was readable by no one else
    from wifibot_power.outputs import staged_folder

    with staged_folder(tmp_path / "report") as stage:
        (stage / "report.html").write_text("<html></html>")
    (tmp_path / "plain").mkdir()
    mode = (tmp_path / "report").stat().st_mode & 0o777
    assert mode == (tmp_path / "plain").stat().st_mode & 0o777


def test_write_set_with_a_folder_in_a_target_s_place_replaces_nothing(tmp_path):
    # the rename onto a folder failed after the files before it were replaced, and the
    # temporary files were left behind
    from wifibot_power.outputs import json_file, write_set

    folder = tmp_path / "out"
    old = _old_set(folder)
    (folder / "b.json").unlink()
    del old["b.json"]
    (folder / "b.json").mkdir()
    (folder / "b.json" / "x").write_text("x")
    with pytest.raises(IsADirectoryError) as error:
        write_set(folder, {"a.json": json_file("new a"), "b.json": json_file("new b")})
    assert error.value.filename == str(folder / "b.json")
    assert {p.name for p in folder.iterdir()} == {*old, "b.json"}  # no temporary file left
    assert {n: (folder / n).read_text() for n in old} == old


# -- issue 29: one writer per folder, what a killed writer left, errors naming the file ---


def test_a_second_writer_on_a_locked_folder_is_refused_and_changes_nothing(tmp_path):
    import fcntl

    from wifibot_power.errors import UsageError
    from wifibot_power.outputs import json_file, write_set

    folder = tmp_path / "out"
    old = _old_set(folder)
    held = os.open(folder, os.O_RDONLY)  # another writer, in the middle of its set
    try:
        fcntl.flock(held, fcntl.LOCK_EX)
        with pytest.raises(UsageError, match="another wbpower is writing into this folder"):
            write_set(folder, {"a.json": json_file("new a")}, remove=["model.json"])
        assert _contents(folder) == old
    finally:
        os.close(held)
    write_set(folder, {"a.json": json_file("new a")})  # released: written
    assert _contents(folder)["a.json"] == '"new a"\n'


def test_two_fits_on_one_folder_at_once_never_mix_their_sets(tmp_path):
    """Two writers racing on one folder (the issue's repro, in-process): each set is written
    whole under the lock or refused; the folder holds one writer's complete set."""
    import threading

    from wifibot_power.errors import UsageError
    from wifibot_power.outputs import write_set

    folder = tmp_path / "out"
    folder.mkdir()
    barrier = threading.Barrier(2)
    outcome: dict[str, str] = {}

    def slow(text: str):
        def write(path: Path) -> None:
            path.write_text(text)
            time.sleep(0.05)  # both writers are writing at once

        return write

    def writer(tag: str) -> None:
        barrier.wait()
        try:
            write_set(folder, {"model.json": slow(tag), "runs.parquet": slow(tag)})
            outcome[tag] = "written"
        except UsageError:
            outcome[tag] = "refused"

    threads = [threading.Thread(target=writer, args=(tag,)) for tag in "AB"]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert sorted(outcome.values()) == ["refused", "written"], outcome
    winner = next(tag for tag, what in outcome.items() if what == "written")
    assert _contents(folder) == {"model.json": winner, "runs.parquet": winner}


def test_temporary_files_a_killed_writer_left_are_removed_by_the_next(tmp_path):
    from wifibot_power.outputs import json_file, write_set

    folder = tmp_path / "out"
    old = _old_set(folder)
    (folder / ".a.json.k3j9x.tmp").write_text("")  # SIGKILL mid-write left it
    (folder / ".other.txt.zz.tmp").write_text("not ours")
    write_set(folder, {"a.json": json_file("new a")})
    assert _contents(folder) == {**old, "a.json": '"new a"\n', ".other.txt.zz.tmp": "not ours"}


def test_a_file_too_large_or_disk_full_error_names_the_file(tmp_path):
    """`ulimit -f` as a full disk: the error names the output that could not be written
    (pyarrow's own error names none)."""
    import resource

    out = tmp_path / "out"
    logs = Path(__file__).resolve().parents[1] / "sample_logs"

    def small_files() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (8 << 10, 8 << 10))

    result = subprocess.run(
        [sys.executable, "-m", "wifibot_power.cli", "fit", str(logs), "-o", str(out)],
        capture_output=True,
        text=True,
        preexec_fn=small_files,
    )
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "File too large" in lines[0], result.stderr
    assert lines[0].startswith(f"wbpower: error: {out}/") and ".parquet: cannot write" in lines[0]
    assert not out.exists()


def test_ctrl_c_in_the_renames_exits_3_saying_the_set_was_written(tmp_path, wbpower, monkeypatch):
    """A Ctrl-C (or SIGTERM) that comes during the final renames is acted on after them: the
    new set is complete, and the exit code says so (3), not 130 ("nothing written")."""
    import wifibot_power.outputs as outputs

    real = outputs._fsync_dir

    def signal_in_the_renames(folder: Path) -> None:
        signal.raise_signal(signal.SIGINT)  # held until the renames are done
        real(folder)

    monkeypatch.setattr(outputs, "_fsync_dir", signal_in_the_renames)
    out = tmp_path / "out"
    logs = Path(__file__).resolve().parents[1] / "sample_logs"
    result = wbpower("inspect", logs, "-o", out)
    assert result.exit_code == 3, result.stderr
    assert result.stderr.strip().endswith(f"interrupted after writing {out}/logs.parquet in full")
    assert (out / "logs.parquet").is_file()
    # before the renames: nothing written, 130
    monkeypatch.setattr(outputs, "_fsync_dir", real)
    monkeypatch.setattr(outputs, "_lock_folder", lambda folder: signal.raise_signal(2))
    result = wbpower("inspect", logs, "-o", tmp_path / "other")
    assert result.exit_code == 130, result.stderr
    assert not (tmp_path / "other").exists()


def test_sigterm_while_writing_leaves_no_temporary_file(tmp_path):
    """SIGTERM in the middle of a write (the issue: a 0-byte `.runs.parquet.*.tmp` was left
    in a new folder): handled as Ctrl-C, the temporary file and the new folder removed."""
    from wifibot_power import signals
    from wifibot_power.outputs import json_file, write_set

    def terminated(path: Path) -> None:
        signal.raise_signal(signal.SIGTERM)

    previous = signal.getsignal(signal.SIGTERM)
    signals.install()
    try:
        with pytest.raises(signals.Terminated):
            write_set(tmp_path / "new", {"a.json": json_file(1), "runs.parquet": terminated})
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not Path("/proc/self").exists(), reason="needs Linux's /proc")
def test_an_output_folder_that_cannot_be_made_is_refused_before_the_work(wbpower, monkeypatch):
    """`-o /proc/out`: access(2) lets root write /proc, mkdir does not; refused before any log
    is read (fit_logs is never called), naming the folder."""
    import wifibot_power.fit as fit

    def no_work(*args, **kwargs):
        raise AssertionError("the work was done before the output folder was checked")

    monkeypatch.setattr(fit, "fit_logs", no_work)
    result = wbpower("fit", Path(__file__).resolve().parents[1] / "sample_logs", "-o", "/proc/out")
    assert result.exit_code == 2
    assert result.stderr.startswith("wbpower: error: -o /proc/out: cannot create anything in /proc")


# -- issue 29 (leftovers): report's staged folder, energy/lifetime/export -o ---------------


def _held_lock(folder: Path) -> int:
    """Another writer holding `folder`'s lock (flock on another open file description)."""
    import fcntl

    held = os.open(folder, os.O_RDONLY)
    fcntl.flock(held, fcntl.LOCK_EX)
    return held


def test_a_staged_folder_is_refused_while_another_writer_holds_the_folder(tmp_path):
    """`report -o DIR` built its staged folder with no lock: two reports at once swapped
    their entries into DIR in turn (one's page beside the other's figures)."""
    from wifibot_power.errors import UsageError
    from wifibot_power.outputs import staged_folder

    folder = tmp_path / "out"
    old = _old_set(folder)
    held = _held_lock(folder)
    try:
        with pytest.raises(UsageError, match="another wbpower is writing into this folder"):
            with staged_folder(folder) as stage:
                (stage / "a.json").write_text("new a")
        assert _contents(folder) == old
        assert [p.name for p in tmp_path.iterdir()] == ["out"]  # no stage left beside it
    finally:
        os.close(held)
    with staged_folder(folder) as stage:  # released: put in place
        (stage / "a.json").write_text("new a")
    assert _contents(folder) == {**old, "a.json": "new a"}


def test_a_staged_folder_holds_the_lock_until_it_is_in_place(tmp_path):
    """While the new entries are built, a `write_set` into the same folder is refused."""
    from wifibot_power.errors import UsageError
    from wifibot_power.outputs import json_file, staged_folder, write_set

    folder = tmp_path / "new"
    with staged_folder(folder) as stage:
        (stage / "report.html").write_text("page")
        with pytest.raises(UsageError, match="another wbpower is writing"):
            write_set(folder, {"model.json": json_file(1)})
    assert _contents(folder) == {"report.html": "page"}


def test_a_staged_folder_for_a_new_folder_stopped_leaves_nothing(tmp_path):
    from wifibot_power.outputs import staged_folder

    with pytest.raises(KeyboardInterrupt):
        with staged_folder(tmp_path / "a" / "report") as stage:
            (stage / "report.html").write_text("page")
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def _fail_second_parquet(monkeypatch) -> None:
    """Writing the second Parquet file of a command fails (disk full), the first succeeds."""
    real = pd.DataFrame.to_parquet
    calls = []

    def to_parquet(frame, path, *args, **kwargs):
        calls.append(path)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        return real(frame, path, *args, **kwargs)

    monkeypatch.setattr(pd.DataFrame, "to_parquet", to_parquet)


def test_energy_out_is_written_as_one_set(tmp_path, wbpower, monkeypatch):
    """`energy -o DIR` wrote energy_phases.parquet, then energy.parquet, one at a time:
    stopped at the second, the folder held a new phase table beside the old trip's row."""
    out = tmp_path / "out"
    first = wbpower("energy", "--speed", "0.5", "--dist", "10", "--steps", "2", "-o", out)
    assert first.exit_code == 0, first.stderr
    old = {p.name: p.read_bytes() for p in sorted(out.iterdir())}
    assert set(old) == {"energy.parquet", "energy_phases.parquet"}
    _fail_second_parquet(monkeypatch)
    again = wbpower("energy", "--speed", "0.9", "--dist", "20", "--steps", "5", "-o", out)
    assert again.exit_code == 2, again.stderr
    assert "No space left on device" in again.stderr
    assert {p.name: p.read_bytes() for p in sorted(out.iterdir())} == old


@pytest.mark.parametrize(
    "args",
    [
        ("energy", "--speed", "0.5", "--dist", "10", "--steps", "2"),
        ("energy", "--sweep", "speed"),
        ("lifetime", "--rate", "54"),
        ("lifetime", "--sweep", "rate"),
    ],
    ids=["energy", "energy-sweep", "lifetime", "lifetime-sweep"],
)
def test_energy_and_lifetime_out_take_the_folder_lock_and_count_as_written(
    tmp_path, wbpower, monkeypatch, args
):
    """One writer per folder, and a Ctrl-C during the renames exits 3 naming the files (it
    exited 130, "nothing written", with the files in place)."""
    import wifibot_power.outputs as outputs

    out = tmp_path / "out"
    out.mkdir()
    held = _held_lock(out)
    try:
        locked = wbpower(*args, "-o", out)
    finally:
        os.close(held)
    assert locked.exit_code == 2, locked.stderr
    assert "another wbpower is writing into this folder now" in locked.stderr
    assert list(out.iterdir()) == []
    real = outputs._fsync_dir

    def signal_in_the_renames(folder: Path) -> None:
        signal.raise_signal(signal.SIGINT)  # held until the renames are done
        real(folder)

    monkeypatch.setattr(outputs, "_fsync_dir", signal_in_the_renames)
    result = wbpower(*args, "-o", out)
    assert result.exit_code == 3, result.stderr
    line = result.stderr.strip().splitlines()[-1]
    assert line.startswith("wbpower: error: interrupted after writing ") and line.endswith(
        " in full"
    )
    listed = line.removeprefix("wbpower: error: interrupted after writing ").removesuffix(
        " in full"
    )
    names = {p.name for p in out.iterdir()}
    assert names and all(name.endswith(".parquet") for name in names)
    assert set(listed.split(", ")) == {str(out / name) for name in names}


def test_export_out_counts_as_written_and_takes_the_folder_lock(tmp_path, wbpower, monkeypatch):
    """`export -o FILE` interrupted once the file was in place exited 130 ("nothing
    written"): now 3, naming it; and it waits for no other writer of that folder."""
    from test_export import drive_section

    import wifibot_power.outputs as outputs

    model = tmp_path / "model.json"
    model.write_text(json.dumps({"format": "wbpower-model", "drive": drive_section()}))
    out = tmp_path / "out" / "power.yaml"
    out.parent.mkdir()
    held = _held_lock(out.parent)
    try:
        locked = wbpower("export", "--model", model, "--to", "rmf", "--turn-rate", "0.5", "-o", out)
    finally:
        os.close(held)
    assert locked.exit_code == 2, locked.stderr
    assert "another wbpower is writing into this folder now" in locked.stderr
    assert not out.exists()
    real = outputs._fsync_dir

    def signal_in_the_renames(folder: Path) -> None:
        signal.raise_signal(signal.SIGINT)
        real(folder)

    monkeypatch.setattr(outputs, "_fsync_dir", signal_in_the_renames)
    result = wbpower("export", "--model", model, "--to", "rmf", "--turn-rate", "0.5", "-o", out)
    assert result.exit_code == 3, result.stderr
    assert result.stderr.strip().endswith(f"interrupted after writing {out} in full")
    assert out.read_text().strip()
    assert [p.name for p in out.parent.iterdir()] == ["power.yaml"]  # no temporary file


class _Label(str):
    """A str subclass (as a StrEnum): json encodes it as its text."""


class _Count(int):
    """An int subclass (as an IntEnum): json encodes it as its number."""


_leaves = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.sampled_from(
        [
            np.float64(np.nan),
            np.float32(1.5),
            np.int64(-3),
            np.bool_(True),
            Path("a/b.csv"),
            datetime(2026, 11, 28, 1, 2, 3, tzinfo=UTC),
            np.arange(3.0),
            np.array([np.inf, 2.0]),
            _Label("turn"),
            _Count(7),
            '\u00e9\u2019\n"\\',
            np.float64(-0.0),
        ]
    ),
)
_documents = st.recursive(
    _leaves,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.lists(inner, max_size=3).map(tuple),
        st.dictionaries(
            st.one_of(st.text(max_size=5), st.integers(), st.booleans()), inner, max_size=4
        ),
    ),
    max_leaves=30,
)


@settings(max_examples=400, deadline=None)
@given(_documents)
@example({"False": None, False: None})  # two keys that are one once made text (found so)
@example({1: "a", "1": "b"})
@example({2: {"x": 1}, "2": 3})  # the outer collision, a dict inside between
@example({"a": {1: 0, "1": 2}, "b": 1})
def test_dumps_indented_is_json_dumps_of_json_safe_character_for_character(document):
    """The fast encoder's text is the standard library's, indent 2, for any document: numpy
    scalars and arrays, NaN and inf, non-ASCII and escaped text, tuples, non-str keys, str
    and int subclasses, empty containers at any depth."""
    expected = json.dumps(json_safe(document), indent=2, allow_nan=False)
    assert dumps_indented(document) == expected


def test_dumps_indented_refuses_what_json_cannot_hold():
    with pytest.raises(TypeError, match="not JSON serializable"):
        dumps_indented({"a": [1, object()]})
