"""Progress on stderr (issue 28: `report sample_logs/` was 14.5 s of blank screen, `simulate`
11 s): every command that can run for seconds draws a live line on stderr while it works
(a bar over the files, then a spinner naming the step under way) when stderr is a terminal,
and nothing when stderr is a pipe or with `--json` (docs/cli-output.md, "Progress").

The terminal is a real pseudo-terminal (pty) on the child's stderr; stdout stays a pipe, and
must hold the command's result alone, never a progress line."""

from __future__ import annotations

import json
import os
import pty
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

SAMPLE_LOGS = Path(__file__).resolve().parents[1] / "sample_logs"
MOTION = [f"v0.{s}0_d10_s1_r{r}" for s in (3, 5, 7, 9) for r in (1, 2)]

#: what each command's live line says while it works (cli/*_cmd.py)
SAYS = {
    "fit": ["reading and segmenting", "fitting the models"],
    "diagnose": ["reading and segmenting", "diagnosing"],
    "report": ["reading and segmenting", "drawing the figures"],
    "simulate": ["simulating: 1 of 2 runs done"],
    "segment": ["segmenting"],
    "inspect": ["reading"],
}


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> Path:
    if not SAMPLE_LOGS.is_dir():
        pytest.skip("sample_logs/ is not there (made by 'make sample-logs')")
    folder = tmp_path_factory.mktemp("logs")
    for name in [*MOTION, "idle_r1"]:
        shutil.copy(SAMPLE_LOGS / f"{name}.csv.gz", folder)
    few = folder / "few"  # for report, the slowest: four speeds, one run each
    few.mkdir()
    for name in MOTION[::2]:
        shutil.copy(SAMPLE_LOGS / f"{name}.csv.gz", few)
    return folder


def _args(command: str, logs: Path, tmp: Path) -> list[str]:
    return {
        "fit": ["fit", str(logs), "-j", "1"],
        "diagnose": ["diagnose", str(logs), "-j", "1"],
        "report": ["report", str(logs / "few"), "-o", str(tmp / "report"), "-j", "1"],
        "simulate": ["simulate", "-o", str(tmp / "sim"), "--speeds", "0.5", "--trips", "2x1"]
        + ["--repeats", "2", "--modes", "", "--sample-period", "0.01"],
        "segment": ["segment", str(logs / f"{MOTION[0]}.csv.gz")],
        "inspect": ["inspect", str(logs)],
    }[command]


def _run(args: list[str], terminal: bool) -> tuple[int, str, str]:
    """Run wbpower with stdout a pipe and stderr a pty (`terminal`) or a pipe: exit code,
    stdout, stderr (the bytes the terminal received, escape codes included)."""
    env = {**os.environ, "TERM": "xterm-256color", "COLUMNS": "100"}
    env.pop("NO_COLOR", None)
    command = [sys.executable, "-m", "wifibot_power", *args]
    if not terminal:
        done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=600)
        return done.returncode, done.stdout, done.stderr
    leader, follower = pty.openpty()
    child = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=follower, stdin=subprocess.DEVNULL, env=env
    )
    os.close(follower)
    received = bytearray()
    while True:
        try:
            chunk = os.read(leader, 65536)
        except OSError:  # EIO: the child closed its end
            break
        if not chunk:
            break
        received += chunk
    out = child.stdout.read().decode()
    code = child.wait(timeout=600)
    os.close(leader)
    return code, out, received.decode(errors="replace")


@pytest.mark.parametrize("command", sorted(SAYS))
def test_progress_shows_at_a_terminal_and_never_in_a_pipe(command, logs, tmp_path):
    args = _args(command, logs, tmp_path)
    code, out, err = _run(args, terminal=True)
    assert code == 0, err
    for words in SAYS[command]:
        assert words in err, (words, err[-2000:])
    assert "\x1b[" in err  # drawn and redrawn on the terminal
    assert not any(words in out for words in SAYS[command]), out  # stdout: the result alone
    assert "\x1b[?25l" not in out

    shutil.rmtree(tmp_path / "sim", ignore_errors=True)
    code, out, err = _run(args, terminal=False)  # stderr a pipe (a CI log)
    assert code == 0, err
    assert not any(words in err for words in SAYS[command]), err
    assert "\x1b[" not in err


@pytest.mark.parametrize("command", ["fit", "simulate", "segment"])
def test_no_progress_with_json_even_at_a_terminal(command, logs, tmp_path):
    code, out, err = _run([*_args(command, logs, tmp_path), "--json"], terminal=True)
    assert code == 0, err
    assert json.loads(out)["error"] is None
    assert not any(words in err for words in SAYS[command]), err
    assert "\x1b[" not in err


def test_energy_profile_of_a_log_shows_its_reading(tmp_path):
    """`energy --profile LOG --model FILE` reads a whole log (hours of free driving)."""
    free = tmp_path / "free"
    for args in (
        ["simulate", "-o", str(free), "--drive", "free", "--repeats", "3", "--duration", "20"]
        + ["--surfaces", "asphalt"],
        ["fit", str(free), "-o", str(tmp_path / "fit"), "-j", "1"],
    ):
        made = _run(args, terminal=False)
        assert made[0] == 0, made[2]
    log = sorted(free.glob("*.csv"))[0]
    args = ["energy", "--profile", str(log), "--model", str(tmp_path / "fit" / "model.json")]
    code, out, err = _run(args, terminal=True)
    assert code == 0, err
    assert f"reading {log.name}" in err and "energy J" in out
    code, out, err = _run([*args, "--json"], terminal=True)
    assert code == 0 and "reading" not in err and json.loads(out)["error"] is None
