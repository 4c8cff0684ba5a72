"""Ctrl-C (cli.md): a real SIGINT to the process group, as a terminal sends it, while
`fit --cache` works with worker processes. The command stops promptly, prints one line
and no traceback, leaves no worker, writes nothing partial and exits 130.

(Seen before this test: `Exception in initializer ... pyarrow.set_cpu_count(threads)
KeyboardInterrupt` printed by each worker, and a hang of over 30 s at exit.)
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest

from wifibot_power import parallel
from wifibot_power.simulate import SimConfig, WriteOptions, write_simulation

pytestmark = pytest.mark.skipif(
    not (sys.platform.startswith("linux") and parallel.can_fork()),
    reason="process groups read from /proc, workers forked: Linux only",
)

#: enough work that the workers are still busy when the signal comes: 8 runs at the paper's
#: 0.1024 ms (~2 MB each; a cold `fit` of them takes ~2 s on 2 busy cores)
#: Slow runs (72 MB in all), so that the parse still runs well past the 0.3 s after the
#: workers start at which the test interrupts it: with 13 MB (speeds 0.3-0.9 m/s, 2 repeats)
#: the work was done in about 0.4 s on an idle machine, and the SIGINT sometimes landed
#: while `fit -o` wrote its outputs (1 run in 4 failed "wrote outputs of an interrupted
#: fit"). (The -o set was not then written as a set; it is now, `outputs.write_set`:
#: docs/errors.md, "Outputs are never left half-written".)
CORPUS = SimConfig(
    speeds_mps=(0.1, 0.15, 0.2, 0.3),
    trips=((10.0, 1),),
    repeats=4,
    modes=(),
    seed=5,
)
#: measured: the command exits 0.1-0.5 s after the signal on 2 cores shared by 7 test
#: runs; a worker stuck in C code is killed after parallel.STOP_GRACE_S (1.5 s)
PROMPT_S = 3.0
#: the command as a user runs it: the venv's script (python -m where it is not installed)
_SCRIPT = Path(sys.executable).with_name("wbpower")
WBPOWER = [str(_SCRIPT)] if _SCRIPT.is_file() else [sys.executable, "-m", "wifibot_power"]


def _group(pgid: int) -> list[int]:
    """Processes of process group `pgid` still alive (zombies are dead)."""
    members = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        state, pgrp = fields[0], int(fields[2])
        if pgrp == pgid and state != "Z":
            members.append(int(entry))
    return members


def _sigint_state() -> str:
    """This process's SIGINT disposition and whether this thread blocks it: a child inherits
    both across exec when ignored or blocked (and Python then leaves SIGINT ignored)."""
    blocked = signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, [])
    return f"handler {signal.getsignal(signal.SIGINT)!r}, blocked {blocked}"


def _sigint_as_a_shell_leaves_it() -> None:
    """In the child before exec: SIGINT at its default and not blocked, as a shell starts a
    foreground job. The test process may have it otherwise (seen: the test failed 3 times
    with the command finishing as if no Ctrl-C came, only while other suites shared the
    machine; an ignored or blocked SIGINT inherited from the test runner would do exactly
    that), which is the runner's state, not what a user's terminal gives."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


