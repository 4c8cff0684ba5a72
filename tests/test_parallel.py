"""Files in parallel: same result for any --jobs, worker errors become skipped entries,
results in input order, only small rows back to the parent, progress per file."""

from __future__ import annotations

import os
import pickle
import signal
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from wifibot_power import parallel
from wifibot_power.cli import common, progress_bar
from wifibot_power.errors import WbpowerError
from wifibot_power.fit import fit_logs
from wifibot_power.io import ReadOptions
from wifibot_power.io.batch import map_runs
from wifibot_power.simulate import SimConfig, WriteOptions, write_simulation

needs_fork = pytest.mark.skipif(not parallel.can_fork(), reason="workers are forked (POSIX)")

#: a corpus the fit can use: 3 speeds x 2 m in one step, an idle log, at 1.024 ms (small files)
SMALL = SimConfig(
    speeds_mps=(0.3, 0.6, 0.9),
    trips=((2.0, 1),),
    repeats=1,
    modes=("idle", "network"),
    mode_repeats=1,
    mode_duration_s=2.0,
    sample_period_s=1.024e-3,
    noise_W=0.3,
    seed=11,
)


@pytest.fixture(scope="module")
def corpus(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("corpus")
    write_simulation(SMALL, folder, WriteOptions(columns="power", decimals=3))
    # two broken inputs: text where a number belongs, and a header with no power column
    (folder / "broken_text.csv").write_text("# mode: idle\npower_W\n23.1\nabc\n23.2\n")
    (folder / "broken_header.csv").write_text("time_s,speed\n0,1\n")
    return folder


# -- map_ordered ---------------------------------------------------------------------------
def test_resolve_jobs() -> None:
    cores = parallel.available_cores()
    assert cores >= 1
    assert parallel.resolve_jobs(0) == cores
    assert parallel.resolve_jobs(None) == cores
    assert parallel.resolve_jobs(3) == 3


def _slow_square(x: int) -> int:
    # later items finish first, so completion order is the reverse of input order
    time.sleep(0.02 * (5 - x))
    return x * x


@needs_fork
def test_results_in_input_order_whatever_finishes_first() -> None:
    done: list[int] = []
    results = parallel.map_ordered(list(range(6)), _slow_square, jobs=3, on_done=done.append)
    assert results == [0, 1, 4, 9, 16, 25]
    assert sorted(done) == list(range(6))  # each item reported done exactly once


def _start_time(x: int) -> float:
    started = time.monotonic()  # CLOCK_MONOTONIC: one clock for every process on the machine
    time.sleep(0.05)
    return started


@needs_fork
def test_costliest_items_start_first_results_stay_in_order() -> None:
    items = [1, 5, 2, 9, 3, 7]
    started = parallel.map_ordered(items, _start_time, jobs=2, cost=float)
    assert len(started) == len(items)
    # the two costliest (9 and 7) are the first two handed to the 2 workers; the cheapest
    # (1) is handed out last, after at least one worker finished a 50 ms item
    by_item = dict(zip(items, started, strict=True))
    assert max(by_item[9], by_item[7]) < min(by_item[x] for x in (1, 2, 3))
    assert by_item[1] == max(started)


@needs_fork
def test_work_runs_in_other_processes_and_needs_no_pickling() -> None:
    parent = os.getpid()
    offset = 7
    # a closure (not picklable) over a local: workers are forked, they inherit it
    pids = parallel.map_ordered([1, 2, 3, 4], lambda x: (os.getpid(), x + offset), jobs=2)
    assert [x for _, x in pids] == [8, 9, 10, 11]
    assert all(pid != parent for pid, _ in pids)


def test_jobs_1_runs_here() -> None:
    parent = os.getpid()
    assert parallel.map_ordered([1, 2], lambda x: os.getpid(), jobs=1) == [parent, parent]


@needs_fork
def test_beside_runs_once_in_a_thread_after_the_workers_are_forked() -> None:
    """`beside` is this process's work while the workers run: called once, in a thread
    that is not the main one, when every worker exists (a thread running at a fork could
    leave a lock held in the child), finished before the results come back; never called
    when the work runs in this process."""
    import multiprocessing
    import threading

    seen: list[tuple[str, int]] = []

    def beside() -> None:
        workers = len(multiprocessing.active_children())
        time.sleep(0.2)  # still running when the workers are done: joined all the same
        seen.append((threading.current_thread().name, workers))

    out = parallel.map_ordered([1, 2, 3, 4, 5], lambda x: x * 2, jobs=2, beside=beside)
    assert out == [2, 4, 6, 8, 10]
    assert len(seen) == 1
    name, workers = seen[0]
    assert name != threading.main_thread().name and workers == 2
    seen.clear()
    assert parallel.map_ordered([1, 2], lambda x: x, jobs=1, beside=beside) == [1, 2]
    assert seen == []


@needs_fork
def test_a_worker_that_dies_is_a_one_line_error() -> None:
    def die(x: int) -> int:
        if x == 2:
            os._exit(3)  # what the kernel's OOM killer leaves: no exception, no result
        return x

    with pytest.raises(WbpowerError) as info:
        parallel.map_ordered([1, 2, 3], die, jobs=2)
    assert "worker process died" in info.value.one_line()
    assert "--jobs 1" in info.value.one_line()
    assert "\n" not in info.value.one_line()


# -- the batch: same result for any jobs, errors become skipped entries ---------------------


@needs_fork
def test_fit_same_result_with_jobs_1_and_jobs_2(corpus: Path) -> None:
    one = fit_logs([corpus], jobs=1)
    two = fit_logs([corpus], jobs=2)
    # identical, not close: the same code runs on the same bytes, only in another process
    assert one.summary() == two.summary()
    pd.testing.assert_frame_equal(one.runs, two.runs)
    pd.testing.assert_frame_equal(one.phases, two.phases)
    assert one.skipped == two.skipped
    # the corpus: 3 motion runs, idle, network; the two broken files are skipped, named
    assert one.n_runs == 5
    skipped_files = sorted(Path(s.file).name for s in one.skipped)
    assert skipped_files == ["broken_header.csv", "broken_text.csv"]


@needs_fork
def test_errors_in_workers_become_skipped_entries(corpus: Path) -> None:
    def segmenter_that_fails_on_one_run(run):
        if run.meta.speed_mps == 0.6:
            raise ZeroDivisionError("boom")  # a bug in the segmenter, inside a worker
        from wifibot_power.segment import segment_run

        return segment_run(run)

    results = {
        jobs: fit_logs([corpus], jobs=jobs, segmenter=segmenter_that_fails_on_one_run)
        for jobs in (1, 2)
    }
    assert results[1].skipped == results[2].skipped
    reasons = [s.reason for s in results[2].skipped]
    failed = [r for r in reasons if "segmentation failed" in r]
    assert len(failed) == 1 and "ZeroDivisionError: boom" in failed[0]
    assert "v0.60" in failed[0]  # names the file
    assert all("\n" not in r for r in reasons)
    text = [r for r in reasons if "broken_text.csv" in r][0]
    assert "'abc' where a number belongs" in text and "line 4" in text
    assert results[2].n_runs == 4  # the other runs still fitted


@needs_fork
def test_cli_fit_jobs_2_exit_codes(corpus: Path, wbpower, tmp_path: Path) -> None:
    result = wbpower("fit", corpus, "--json", "--jobs", "2")
    assert result.exit_code == 1  # done, some input skipped (cli.md)
    assert "broken_text.csv" in result.stderr and "Traceback" not in result.stderr
    single = wbpower("fit", corpus / "broken_text.csv", "--jobs", "2")
    assert single.exit_code == 2
    assert single.stderr.count("\n") == 1 and "broken_text.csv" in single.stderr


def test_rows_sent_back_are_small_not_samples(corpus: Path, monkeypatch) -> None:
    """What a worker returns is pickled to the parent: it must be a row, not the samples."""
    seen: list[object] = []
    real = parallel.map_ordered

    def spy(items, task, **kwargs):
        results = real(items, task, **kwargs)
        seen.extend(results)
        return results

    monkeypatch.setattr(parallel, "map_ordered", spy)  # batch imports it when it has work
    result = fit_logs([corpus], jobs=1)
    samples = int(result.runs["samples"].max())
    assert samples > 1500  # a 2 m run at 0.3 m/s at 1.024 ms: ~10 s, ~10k samples
    for outcome in seen:
        size = len(pickle.dumps(outcome))
        # the samples alone would be 8 bytes x samples; a row and a few phases are ~ kB, and
        # the run's piece signature (pipeline/pieces.py) ~1,000 windows at most, ~17 kB
        ok, value = outcome
        signature = len(value[1].split("#", 1)[1]) if ok else 0
        assert signature < 18_000, signature
        assert size - signature < 8 * samples / 4, size


def test_map_runs_keeps_file_order_and_skips(corpus: Path) -> None:
    rows, skipped = map_runs([corpus], ReadOptions(), lambda run: Path(run.file).name, jobs=1)
    assert rows == sorted(rows)  # find_logs sorts paths; results keep that order
    assert len(skipped) == 2


# -- progress ------------------------------------------------------------------------------
def test_progress_is_silent_without_a_terminal(corpus: Path) -> None:
    items = sorted(corpus.glob("*.csv"))
    # pytest captures stderr: not a TTY, so no bar, just the items
    assert common.progress(items, "fitting") is items


def test_file_progress_counts_files_and_bytes(corpus: Path) -> None:
    items = sorted(corpus.glob("v*.csv"))
    bar = progress_bar.FileProgress(items, "fitting")
    assert bar.total_bytes == sum(p.stat().st_size for p in items)
    for item in reversed(items):  # files finish in any order
        bar.done(item)
    task = bar._bar.tasks[0]
    assert task.fields["files"] == len(items)
    assert task.completed == bar.total_bytes
    bar.close()


def test_generator_wrap_still_advances_once_per_file(corpus: Path) -> None:
    """The older hook (a generator over the sources) advances as each file is done."""
    advanced: list[str] = []

    def wrap(sources):
        for source in sources:
            yield source
            advanced.append(source.path.name)

    rows, _ = map_runs([corpus], ReadOptions(), lambda run: run.samples, wrap=wrap, jobs=1)
    assert len(advanced) == len(rows) + 2  # every file, the two skipped included
    assert np.all(np.asarray(rows) > 0)


def test_prepare_runs_once_before_work_and_not_when_all_is_kept(corpus: Path, tmp_path) -> None:
    """`prepare` (fit: import pandas and the segmenter once, before forking) is called once
    when some file needs work, and not at all when the cache keeps every result."""
    import shutil

    from wifibot_power.cache import ParseCache, ResultMemo
    from wifibot_power.fit import fit_logs

    good = tmp_path / "good"  # the corpus without its 2 broken logs (those are never kept)
    shutil.copytree(corpus, good, ignore=shutil.ignore_patterns("broken_*"))
    calls: list[int] = []
    cache = ParseCache(tmp_path / "cache")
    fit_logs([good], jobs=2, cache=cache)  # parses kept: the work below needs no parsing

    def prepare() -> None:
        calls.append(1)

    # a fresh memo key: nothing kept for it yet -> work on the 5 logs (3 speeds, idle,
    # network), prepare once
    memo = ResultMemo(key="test prepare", to_json=lambda r: r, from_json=lambda r: r)
    names, _ = map_runs(
        [good], ReadOptions(), lambda run: Path(run.file).name, jobs=2, cache=cache,
        memo=memo, prepare=prepare,
    )  # fmt: skip
    assert calls == [1] and len(names) == 5
    again, _ = map_runs(
        [good], ReadOptions(), lambda run: pytest.fail("worked"), jobs=2, cache=cache,
        memo=memo, prepare=prepare,
    )  # fmt: skip
    assert calls == [1] and again == names


def test_progress_shows_no_rate_until_a_second_of_work() -> None:
    # the first files finish a few ms after the start: 371 MB in 1 ms read "371.3 GB/s"
    assert progress_bar.rate_text(371.3e6, 0.001) == ""
    assert progress_bar.rate_text(0, 5.0) == ""
    assert progress_bar.rate_text(371.3e6, 2.0) == "185.7 MB/s"  # 371.3 MB over 2 s
    assert progress_bar.rate_text(1500, 1.5) == "1.0 kB/s"


def test_the_bar_rate_counts_from_the_start_of_the_work(corpus: Path, monkeypatch) -> None:
    items = sorted(corpus.glob("v*.csv"))
    clock = [100.0]
    monkeypatch.setattr(progress_bar.time, "monotonic", lambda: clock[0])
    bar = progress_bar.FileProgress(items, "fitting")
    clock[0] += 0.002  # two files done 2 ms after the start
    bar.done(items[0])
    bar.done(items[1])
    (rate,) = [c for c in bar._bar.columns if isinstance(c, progress_bar._RateColumn)]
    task = bar._bar.tasks[0]
    assert str(rate.render(task)) == ""
    clock[0] = 104.0  # 4 s after the start
    done_bytes = items[0].stat().st_size + items[1].stat().st_size
    assert str(rate.render(task)) == progress_bar.rate_text(done_bytes, 4.0) != ""
    bar.close()


def _death_signal(_: int) -> int:
    """In a worker: the signal the kernel sends it when its parent dies (prctl(2))."""
    import ctypes

    libc = ctypes.CDLL(None, use_errno=True)
    value = ctypes.c_int(-1)
    libc.prctl(2, ctypes.byref(value), 0, 0, 0)  # PR_GET_PDEATHSIG
    return value.value


@pytest.mark.skipif(not parallel.can_fork(), reason="workers are forked on Linux only")
def test_every_worker_ends_when_its_parent_dies():
    """Each forked worker asks for SIGKILL when its parent dies (PR_SET_PDEATHSIG): a parent
    killed by SIGKILL leaves no worker blocked on the pool's queue holding its stdout (issue
    29). The end-to-end check: tests/test_interrupt.py, a real SIGKILL."""
    assert parallel.map_ordered(list(range(4)), _death_signal, jobs=2) == [signal.SIGKILL] * 4


def _threads() -> set[str]:
    return {task.name for task in Path("/proc/self/task").iterdir()}


def _blocked_in_new_threads(before: set[str]) -> list[int]:
    """SigBlk of each thread of this process not in `before` (/proc)."""
    masks = []
    for task in Path("/proc/self/task").iterdir():
        if task.name in before:
            continue
        status = (task / "status").read_text()
        masks.append(int(status.split("SigBlk:")[1].split()[0], 16))
    return masks


@pytest.mark.skipif(not parallel.can_fork(), reason="workers are forked on Linux only")
def test_the_parents_other_threads_leave_ctrl_c_and_sigterm_to_the_main_thread():
    """The kernel gives a process's signal to any thread that does not block it; one taken
    by the pool's manager thread or the `beside` thread does not interrupt the main thread's
    wait, which then acts on it only when the next file is done. Both block SIGINT and
    SIGTERM (as pyarrow's threads would, started from them)."""
    seen: list[list[int]] = []
    before = _threads()  # (threads earlier tests left: pyarrow's pools, ...)
    parallel.map_ordered(
        list(range(4)),
        lambda k: time.sleep(0.2) or k,
        jobs=2,
        beside=lambda: seen.append(_blocked_in_new_threads(before)),
    )
    wanted = (1 << (signal.SIGINT - 1)) | (1 << (signal.SIGTERM - 1))
    assert seen and len(seen[0]) >= 2  # the manager thread and `beside` at least
    assert all(mask & wanted == wanted for mask in seen[0]), [hex(m) for m in seen[0]]


@pytest.mark.skipif(not parallel.can_fork(), reason="workers are forked on Linux only")
def test_an_interrupt_after_the_forks_but_before_the_pool_knows_them_stops_them(monkeypatch):
    """A Ctrl-C that lands inside the first submit, once the workers are forked but before
    the pool's manager thread starts (soak_fit.py: the parent then waited at exit for its
    idle workers forever): every forked worker is stopped all the same."""
    from concurrent.futures import process

    forked: list[int] = []

    def interrupted_start(self):
        self._launch_processes()
        forked.extend(self._processes)
        raise KeyboardInterrupt

    monkeypatch.setattr(
        process.ProcessPoolExecutor, "_start_executor_manager_thread", interrupted_start
    )
    try:
        with pytest.raises(KeyboardInterrupt):
            parallel.map_ordered(list(range(4)), lambda k: k, jobs=2)
        assert len(forked) == 2
        deadline = time.monotonic() + 5
        alive = forked
        while alive and time.monotonic() < deadline:
            alive = [pid for pid in forked if _alive(pid)]
            time.sleep(0.05)
        assert alive == [], "forked workers left running"
    finally:
        for pid in forked:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


#: Arrays of a file's size allocated, touched and freed over and over, as a worker does file
#: after file (40 rounds of 6 x 600 KB); the page faults that took.
_CHURN_PAGES = 6 * 75_000 * 8 / 4096


def _churn_faults() -> int:
    import resource

    np.ones(80_000).sum()  # numpy's own first allocations, before counting
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(40):
        arrays = [np.ones(75_000) for _ in range(6)]
        del arrays
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before


_CHURN = """
import sys
from wifibot_power import parallel
from tests.test_parallel import _churn_faults
if sys.argv[1] == "pinned":
    assert parallel.pin_malloc_thresholds()
print(_churn_faults())
"""


@needs_fork
def test_workers_keep_freed_memory_for_the_next_file() -> None:
    """A worker's freed arrays are reused, not given back to the OS and faulted in again file
    after file (`pin_malloc_thresholds`): 40 rounds of 3.6 MB of arrays fault each page in
    about once, not once a round (glibc's default trims the heap's top each round)."""
    import subprocess
    import sys

    def faults(mode: str) -> int:
        done = subprocess.run(
            [sys.executable, "-c", _CHURN, mode],
            capture_output=True,
            text=True,
            check=True,
            cwd=Path(__file__).resolve().parent.parent,
        )
        return int(done.stdout)

    assert faults("default") > 20 * _CHURN_PAGES  # the churn this is about: ~40 x the pages
    assert faults("pinned") < 3 * _CHURN_PAGES
    # and every forked worker has them pinned
    assert parallel.map_ordered([0, 1], _worker_churn_faults, jobs=2) == [True, True]


def _worker_churn_faults(_: int) -> bool:
    return _churn_faults() < 3 * _CHURN_PAGES


class _Watched:
    """A future that records whether SIGINT and SIGTERM were blocked at each look."""

    def __init__(self, result: object) -> None:
        self.looks: list[bool] = []
        self._result = result

    def _blocked(self) -> bool:
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, [])
        return signal.SIGINT in mask and signal.SIGTERM in mask

    def done(self) -> bool:
        self.looks.append(self._blocked())
        return len(self.looks) > 2

    def result(self) -> object:
        self.looks.append(self._blocked())
        return self._result


def test_the_futures_are_looked_at_with_the_stop_signals_blocked():
    """A SIGTERM landing inside `Future.done`'s `with self._condition` after the lock was
    taken left it held, and `fit` hung in `shutdown` (1 in ~200 SIGTERMs as its workers
    start, under load): every look at a future, and its result, is made with SIGINT and
    SIGTERM blocked (the handler acts after), only the sleep between looks is not."""
    future = _Watched(42)
    results = parallel._collect(None, {future: 0}, iter(()), lambda index: None, [])
    assert results == {0: 42}
    assert len(future.looks) == 4 and all(future.looks)
