"""The small things of issue 28 that add up: what the human output says, in words a reader
takes in at once (`simulate`'s summary, `energy`'s digits, `diagnose` with no finding,
`--markdown`, what `-o` wrote)."""

from __future__ import annotations

import json
import re
from pathlib import Path

from wifibot_power.cli.simulate_cmd import size_text

SMALL_GRID = ["--speeds", "0.5", "--trips", "2x1", "--repeats", "2", "--modes", ""]


def test_simulate_says_what_it_wrote_in_words(wbpower, tmp_path):
    out = tmp_path / "sim"
    result = wbpower("simulate", "-o", out, *SMALL_GRID, "--effect", "decel_phase=0.3")
    assert result.exit_code == 0, result.stderr
    text = result.stdout
    logs = sorted(out.glob("v*.csv"))
    assert len(logs) == 2
    size = sum(p.stat().st_size for p in logs)
    assert re.search(rf"logs\s+│ 2 files, {re.escape(size_text(size))}", text), text
    assert size_text(size).endswith(" MB") and 1 <= float(size_text(size).split()[0]) < 1000
    assert re.search(r"effects\s+│ decel_phase=0\.3\b", text), text
    assert "csv_bytes" not in text and "{}" not in text and str(size) not in text
    # the JSON keeps the raw numbers (cli.md: `--json` for scripts)
    again = tmp_path / "again"
    doc = json.loads(wbpower("simulate", "-o", again, *SMALL_GRID, "--json").stdout)
    assert doc["csv_bytes"] == sum(p.stat().st_size for p in again.glob("v*.csv"))
    assert doc["effects"] == {}


def test_simulate_without_effects_says_none(wbpower, tmp_path):
    result = wbpower("simulate", "-o", tmp_path / "sim", *SMALL_GRID)
    assert re.search(r"effects\s+│ none\b", result.stdout), result.stdout


def test_sizes_read_as_people_read_them():
    assert size_text(91891604) == "91.9 MB"
    assert size_text(512) == "512 B"
    assert size_text(1500) == "1.5 kB"
    assert size_text(2.5e9) == "2.5 GB"
    assert size_text(Path(__file__).stat().st_size).split()[1] in ("B", "kB")


def _model_file(tmp_path: Path, t_acc_s: float, extensions: dict) -> Path:
    from wifibot_power.model import load_model
    from wifibot_power.outputs import json_safe

    data = json_safe(load_model("paper").to_json())  # NaN intervals -> null, as fit writes
    data["t_acc"]["intercept"] = t_acc_s  # a fitted t_acc, to the microsecond
    data["extensions"] = extensions
    data["source"] = "diagnose"
    path = tmp_path / "model.json"
    path.write_text(json.dumps(data))
    return path


def test_energy_shows_t_acc_to_the_tables_precision(wbpower, tmp_path):
    model = _model_file(tmp_path, 0.800034, {})
    result = wbpower("energy", "--speed", "0.8", "--dist", "10", "--steps", "10", "--model", model)
    assert result.exit_code == 0, result.stderr
    assert "t_acc 0.800 s" in result.stdout and "0.800034" not in result.stdout
    # the JSON keeps every digit
    doc = json.loads(
        wbpower("energy", "--speed", "0.8", "--dist", "10", "--model", model, "--json").stdout
    )
    assert doc["t_acc_s"] == 0.800034


def test_an_extension_that_adds_no_energy_is_said_not_a_row(wbpower, tmp_path):
    """A ripple of zero mean (cruise_ripple) adds 0 J: it was a `cruise_ripple - - 0.00` row;
    decel_phase adds a phase with time and energy: a row."""
    ripple = {"amplitude_W": 1.0, "hz_per_mps": 2.45}
    decel = {"t_dec_s": 0.3, "P_dec_intercept_W": 24.0, "P_dec_slope_W_per_mps": 2.6}
    model = _model_file(tmp_path, 1.0, {"decel_phase": decel, "cruise_ripple": ripple})
    args = ["energy", "--speed", "0.8", "--dist", "10", "--steps", "10", "--model", model]
    text = wbpower(*args).stdout
    rows = [line for line in text.splitlines() if line.startswith("│")]
    assert [r.split("│")[1].strip() for r in rows] == ["accel", "cruise", "decel", "total"], text
    assert "cruise_ripple adds 0 J to this trip" in " ".join(text.split()), text
    doc = json.loads(wbpower(*args, "--json").stdout)
    ripple_phase = [p for p in doc["phases"] if p["phase"] == "cruise_ripple"]
    assert ripple_phase and ripple_phase[0]["energy_J"] == 0  # the JSON still lists it