@pytest.fixture(scope="module")
def corpus(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("interrupt")
    write_simulation(CORPUS, folder, WriteOptions(columns="power", decimals=3))
    return folder


@pytest.mark.parametrize("after_s", [0.0, 0.3])
@pytest.mark.parametrize("name", ["fit", "diagnose"])
def test_ctrl_c_during_fit_with_workers_stops_cleanly(
    corpus: Path, tmp_path: Path, after_s: float, name: str
) -> None:
    """fit (with a cache), and diagnose, whose parent imports pandas in a thread while its
    workers read (`map_runs(beside=...)`): at 0 s the signal lands as that import starts."""
    cache, out = tmp_path / "cache", tmp_path / "out"
    command = [*WBPOWER, name, str(corpus), "-j", "2", "-o", str(out)]
    if name == "fit":
        command += ["--cache", str(cache)]
    inherited = _sigint_state()  # what the command would inherit from this test process
    process = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,  # its own process group, as a shell gives a job
        preexec_fn=_sigint_as_a_shell_leaves_it,
    )
    try:
        # wait until the workers are forked (the group holds more than the command itself)
        deadline = time.monotonic() + 60
        while len(_group(process.pid)) < 3 and process.poll() is None:
            assert time.monotonic() < deadline, "the workers never started"
            time.sleep(0.01)
        assert process.poll() is None, "finished before it could be interrupted"
        # as the workers start (the initializer), or into the work (parsing, cache writes)
        time.sleep(after_s)
        os.killpg(process.pid, signal.SIGINT)
        sent = time.monotonic()
        stdout, stderr = process.communicate(timeout=30)
        took_s = time.monotonic() - sent
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.communicate()
    text = stderr.decode()
    assert process.returncode == 130, f"{text}(this test process's SIGINT: {inherited})"
    assert text == "wbpower: error: interrupted\n"
    assert stdout == b""
    assert took_s < PROMPT_S
    time.sleep(0.1)
    assert _group(process.pid) == [], "a worker outlived the command"
    assert not out.exists(), f"{name} -o wrote outputs of an interrupted run"
    assert not [p for p in cache.rglob("*") if p.name.endswith(".tmp")], "half-written cache"


