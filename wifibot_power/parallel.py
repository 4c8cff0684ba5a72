"""Files processed in parallel across cores, a file at a time per worker, results in input order.

The unit of work is one file: a worker reads it, reduces it to a small result (a table row,
a few phases) and returns only that, so memory is bounded by `jobs` files in flight, never by
how many files there are. Results come back in the order of the inputs whatever order the
workers finish in, so `--jobs 1` and `--jobs N` give the same output.

Workers are forked (POSIX `fork`): they inherit the loaded libraries and the task, so nothing
has to be importable or picklable but the small results, and starting a worker costs
milliseconds, not the seconds a fresh interpreter needs to import numpy, pandas and pyarrow.
Where forking is not safe (not Linux) the work runs in the calling process, one file at a
time.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import multiprocessing.connection
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import TypeVar

from wifibot_power import signals
from wifibot_power.errors import WbpowerError

T = TypeVar("T")
R = TypeVar("R")

#: The task of the pool being run. Forked workers inherit it: it is never pickled.
_TASK: Callable[[int], object] | None = None


def available_cores() -> int:
    """Cores this process may run on (the CPU affinity mask, as `nproc` counts them)."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # not on Linux
        return max(os.cpu_count() or 1, 1)


def resolve_jobs(jobs: int | None) -> int:
    """Worker processes for `jobs`: None or 0 means all available cores; never below 1."""
    if jobs is None or jobs <= 0:
        return available_cores()
    return int(jobs)


def can_fork() -> bool:
    """Whether workers can be forked safely: on Linux. (macOS has fork, but its system
    libraries are not fork-safe, which is why Python spawns there by default.)"""
    return sys.platform.startswith("linux") and "fork" in multiprocessing.get_all_start_methods()


#: In a worker: set when the parent asked it to stop (SIGTERM).
_STOPPING = False
#: In a worker: whether it is running a task (then SIGTERM unwinds it first).
_IN_TASK = False
#: Seconds a stopped worker has to finish its cleanup before it is killed.
STOP_GRACE_S = 1.5
#: Linux's prctl(2) option: the signal a process gets when the thread that forked it ends.
_PR_SET_PDEATHSIG = 1


def _start_worker(threads: int, parent: int) -> None:
    """A worker's start: Ctrl-C is the parent's to handle, SIGTERM stops the worker cleanly,
    the worker stops when its parent dies, and pyarrow gets the worker's share of the
    cores."""
    # The terminal sends SIGINT to the whole process group; a worker ignores it (no
    # KeyboardInterrupt traceback from the middle of a task), and the parent stops it.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _stop)
    _stop_with_parent(parent)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, set(signals.STOP_SIGNALS))
    _share_cores(threads)
    pin_malloc_thresholds()


