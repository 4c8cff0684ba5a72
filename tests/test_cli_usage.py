"""Usage errors are usage errors (cli.md): exit 2, one line on stderr naming what to do,
before any work is done; never an "internal error". And `simulate --compress zst` writes
logs the readers (and the `zstd` tool) read back."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

SAMPLE_LOGS = Path(__file__).resolve().parents[1] / "sample_logs"


def _one_line_usage_error(result, *words: str) -> None:
    assert result.exit_code == 2, (result.exit_code, result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("wbpower: error: "), result.stderr
    assert "internal error" not in lines[0]
    for word in words:
        assert word in lines[0], lines[0]
    assert result.stdout == ""


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--compress", "bz2"], ["--compress", "none|gz|zst"]),
        (["--columns", "foo"], ["--columns", "full|power"]),
        (["--speeds", "0.5,fast"], ["--speeds"]),
        (["--trips", "2y"], ["--trips"]),
    ],
)
def test_simulate_bad_option_is_a_usage_error_before_writing(wbpower, tmp_path, args, words):
    out = tmp_path / "logs"
    _one_line_usage_error(wbpower("simulate", "-o", out, *args), *words)
    assert not out.exists()


def test_fit_into_an_existing_file_is_refused_before_the_fit(wbpower, tmp_path, monkeypatch):
    import wifibot_power.fit

    def no_fit(*args, **kwargs):
        raise AssertionError("the fit ran before -o was checked")

    monkeypatch.setattr(wifibot_power.fit, "fit_logs", no_fit)
    target = tmp_path / "model.json"
    target.write_text("keep me")
    _one_line_usage_error(wbpower("fit", SAMPLE_LOGS, "-o", target), "is a file, not a folder")
    assert target.read_text() == "keep me"


@pytest.mark.parametrize(
    "args",
    [
        ["energy", "--speed", "0.5", "--dist", "2"],
        ["lifetime", "--rate", "54"],
        ["diagnose", str(SAMPLE_LOGS)],
        ["simulate"],
        ["inspect", str(SAMPLE_LOGS)],
        ["segment", str(SAMPLE_LOGS / "idle_r1.csv.gz")],
    ],
)
def test_every_out_option_refuses_a_file(wbpower, tmp_path, args):
    target = tmp_path / "a_file"
    target.write_text("keep me")
    _one_line_usage_error(wbpower(*args, "-o", target), "is a file, not a folder")
    assert target.read_text() == "keep me"


def test_segment_of_a_folder_says_it_takes_one_file(wbpower):
    _one_line_usage_error(wbpower("segment", SAMPLE_LOGS), "segment takes one file")


#: every command (cli/__init__.py COMMANDS), and an argument list it would otherwise accept
_COMMAND_ARGS = {
    "inspect": [str(SAMPLE_LOGS)],
    "segment": [str(SAMPLE_LOGS / "idle_r1.csv.gz")],
    "fit": [str(SAMPLE_LOGS)],
    "energy": ["--speed", "0.5", "--dist", "2"],
    "lifetime": ["--rate", "54"],
    "diagnose": [str(SAMPLE_LOGS)],
    "simulate": ["-o", "unused"],
    "report": [str(SAMPLE_LOGS), "-o", "unused"],
    "export": ["--model", "model.json", "--to", "rmf"],
    "docs": ["causes"],
}


def _click_usage_error(result, command: str, *words: str) -> None:
    """One line (not click's Usage / Try / blank / Error block) that names the command's help."""
    _one_line_usage_error(result, *words, f"see 'wbpower {command} --help')")
    assert "Usage:" not in result.stderr and "Try '" not in result.stderr


def test_usage_error_covers_every_command():
    from wifibot_power.cli import COMMANDS

    assert set(_COMMAND_ARGS) == set(COMMANDS)


@pytest.mark.parametrize("command", sorted(_COMMAND_ARGS))
def test_unknown_option_is_one_line_for_every_command(wbpower, command):
    result = wbpower(command, *_COMMAND_ARGS[command], "--bogus")
    _click_usage_error(result, command, "no such option: --bogus")


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["energy", "--speed", "abc", "--dist", "2"], ["'abc' is not a valid float", "--speed"]),
        (["fit", str(SAMPLE_LOGS), "--jobs", "many"], ["'many' is not a valid", "--jobs"]),
        (["inspect", str(SAMPLE_LOGS), "--time-unit", "h"], ["--time-unit", "'h'"]),
        (["fit"], ["missing argument"]),
        (["segment"], ["missing argument"]),
        (["energy", "--speed"], ["option '--speed' requires an argument"]),
        (["segment", "a.csv", "b.csv"], ["unexpected extra argument"]),
        (["fit", str(SAMPLE_LOGS), "--jsn"], ["no such option: --jsn", "--json"]),
    ],
)
def test_bad_values_and_missing_arguments_are_one_line(wbpower, args, words):
    _click_usage_error(wbpower(*args), args[0], *words)


def test_unknown_command_is_one_line(wbpower):
    result = wbpower("fitt", "x")
    _one_line_usage_error(result, "no such command 'fitt'", "(see 'wbpower --help')")


def test_help_is_unchanged_and_the_installed_script_says_one_line(wbpower):
    assert wbpower("fit", "--help").stdout.startswith("Usage: wbpower fit [OPTIONS]")
    assert wbpower("fit", "--help").exit_code == 0
    # the command as a user runs it (python -m: its prog name), through `cli.main`
    result = subprocess.run(
        [sys.executable, "-m", "wifibot_power", "lifetime", "--rate", "54", "--zzz"],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2 and result.stdout == ""
    (line,) = result.stderr.splitlines()
    assert line.startswith("wbpower: error: no such option: --zzz (see '")
    assert line.endswith(" lifetime --help')")


def test_simulate_writes_zstd_logs_that_read_back(wbpower, tmp_path):
    out = tmp_path / "zst"
    args = ["--speeds", "0.5", "--trips", "2x1", "--repeats", "1", "--modes", ""]
    result = wbpower("simulate", "-o", out, "--compress", "zst", "--seed", "3", *args)
    assert result.exit_code == 0, result.stderr
    (log,) = out.glob("v*.csv*")
    assert log.name.endswith(".csv.zst")
    assert log.read_bytes()[:4] == bytes.fromhex("28b52ffd")  # the zstd frame magic number
    plain = tmp_path / "plain"
    assert wbpower("simulate", "-o", plain, "--seed", "3", *args).exit_code == 0
    (plain_log,) = plain.glob("v*.csv")
    if shutil.which("zstd"):
        unpacked = subprocess.run(["zstd", "-dc", log], capture_output=True, check=True).stdout
        assert unpacked == plain_log.read_bytes()
    zst = wbpower("inspect", "--json", log)
    raw = wbpower("inspect", "--json", plain_log)
    assert zst.exit_code == raw.exit_code == 0
    assert zst.stdout.replace(str(log), "X") == raw.stdout.replace(str(plain_log), "X")