def test_ctrl_c_while_starting_is_quiet(tmp_path: Path) -> None:
    # a SIGINT while the interpreter imports typer/rich/numpy: no traceback either
    # (before `wifibot_power.cli.main` runs, the signal lands in Python's own start-up or the
    # script's first import: "Fatal Python error: init_import_site" or a traceback, which no
    # program can prevent; ~0.1 s on a quiet machine, over 0.2 s on a loaded one, where the
    # fixed delays this test had failed; so the delays start after that, as measured now)
    # the slower of two measured starts, and half as much again: load that changes between
    # the measurement and the test (the sixth session saw one early SIGINT in a loaded
    # `make test`) must not put the signal back before main
    starts_s = []
    for _ in range(2):
        started = time.monotonic()
        subprocess.run([sys.executable, "-c", "import wifibot_power.cli"], check=True)
        starts_s.append(time.monotonic() - started)
    before_main_s = 1.5 * max(starts_s)
    for delay_s in (before_main_s + 0.1, before_main_s + 0.25, before_main_s + 0.4):
        process = subprocess.Popen(
            [*WBPOWER, "lifetime", "--rate", "54"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            start_new_session=True,
            preexec_fn=_sigint_as_a_shell_leaves_it,
        )
        time.sleep(delay_s)
        os.killpg(process.pid, signal.SIGINT)
        _, stderr = process.communicate(timeout=30)
        # too late is possible on a fast machine: then the command finished (0), or the signal
        # came as Python was exiting, after restoring the default handler (-2: killed by
        # SIGINT, which a shell reports as 130 too; nothing printed)
        assert process.returncode in (0, 130, -signal.SIGINT), stderr.decode()
        assert b"Traceback" not in stderr
        if process.returncode == 130:
            # or nothing at all: a signal held while modules load and delivered as the
            # command ends exits 130 without its line (seen once in CI, ninth session)
            assert stderr in (b"wbpower: error: interrupted\n", b"")
        if process.returncode == -signal.SIGINT:
            assert stderr == b""


#: small corpora of different run names, so an old report and a new one differ in figures
#: (6 runs each at 1 ms samples: a report of one takes a few seconds on 2 busy cores)
_OLD_RUNS = SimConfig(
    speeds_mps=(0.2, 0.5, 0.8), trips=((3.0, 1),), repeats=2, modes=(), seed=1,
    sample_period_s=1.024e-3,
)  # fmt: skip
_NEW_RUNS = replace(_OLD_RUNS, trips=((2.0, 1),), seed=2)


def _files(folder: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()
    }


def test_ctrl_c_while_report_writes_leaves_the_old_report_or_the_whole_new_one(
    tmp_path: Path,
) -> None:
    """`report -o DIR` over an older report, Ctrl-C as soon as anything new shows up under
    DIR's parent (its figures appearing in DIR/figures, or the folder it builds the report
    in): DIR then holds the old report exactly, or (the signal held off until the report
    was put in place) the whole new one, never some new figures beside the old page."""
    old_logs, new_logs, work = tmp_path / "old_logs", tmp_path / "new_logs", tmp_path / "work"
    write_simulation(_OLD_RUNS, old_logs, WriteOptions(columns="power", decimals=3))
    write_simulation(_NEW_RUNS, new_logs, WriteOptions(columns="power", decimals=3))
    work.mkdir()
    out = work / "out"
    made = subprocess.run([*WBPOWER, "report", str(old_logs), "-o", str(out), "-j", "2"])
    assert made.returncode == 0
    old = _files(out)
    old_traces = {name for name in old if name.startswith("figures/trace_v")}
    process = subprocess.Popen(
        [*WBPOWER, "report", str(new_logs), "-o", str(out), "-j", "2"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
        preexec_fn=_sigint_as_a_shell_leaves_it,
    )
    try:
        while process.poll() is None:
            beside = [p.name for p in work.iterdir() if p.name != "out"]
            # a figure put in place (not its hidden temporary file, which a stopped worker
            # removes)
            figures = {p.name for p in (out / "figures").iterdir() if not p.name.startswith(".")}
            # (hidden names on both sides: temporary files, and the report's list of what it
            # wrote, figures/.wbpower-figures)
            shown = {Path(n).name for n in old if n.startswith("figures/")}
            if beside or figures != {n for n in shown if not n.startswith(".")}:
                os.killpg(process.pid, signal.SIGINT)
                break
            time.sleep(0.002)
        _, stderr = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.communicate()
    text = stderr.decode()
    assert process.returncode in (0, 3, 130), text
    assert "Traceback" not in text
    if process.returncode == 130:  # nothing written
        assert text.endswith("wbpower: error: interrupted\n")
        assert _files(out) == old
    if process.returncode == 3:  # the signal held off until the report was put in place
        assert "wbpower: error: interrupted after writing" in text
        assert _files(out) != old
    now = _files(out)
    if now != old:  # then the whole new report: its page, its figures, nothing of the old
        assert now["report.html"] != old["report.html"]
        assert not old_traces & set(now)
        page = now["report.html"].decode()
        assert page.count("<img ") == len([n for n in now if n.startswith("figures/")]) > 6
    assert [p.name for p in work.iterdir()] == ["out"], "a folder left beside DIR"


def _start_fit(corpus: Path, out: Path, name: str = "fit") -> subprocess.Popen:
    process = subprocess.Popen(
        [*WBPOWER, name, str(corpus), "-j", "2", "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
        preexec_fn=_sigint_as_a_shell_leaves_it,
    )
    deadline = time.monotonic() + 60
    while len(_group(process.pid)) < 3 and process.poll() is None:
        assert time.monotonic() < deadline, "the workers never started"
        time.sleep(0.01)
    assert process.poll() is None, "finished before it could be stopped"
    return process


@pytest.mark.parametrize(("name", "after_s"), [("fit", 0.0), ("fit", 0.3), ("diagnose", 0.3)])
def test_sigterm_to_fit_stops_its_workers_and_exits_143(
    corpus: Path, tmp_path: Path, name: str, after_s: float
) -> None:
    """SIGTERM to the command alone (what `timeout` and a CI cancel send; not to its group):
    handled as Ctrl-C, exit 143, no worker left, nothing written, stdout closed (issue 29:
    `timeout -s TERM 0.35 wbpower fit logs -o X | cat` hung with orphaned workers holding
    the pipe)."""
    out = tmp_path / "out"
    process = _start_fit(corpus, out, name)
    time.sleep(after_s)
    process.send_signal(signal.SIGTERM)
    stdout, stderr = _ended(process)
    assert process.returncode == 143, stderr.decode()
    assert stderr == b"wbpower: error: terminated (SIGTERM)\n"
    assert stdout == b""
    time.sleep(0.1)
    assert _group(process.pid) == [], "a worker outlived the command"
    assert not out.exists(), "fit -o wrote outputs of a terminated run"


def test_sigkill_of_fit_leaves_no_worker_behind(corpus: Path, tmp_path: Path) -> None:
    """SIGKILL of the parent alone: its workers end too (PR_SET_PDEATHSIG), and the pipe they
    inherited is closed, so a reader of the command's output is not blocked forever."""
    process = _start_fit(corpus, tmp_path / "out")
    try:
        time.sleep(0.3)
        process.kill()
        started = time.monotonic()
        stdout, _ = process.communicate(timeout=30)  # EOF: no worker holds stdout
        took_s = time.monotonic() - started
        deadline = time.monotonic() + PROMPT_S
        while _group(process.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _group(process.pid) == [], "a worker outlived its killed parent"
        assert took_s < PROMPT_S
    finally:
        for pid in _group(process.pid):
            os.kill(pid, signal.SIGKILL)


def test_a_signal_once_the_command_is_done_cannot_turn_its_exit_into_killed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """After the command (its outputs written), SIGINT and SIGTERM are ignored: Python's
    shutdown puts handlers back to the default, and a signal then ended the process as
    killed by it (-15: "nothing written") after `fit -o` had written its set (the soak test,
    benchmarks/soak_fit.py, saw it 9 times in 200 runs). Ignored signals stay ignored."""
    from wifibot_power.cli import main

    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    monkeypatch.setattr(sys, "argv", ["wbpower", "lifetime", "--rate", "54", "--json"])
    try:
        with pytest.raises(SystemExit) as done:
            main()
        assert done.value.code in (0, None)
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_IGN
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        for signum, handler in saved.items():
            signal.signal(signum, handler)


_SWALLOWING_MODULE = """
import signal
import weakref


class A:
    pass


a = A()
r = weakref.ref(a, lambda ref: signal.raise_signal(signal.{name}))
del a  # its weakref callback gets the signal, inside this import
"""

_IMPORTER = """
import sys, time
from wifibot_power import signals
signals.install()
sys.path.insert(0, sys.argv[1])
try:
    import swallowing  # noqa: F401
    time.sleep(2)
    print("went on")
except KeyboardInterrupt as exc:
    print(type(exc).__name__)
"""


@pytest.mark.parametrize(
    ("name", "raised"), [("SIGINT", "KeyboardInterrupt"), ("SIGTERM", "Terminated")]
)
def test_a_signal_inside_an_import_callback_is_not_swallowed(tmp_path: Path, name, raised) -> None:
    """A KeyboardInterrupt raised in a weakref callback (the import machinery's own, as the
    soak test saw) is printed and swallowed by Python: the command went on and wrote its set
    after a Ctrl-C. The handlers deliver such a signal again once the import is done."""
    (tmp_path / "swallowing.py").write_text(_SWALLOWING_MODULE.format(name=name))
    done = subprocess.run(
        [sys.executable, "-c", _IMPORTER, str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=_sigint_as_a_shell_leaves_it,
    )
    assert done.stdout.strip() == raised, done.stderr
    assert "Exception ignored" not in done.stderr


def test_no_interrupt_is_raised_while_workers_are_forked() -> None:
    """While `signals.blocked()` holds Ctrl-C back (workers being forked), a Ctrl-C that
    still reaches the Python handler (taken by another thread, or `interrupt_main`) is not
    raised there, half-way through the forks: it comes once the block ends."""
    import _thread

    from wifibot_power import signals

    saved = {s: signal.getsignal(s) for s in signals.STOP_SIGNALS}
    signals.install()
    try:
        inside = []
        with pytest.raises(KeyboardInterrupt):
            with signals.blocked():
                _thread.interrupt_main(signal.SIGINT)
                for _ in range(50):  # bytecode on which the handler runs
                    time.sleep(0.002)
                inside.append("the block ran to its end")
            time.sleep(2)  # the Ctrl-C comes here
        assert inside == ["the block ran to its end"]
    finally:
        for signum, handler in saved.items():
            signal.signal(signum, handler)


def _ended(process: subprocess.Popen) -> tuple[bytes, bytes]:
    """`process.communicate(timeout=30)`: it returns only once every holder of the pipes
    (workers too) is gone; a process still running then is killed with its group."""
    try:
        return process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.communicate()


def _script_alone(script: str, *args: str) -> str:
    """Run a Python `script` in a session of its own; its stdout, once it ended within 30 s
    (not hung), exited 0, printed no traceback and left no process behind."""
    done = subprocess.Popen(
        [sys.executable, "-c", script, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    stdout, stderr = _ended(done)
    assert done.returncode == 0, stderr.decode()
    assert b"Traceback" not in stderr, stderr.decode()
    time.sleep(0.1)
    assert _group(done.pid) == [], "a worker outlived the command"
    return stdout.decode()


_LARGE_RESULTS = """
import os, signal, sys, threading
from wifibot_power import parallel, signals

signals.install()
threading.Timer(float(sys.argv[1]), os.kill, args=(os.getpid(), signal.SIGTERM)).start()
try:
    parallel.map_ordered(list(range(400)), lambda k: b"x" * 8_000_000, jobs=2)
    print("finished")
except KeyboardInterrupt as exc:
    print(type(exc).__name__)
"""


@pytest.mark.parametrize("after_s", [0.3, 0.5])
def test_a_worker_stopped_while_it_sends_a_large_result_does_not_hang_the_parent(
    after_s: float,
) -> None:
    """The hang of `diagnose -j 2` stopped 0.3 s into its work (issue 29; 3 runs in 60 under
    load, its stacks dumped): a worker stopped while it sent a large result left half a
    message in the pool's result pipe, the pool's thread waited for the rest forever, and so
    did the parent, joining it. Here the workers do nothing but send 8 MB results, so the
    SIGTERM nearly always stops one mid-message (before the fix: 6 hangs in 6 tries)."""
    stdout = _script_alone(_LARGE_RESULTS, str(after_s))
    assert stdout.strip() == "Terminated"


_KILLED_MID_MESSAGE = """
import os, signal, struct
from multiprocessing import connection
from wifibot_power import parallel
from wifibot_power.errors import WbpowerError


def dies_mid_message(k):
    def half_then_killed(self, buf):
        # the result's length and half of it sent, then killed, as by the OOM killer
        self._send(struct.pack("!i", len(buf)) + bytes(buf[: len(buf) // 2]))
        os.kill(os.getpid(), signal.SIGKILL)

    connection.Connection._send_bytes = half_then_killed  # (in the worker only)
    return b"x" * 1_000_000


try:
    parallel.map_ordered([1, 2, 3], dies_mid_message, jobs=2)
except WbpowerError as exc:
    print(exc.one_line())
"""


def test_a_worker_killed_while_it_sends_a_result_is_a_one_line_error_not_a_hang() -> None:
    """A worker killed (the OOM killer: no signal to catch) half-way through sending its
    result: the pool's thread waited forever for the rest of the message, so it never saw
    the worker's death, and the parent waited forever for a result. The parent watches its
    workers while it waits."""
    assert "a worker process died" in _script_alone(_KILLED_MID_MESSAGE)