def _stop_with_parent(parent: int) -> None:
    """SIGKILL to this worker when its parent dies without stopping it (SIGKILL, a crash):
    no worker is left re-parented to init, blocked forever on the pool's queue and holding
    the parent's stdout open (issue 29: `timeout ... wbpower fit | cat` then never ended).
    Linux's PR_SET_PDEATHSIG (prctl(2)), set by the worker itself; a parent that died before
    it was set is seen by its pid (the worker's parent is then init or a subreaper).

    SIGKILL, not SIGTERM: a SIGTERM handled in Python runs only once the main thread gets
    back to Python, and the kernel may hand a process's signal to any of its threads. Seen
    (once in 200 runs of benchmarks/soak_fit.py, and again in 1 of 60 kills 0.15-0.45 s into
    `fit`): an orphaned worker with SIGTERM caught (/proc SigCgt) and nothing pending, both
    of its threads blocked reading a pipe, the signal taken by the other thread, the main
    thread's read never interrupted, stdout held forever. A parent that stops normally (Ctrl-C,
    SIGTERM, an error) still stops its workers with SIGTERM first (`_stop_workers`), so
    that they remove what they were writing; only an abnormal death of the parent, which
    leaves its own temporary files too, leaves theirs."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):  # pragma: no cover - not Linux: never forked there
        pass
    if os.getppid() != parent:
        os._exit(128 + signal.SIGTERM)


def _stop(signum: int, frame: object) -> None:
    """SIGTERM in a worker: unwind the task (its `finally`/`except` blocks remove temporary
    files, e.g. a cache entry half written), then exit; between tasks, exit now."""
    global _STOPPING
    _STOPPING = True
    if not _IN_TASK:
        os._exit(128 + signal.SIGTERM)
    raise SystemExit(128 + signal.SIGTERM)


def _share_cores(threads: int) -> None:
    """In a worker: its share of the cores for pyarrow's own thread pool. The cores are
    already busy with one file per worker; more threads per file only add contention
    (measured: about 10% less CPU for `fit` with one pyarrow thread per worker on 2 cores)."""
    pyarrow = sys.modules.get("pyarrow")
    if pyarrow is not None:
        pyarrow.set_cpu_count(threads)
        pyarrow.set_io_thread_count(max(threads, 1))


#: glibc's mallopt(3) parameters (malloc.h): M_TRIM_THRESHOLD, M_MMAP_THRESHOLD
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
#: A worker's malloc thresholds [bytes]: glibc's dynamic ones at their largest
#: (DEFAULT_MMAP_THRESHOLD_MAX on 64 bits, and twice it to trim the heap's top)
MMAP_THRESHOLD_BYTES, TRIM_THRESHOLD_BYTES = 32 << 20, 64 << 20


def pin_malloc_thresholds() -> bool:
    """In a worker: glibc's malloc thresholds pinned where its dynamic ones end up, from the
    start. By default a block freed over 128 KiB raises the mmap threshold to its size, and
    the heap's free top is given back to the OS beyond twice that: a file's per-sample arrays
    (576 KB each for an hour at 20 Hz), freed and allocated again for the next file, were
    given back and faulted in again (zeroed by the kernel) file after file. Measured on the
    bench's drive corpus (200 files, `--jobs 2`): the workers' page faults 555,000 -> 15,000,
    their system CPU 1.4 -> 0.2 s, their peak RSS unchanged (75 MB); pickling a run's record
    for the parent (1.9 MB) 4.0 -> 0.8 ms. On the `power` corpus (5 MB logs) the workers'
    system CPU 0.45 -> 0.16 s for 7 MB more RSS each (139 -> 146 MB: what a worker keeps for
    its next file; 8/16 MiB thresholds kept the memory and lost the gain). Memory stays
    bounded: what is freed is reused by the next file, at most `TRIM_THRESHOLD_BYTES` of free
    top is kept, and blocks over `MMAP_THRESHOLD_BYTES` are mapped and unmapped as before.
    Workers only: a process that calls the library keeps its own allocator's settings. False
    where it does not apply (not glibc)."""
    try:
        libc = ctypes.CDLL(None)
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # pragma: no cover - not glibc: nothing to pin
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    # the trim threshold first: setting either one ends glibc's dynamic adjustment of both
    return bool(
        mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES)
        and mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)
    )


def _run_task(index: int) -> object:
    global _IN_TASK
    assert _TASK is not None, "worker started without a task"
    _IN_TASK = True
    try:
        return _TASK(index)
    except BaseException:
        if _STOPPING:  # cleaned up while unwinding: leave now, not back to the pool's loop
            os._exit(128 + signal.SIGTERM)
        raise
    finally:
        _IN_TASK = False


def _forked(
    pool: ProcessPoolExecutor, known: list[multiprocessing.process.BaseProcess]
) -> list[multiprocessing.process.BaseProcess]:
    """Every worker the pool has forked, also when the first submit (which forks them all)
    was interrupted before they were known: stopped, or idle workers would be waited for
    at exit forever (the pool's manager thread, which tells them to end, may not have been
    started; seen in benchmarks/soak_fit.py)."""
    forked = dict.fromkeys(known)
    forked.update(dict.fromkeys((pool._processes or {}).values()))  # noqa: SLF001
    return list(forked)


def _stop_workers(processes: list[multiprocessing.process.BaseProcess]) -> None:
    """Stop the workers now: SIGTERM (each unwinds its task and exits), then SIGKILL for any
    still running after `STOP_GRACE_S` (stuck in a long C call)."""
    for process in processes:
        if process.is_alive():
            process.terminate()
    deadline = time.monotonic() + STOP_GRACE_S
    for process in processes:
        process.join(max(deadline - time.monotonic(), 0.0))
    for process in processes:
        if process.is_alive():
            process.kill()
            process.join()


def map_ordered(
    items: Sequence[T],
    task: Callable[[T], R],
    *,
    jobs: int | None = 1,
    on_done: Callable[[T], None] | None = None,
    cost: Callable[[T], float] | None = None,
    beside: Callable[[], object] | None = None,
) -> list[R]:
    """`[task(item) for item in items]`, run by `jobs` forked workers, in the order of `items`.

    `task` should catch what it can handle and return a small value; an exception it raises is
    re-raised here. `on_done(item)` is called in this process as each item finishes (progress).
    At most `2 x jobs` items are queued, and a worker holds one at a time, so at most `jobs`
    files are in memory at once. With `cost(item)` (e.g. file size), the costliest items are
    started first, so no large file is left to run alone at the end (longest processing time
    first scheduling); the results stay in the order of `items`.

    `beside()` is what this process does meanwhile: called in a thread of its own once the
    workers are forked (never before: a thread running while a process forks can leave a
    lock held in the child), done before the results are returned; not called when the
    work runs in this process. E.g. importing what comes after the work (`diagnose_logs`:
    pandas), which this process, waiting for the workers, would otherwise do after them.
    """
    workers = min(resolve_jobs(jobs), len(items))
    if workers <= 1 or not can_fork():
        results = []
        for item in items:
            results.append(task(item))
            if on_done is not None:
                on_done(item)
        return results

    global _TASK
    previous, _TASK = _TASK, lambda index: task(items[index])
    order = range(len(items))
    if cost is not None:
        order = sorted(order, key=lambda index: -cost(items[index]))

    def done(index: int) -> None:
        if on_done is not None:
            on_done(items[index])

    try:
        results_by_index = _map_forked(iter(order), workers, done, beside)
    finally:
        _TASK = previous
    return [results_by_index[index] for index in range(len(items))]


def _map_forked(
    queue: Iterator[int],
    workers: int,
    on_done: Callable[[int], object],
    beside: Callable[[], object] | None,
) -> dict[int, object]:
    """`_TASK(index)` for each index of `queue` (in that order) in `workers` forked workers;
    `on_done(index)` as each is done. No worker is left behind however it ends."""
    threads = max(available_cores() // workers, 1)
    pool = ProcessPoolExecutor(
        max_workers=workers,
        mp_context=multiprocessing.get_context("fork"),
        initializer=_start_worker,
        initargs=(threads, os.getpid()),
    )
    processes: list[multiprocessing.process.BaseProcess] = []
    meanwhile: threading.Thread | None = None
    try:
        first = next(queue, None)
        if first is None:
            return {}
        pending, processes = _fork_workers(pool, first)
        if beside is not None:
            meanwhile = _start_beside(beside)
        # a window of 2 items per worker in flight: workers never wait for work, and the
        # parent holds a few futures, not one per file
        for index in queue:
            pending[pool.submit(_run_task, index)] = index
            if len(pending) >= 2 * workers:
                break
        results = _collect(pool, pending, queue, on_done, processes)
    except BrokenProcessPool:
        _stop_pool(pool, processes)
        raise WbpowerError(
            "a worker process died (killed for lack of memory?)",
            fix="run again with --jobs 1, or with fewer jobs",
        ) from None
    except BaseException:
        # Ctrl-C (KeyboardInterrupt), SIGTERM (`signals.Terminated`), or an error a task
        # raised: no worker is left behind
        _stop_pool(pool, processes)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    if meanwhile is not None:
        meanwhile.join()
    return results


def _fork_workers(
    pool: ProcessPoolExecutor, index: int
) -> tuple[dict[Future, int], list[multiprocessing.process.BaseProcess]]:
    """The first submit, which forks every worker, with SIGINT and SIGTERM held back
    meanwhile, so they land once the workers are known and can be stopped."""
    with signals.blocked():
        pending = {pool.submit(_run_task, index): index}
        return pending, list(pool._processes.values())  # noqa: SLF001


def _start_beside(beside: Callable[[], object]) -> threading.Thread:
    """`beside()` in a thread of its own, started once every worker is forked (fork: all at
    once, by the first submit), with Ctrl-C and SIGTERM blocked, which it keeps (as the
    pool's manager thread, started by the first submit): the kernel gives them to the main
    thread, whose wait (`_finished`) they interrupt at once."""
    meanwhile = threading.Thread(target=beside, name="beside", daemon=True)
    with signals.blocked():
        meanwhile.start()
    return meanwhile


def _collect(
    pool: ProcessPoolExecutor,
    pending: dict[Future, int],
    queue: Iterator[int],
    on_done: Callable[[int], object],
    processes: list[multiprocessing.process.BaseProcess],
) -> dict[int, object]:
    """The results of `pending` as they finish, each replaced by the next index of `queue`;
    every `_WATCH_S` without one, a check that no worker has died (`_check_alive`)."""
    results: dict[int, object] = {}
    while pending:
        for future in _finished(pending, processes):
            index = pending.pop(future)
            with signals.blocked():  # a future's lock, and the pool's, taken and given back
                results[index] = future.result()
            on_done(index)
            next_index = next(queue, None)
            if next_index is not None:
                with signals.blocked():
                    pending[pool.submit(_run_task, next_index)] = next_index
    return results


#: seconds between two looks at the results in flight
_POLL_S = 0.005
#: seconds between two checks that every worker is alive while no result comes
_WATCH_S = 0.5


def _finished(
    pending: dict[Future, int], processes: list[multiprocessing.process.BaseProcess]
) -> list[Future]:
    """The futures of `pending` that are done, waiting for one: polled every `_POLL_S`, with
    a check that no worker has died every `_WATCH_S` (`_check_alive`).

    Polled, not `concurrent.futures.wait`: its `Condition.wait`, when a Ctrl-C or SIGTERM
    interrupts it while it takes its lock back (held by the pool's thread, marking a result
    done), raises without that lock and then releases it from under the pool's thread,
    which dies ("Exception in thread ... RuntimeError: release unlocked lock": a traceback
    on stderr, seen once in ~60 interrupted runs under load). A sleep interrupted raises
    with no lock held.

    Each look at the futures (`Future.done`: `with self._condition`) runs with the signals
    blocked (`signals.blocked`: the handler acts once they are unblocked): a SIGTERM landing
    in `Condition.__enter__` after its lock was taken raised before the `with` could give it
    back, so the pool's thread, marking that future, waited for the lock forever and
    `shutdown(wait=True)` for that thread: `fit` hung (1 in ~200 SIGTERMs sent as its
    workers start, under load; stacks dumped from the stuck process: the pool's thread in
    `terminate_broken` -> `Future.set_exception` -> `Condition.__enter__`, the main thread
    in `shutdown` -> `join`). Only the sleep between looks is interruptible."""
    waited_s = 0.0
    while True:
        with signals.blocked():
            done = [future for future in pending if future.done()]
        if done:
            return done
        time.sleep(_POLL_S)
        waited_s += _POLL_S
        if waited_s >= _WATCH_S:
            _check_alive(processes)
            waited_s = 0.0


def _check_alive(processes: list[multiprocessing.process.BaseProcess]) -> None:
    """`BrokenProcessPool` if a worker has died (the OOM killer; workers end only when told
    to). The pool's own thread sees a death too, but not one half-way through sending a
    result: it waits for the rest of that message forever, and this process waited forever
    for the result (issue 29). Read from the workers' sentinels (no wait: not reaped here)."""
    if multiprocessing.connection.wait([p.sentinel for p in processes], timeout=0):
        raise BrokenProcessPool("a worker process died")


def _stop_pool(
    pool: ProcessPoolExecutor, processes: list[multiprocessing.process.BaseProcess]
) -> None:
    """Stop every worker the pool forked, then end the read of the pool's result thread
    (`_end_result_reads`), so that `pool.shutdown(wait=True)`, which waits for that thread,
    returns. A second Ctrl-C or SIGTERM meanwhile is acted on once this is done, not half-way
    (it would leave the pool's thread blocked, and the exit waiting for it)."""
    with signals.held():
        _stop_workers(_forked(pool, processes))
        _end_result_reads(pool)


def _end_result_reads(pool: ProcessPoolExecutor) -> None:
    """Close this process's copy of the write end of the pool's result pipe, once its workers
    are all gone: a read of that pipe then ends (EOF) instead of waiting forever.

    The cause of the hang of issue 29 (`diagnose -j 2` stopped 0.3 s into its work, 3 runs in
    60 under load): a worker stopped while it sent a result (diagnose's are large: written in
    several pieces) leaves half a message in the pipe. The pool's manager thread reads the
    message's length, then waits for the rest, which never comes; nor does EOF, as this
    process holds the pipe's write end too (it never writes there). `shutdown(wait=True)`
    waited for that thread forever (stacks dumped from the stuck process:
    `wait_result_broken_or_wakeup` -> `Connection._recv`). With EOF the read fails, the pool
    marks itself broken and its thread ends."""
    results = getattr(pool, "_result_queue", None)
    writer = getattr(results, "_writer", None)
    if writer is not None:
        writer.close()
