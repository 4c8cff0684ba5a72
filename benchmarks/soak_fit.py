"""Soak test of `fit -o` under the signals CI and users send (issue 29). Not part of `make test`.

RUNS times: `wbpower fit CORPUS -o OUT -j 2` (CORPUS one of two simulated corpora, A or B,
whose complete output sets differ), stopped at a random moment by SIGINT (to its process
group, as a terminal sends Ctrl-C), SIGTERM (to the command alone, as `timeout` and a CI
cancel send) or SIGKILL (to the command alone: its workers must end by themselves), or left
to finish; part of the time a second writer runs `fit -o OUT` on the other corpus at once.
After each run:

- OUT holds exactly one complete set, byte for byte A's or B's (model.json, runs.parquet,
  phases.parquet, stop_and_go.parquet), never a mixture;
- a command that exited 130 (SIGINT), 143 (SIGTERM) or 2 (the folder locked by the other
  writer) left OUT as it was; one that exited 0, or 3 (interrupted after its set was
  written in full), left its own set;
- no process of the command (workers included) is alive a few seconds later;
- the only temporary files are those a SIGKILL left mid-write (`.NAME.*.tmp`), and the next
  writer removes them: after a final clean run none remains;
- no traceback, but from a signal that came in Python's own start-up, before wbpower's
  code runs (the process then dies of the signal, -2 or -15, or exits 1 from its site
  initialisation, with no frame of wbpower's code, having written nothing: the folder must
  be unchanged; counted apart).

Usage: `.venv/bin/python benchmarks/soak_fit.py [--runs 200] [--seed 0] [--work DIR]`;
prints one JSON summary, exit 1 if any check failed. docs/errors.md quotes its result.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
_SCRIPT = Path(sys.executable).with_name("wbpower")
WBPOWER = [str(_SCRIPT)] if _SCRIPT.is_file() else [sys.executable, "-m", "wifibot_power.cli"]
#: seconds a command may take to exit after its signal before it counts as hung
HANG_S = 60.0
#: seconds its workers may take to end after it exited
ORPHAN_S = 5.0


def make_corpora(work: Path) -> dict[str, Path]:
    from wifibot_power.simulate import SimConfig, WriteOptions, write_simulation

    corpora = {}
    for name, seed in (("A", 1), ("B", 2)):
        folder = work / f"corpus_{name}"
        if not folder.exists():
            config = SimConfig(
                speeds_mps=(0.2, 0.5, 0.8),
                trips=((2.0, 1),),
                repeats=2,
                modes=("idle",),
                mode_repeats=1,
                mode_duration_s=3.0,
                seed=seed,
                sample_period_s=1.024e-3,
            )
            write_simulation(config, folder, WriteOptions(columns="power", decimals=3))
        corpora[name] = folder
    return corpora


def contents(folder: Path) -> dict[str, bytes]:
    """The files of an output set (temporary files apart)."""
    if not folder.is_dir():
        return {}
    return {
        p.name: p.read_bytes()
        for p in sorted(folder.iterdir())
        if p.is_file() and not p.name.endswith(".tmp")
    }


def temporaries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.glob(".*.tmp")) if folder.is_dir() else []


def alive_with(marker: str) -> list[int]:
    """Processes (not zombies) whose command line holds `marker` (the output folder)."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) == os.getpid():
            continue
        try:
            cmdline = Path(f"/proc/{entry}/cmdline").read_bytes()
            state = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if marker.encode() in cmdline and state != "Z":
            found.append(int(entry))
    return found