def test_diagnose_with_no_finding_does_not_repeat_the_baseline(wbpower, tmp_path):
    """No cause named: the extended model is the paper-form model, so its columns (and the
    pattern rows of its error) would repeat the baseline's; and no "(none)" row."""
    logs = tmp_path / "clean"
    made = wbpower(
        "simulate", "-o", logs, "--speeds", "0.3,0.5,0.7,0.9", "--trips", "2x1,10x1,10x5",
        "--repeats", "2", "--modes", "idle", "--sample-period", "0.002",
    )  # fmt: skip
    assert made.exit_code == 0, made.stderr
    result = wbpower("diagnose", logs, "-j", "1")
    assert result.exit_code == 0, result.stderr
    text = result.stdout
    doc = json.loads(wbpower("diagnose", logs, "-j", "1", "--json").stdout)
    assert doc["findings"] == [] and doc["extended"]["causes"] == []
    headers = [line for line in text.split("Pattern")[0].splitlines() if line.startswith("┃")]
    assert headers and not any("extended" in line for line in headers), text
    assert "(2/2)" not in text  # the table fits: no extended columns moved aside
    assert "paper-form" in text and "no cause named" in text
    patterns = text.split("Pattern")[1].split("Findings")[0]
    assert "baseline" in patterns and "extended" not in patterns, patterns
    assert "(none)" not in text
    assert "Findings: no cause named: " in text


def test_the_extended_columns_stay_when_a_cause_is_named():
    import pandas as pd

    from wifibot_power.cli.diagnose_cmd import _nothing_added

    class Result:
        findings: list = []
        runs = pd.DataFrame({"baseline_energy_J": [1.0, 2.0], "extended_energy_J": [1.0, 2.0]})

    assert _nothing_added(Result())
    Result.findings = ["decel_phase"]
    assert not _nothing_added(Result())
    Result.findings = []
    Result.runs = pd.DataFrame({"baseline_energy_J": [1.0, 2.0], "extended_energy_J": [1.0, 2.5]})
    assert not _nothing_added(Result())


def _said_written(result) -> list[str]:
    return [
        line.removeprefix("wbpower: wrote ")
        for line in result.stderr.splitlines()
        if line.startswith("wbpower: wrote ")
    ]


def test_every_command_with_o_says_what_it_wrote(wbpower, tmp_path):
    """`-o DIR` (and `--plot FILE`): each file written, one `wbpower: wrote PATH` line on
    stderr, and the `--json` document's `written` (diagnose said nothing; issue 28)."""
    logs = tmp_path / "logs"
    wbpower("simulate", "-o", logs, *SMALL_GRID[:-2], "--speeds", "0.3,0.6,0.9", "--modes", "")
    one = sorted(logs.glob("v*.csv"))[0]
    cases = {
        "inspect": ["inspect", logs],
        "segment": ["segment", one],
        "fit": ["fit", logs, "-j", "1"],
        "diagnose": ["diagnose", logs, "-j", "1"],
    }
    for command, args in cases.items():
        out = tmp_path / f"out_{command}"
        result = wbpower(*args, "-o", out)
        assert result.exit_code == 0, (command, result.stderr)
        files = sorted(str(p) for p in out.iterdir())
        assert files and sorted(_said_written(result)) == files, (command, result.stderr)
        _help_names_each_file(command, out)
        again = wbpower(*args, "-o", out, "--json")
        doc = json.loads(again.stdout)
        assert sorted(doc["written"]) == files == sorted(_said_written(again)), command
    # a run that writes nothing has no `written`, and says nothing of it
    quiet = wbpower("fit", logs, "-j", "1", "--json")
    assert "written" not in json.loads(quiet.stdout) and not _said_written(quiet)
    # --plot: its figure, the same way
    figure = tmp_path / "fit.png"
    doc = json.loads(wbpower("fit", logs, "-j", "1", "--plot", figure, "--json").stdout)
    assert doc["written"] == [str(figure)] and figure.is_file()


def _help_names_each_file(command: str, out: Path) -> None:
    """`-o`'s help says what it writes (it said "the tables (Parquet, JSON)" for every
    command): each file found in `out` is named there (a sweep's by its pattern)."""
    from test_cli_help import _help, _option_blocks

    block = " ".join(_option_blocks(_help(command))["--out"].split())
    for path in out.iterdir():
        name = path.name  # lifetime's sweep of X: lifetime_sweep_X.parquet
        name = re.sub(r"_sweep_\w+\.", "_sweep_X.", name) if command == "lifetime" else name
        assert name in block, (command, path.name, block)


def test_energy_and_lifetime_o_help_names_their_files(wbpower, tmp_path):
    cases = {
        "energy": [["--speed", "0.5", "--dist", "10"], ["--sweep", "speed"]],
        "lifetime": [["--rate", "54"], ["--rate", "54", "--sweep", "rate"]],
    }
    for command, runs in cases.items():
        out = tmp_path / command
        for args in runs:
            assert wbpower(command, *args, "-o", out).exit_code == 0
        assert len(list(out.iterdir())) >= 2
        _help_names_each_file(command, out)