def start(corpus: Path, out: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [*WBPOWER, "fit", str(corpus), "-j", "2", "-o", str(out), "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,  # a process group of its own, as a shell gives a job
    )


def stop(process: subprocess.Popen, how: str) -> None:
    if process.poll() is not None:
        return
    try:
        if how == "INT":
            os.killpg(process.pid, signal.SIGINT)  # Ctrl-C: the whole group
        elif how == "TERM":
            process.send_signal(signal.SIGTERM)  # timeout(1), a CI cancel: the command only
        elif how == "KILL":
            process.send_signal(signal.SIGKILL)  # the command only: workers on their own
    except ProcessLookupError:
        pass


def finish(process: subprocess.Popen) -> tuple[int | None, str]:
    """Exit code (None: hung, then killed) and stderr."""
    try:
        _, stderr = process.communicate(timeout=HANG_S)
        return process.returncode, stderr.decode(errors="replace")
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        _, stderr = process.communicate()
        return None, stderr.decode(errors="replace")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--work", type=Path, default=None)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    work = args.work or Path(tempfile.mkdtemp(prefix="wbpower-soak."))
    work.mkdir(parents=True, exist_ok=True)
    corpora = make_corpora(work)
    out = work / "out"
    # the reference sets, each written by an undisturbed run; the time a fit takes
    sets, full_s = {}, []
    for name, corpus in corpora.items():
        reference = work / f"reference_{name}"
        started = time.monotonic()
        code, stderr = finish(start(corpus, reference))
        full_s.append(time.monotonic() - started)
        assert code == 0, stderr
        sets[name] = contents(reference)
    assert sets["A"] != sets["B"] and all(sets.values())
    code, stderr = finish(start(corpora["A"], out))
    assert code == 0, stderr

    failures: list[str] = []
    codes: Counter[str] = Counter()
    signals_sent: Counter[str] = Counter()
    left_by_kill = 0
    two_writers = 0
    started = time.monotonic()
    before_main = 0
    recent_s = list(full_s)  # how long the last undisturbed fits took
    for run in range(args.runs):
        before = contents(out)
        temporaries_before = set(temporaries(out))
        mine = rng.choice("AB")
        how = rng.choice(("INT", "TERM", "KILL", "none"))
        # up to a little past the end of a fit, as long as the last undisturbed ones took
        # (the machine's load changes: a fixed delay would land after the end most times)
        delay_s = rng.uniform(0.0, 1.1 * sorted(recent_s)[len(recent_s) // 2])
        second = rng.random() < 0.3
        first = start(corpora[mine], out)
        began = time.monotonic()
        other = None
        if second:
            two_writers += 1
            time.sleep(rng.uniform(0.0, 0.5 * max(recent_s)))
            other = start(corpora["B" if mine == "A" else "A"], out)
        if how != "none":
            time.sleep(delay_s)
            stop(first, how)
            signals_sent[how] += 1
        code, stderr = finish(first)
        if how == "none" and not second and code == 0:
            recent_s = [*recent_s[-4:], time.monotonic() - began]
        other_code, other_stderr = finish(other) if other is not None else (None, "")
        codes[f"{how}:{code}"] += 1
        if other is not None:
            codes[f"second:{other_code}"] += 1
        now = contents(out)
        where = f"run {run} ({mine}, {how} after {delay_s:.2f} s, second writer {second})"
        if code is None or (other is not None and other_code is None):
            failures.append(f"{where}: hung ({stderr.strip()[-200:]})")
        if now not in sets.values():
            failures.append(f"{where}: not one complete set: {sorted(now)}")
        # killed by the signal itself (no handler yet): Python's start-up, before wbpower's
        # code runs (a traceback from an import, if any, is Python's own); nothing written
        # (Python exits 1 where the signal lands in its site initialisation)
        started_only = (
            code in (1, -signal.SIGINT, -signal.SIGTERM)
            and "wbpower:" not in stderr
            and "wifibot_power/" not in stderr  # no frame of wbpower's own code
        )
        if started_only:
            before_main += 1
        if "Traceback" in other_stderr or ("Traceback" in stderr and not started_only):
            failures.append(f"{where}: a traceback: {(stderr + other_stderr)[-300:]}")
        if other is None:  # one writer: its exit code says what the folder holds
            if code in (0, 3) and now != sets[mine]:
                failures.append(f"{where}: exit {code} but its set is not in place")
            if (code in (2, 130, 143) or started_only) and now != before:
                failures.append(f"{where}: exit {code} but the folder changed")
            if code not in (0, 2, 3, 130, 143, -signal.SIGKILL) and not started_only:
                failures.append(f"{where}: exit {code}: {stderr.strip()[-200:]}")
        deadline = time.monotonic() + ORPHAN_S
        while alive_with(str(out)) and time.monotonic() < deadline:
            time.sleep(0.05)
        left = alive_with(str(out))
        if left:
            failures.append(f"{where}: processes left behind: {left}")
            for pid in left:
                os.kill(pid, signal.SIGKILL)
        # a temporary file a SIGKILL left stays until the next writer reaches write_set
        stray = sorted(set(temporaries(out)) - temporaries_before)
        if stray:
            if how != "KILL":
                failures.append(f"{where}: temporary files left without a SIGKILL: {stray}")
            left_by_kill += 1
    # a last, undisturbed writer removes what any SIGKILL left
    code, stderr = finish(start(corpora["A"], out))
    if code != 0 or contents(out) != sets["A"] or temporaries(out):
        failures.append(f"final clean run: exit {code}, temporaries {temporaries(out)}")
    summary = {
        "runs": args.runs,
        "seed": args.seed,
        "signals": dict(signals_sent),
        "runs_with_a_second_writer": two_writers,
        "exit_codes": dict(sorted(codes.items())),
        "runs_after_which_a_sigkill_left_temporary_files": left_by_kill,
        "runs_killed_by_the_signal_in_python_start_up": before_main,
        "temporary_files_after_the_final_run": len(temporaries(out)),
        "fit_s_last": [round(x, 2) for x in recent_s],
        "seconds": round(time.monotonic() - started, 1),
        "failures": failures,
    }
    print(json.dumps(summary, indent=2))
    raise SystemExit(1 if failures else 0)


if __name__ == "__main__":
    main()
