"""`--json` is one JSON document on stdout however a command ends (cli.md, top): on success
(`error` null), on failure (`error` the one-line message, exit 2), with skipped input
(`skipped: [{file, reason}]`, exit 1); `warnings` holds every warning said on stderr, the
reader's included. And a batch names every input it left out with its own reason, on
stderr and in `skipped`, for `inspect`, `fit`, `diagnose` and `report` (issue 26), also
when nothing in it could be used.
"""

from __future__ import annotations

import gzip
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from wifibot_power.cli import COMMANDS

SAMPLE_LOGS = Path(__file__).resolve().parents[1] / "sample_logs"
MOTION = [f"v0.{s}0_d10_s1_r{r}" for s in (3, 5, 7, 9) for r in (1, 2)]


def _document(result, code: int) -> dict:
    """stdout as the one JSON document of cli.md, and the exit code."""
    assert result.exit_code == code, (result.exit_code, result.stdout[-500:], result.stderr)
    doc = json.loads(result.stdout)  # the whole of stdout: one document, nothing else
    assert isinstance(doc, dict)
    assert {"error", "skipped", "warnings"} <= set(doc), sorted(doc)
    assert isinstance(doc["skipped"], list) and isinstance(doc["warnings"], list)
    for item in doc["skipped"]:
        assert set(item) == {"file", "reason"} and item["reason"], item
    assert all(isinstance(w, str) and "\n" not in w for w in doc["warnings"])
    return doc


def _failed(result, *words: str) -> dict:
    """A failure: exit 2, `error` the one line printed on stderr."""
    doc = _document(result, 2)
    assert isinstance(doc["error"], str) and doc["error"], doc
    line = result.stderr.strip().splitlines()[-1]
    assert line == f"wbpower: error: {doc['error']}", (line, doc["error"])
    for word in words:
        assert word in doc["error"], doc["error"]
    return doc


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> Path:
    if not SAMPLE_LOGS.is_dir():
        pytest.skip("sample_logs/ is not there (made by 'make sample-logs')")
    folder = tmp_path_factory.mktemp("good")
    for name in [*MOTION, "idle_r1"]:
        shutil.copy(SAMPLE_LOGS / f"{name}.csv.gz", folder)
    return folder


@pytest.fixture(scope="module")
def model_file(tmp_path_factory) -> Path:
    from test_export import drive_section

    path = tmp_path_factory.mktemp("model") / "model.json"
    path.write_text(json.dumps({"format": "wbpower-model", "drive": drive_section()}))
    return path


# -- 1. every command, on failure and on success -------------------------------------------
def _failing(tmp: Path, logs: Path, model_file: Path) -> dict[str, tuple[list[str], str]]:
    """Per command: arguments that fail, and a word of the error."""
    empty = tmp / "empty.csv"
    empty.write_text("")
    a_file = tmp / "a_file"
    a_file.write_text("x")
    return {
        "inspect": (["inspect", empty], "the file is empty"),
        "segment": (["segment", empty], "the file is empty"),
        "fit": (["fit", empty], "the file is empty"),
        "diagnose": (["diagnose", empty], "the file is empty"),
        "energy": (["energy", "--speed", "-1", "--dist", "10"], "speed"),
        "lifetime": (["lifetime", "--rate", "100", "--sweep", "nowhere"], "sweep"),
        "simulate": (["simulate", "-o", a_file], "is a file"),
        "report": (["report", logs, "-o", a_file], "is a file"),
        "export": (["export", "--model", tmp / "none.json", "--to", "rmf"], "no such model"),
        "docs": (["docs", "nowhere"], "no documentation page 'nowhere'"),
    }


def test_every_command_prints_one_document_when_it_fails(wbpower, tmp_path, logs, model_file):
    cases = _failing(tmp_path, logs, model_file)
    assert set(cases) == set(COMMANDS)  # a new command gets its case here
    for command, (args, word) in cases.items():
        _failed(wbpower(*args, "--json"), word)
        # and without --json, nothing on stdout: the document is --json's alone
        assert wbpower(*args).stdout == "", command


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_usage_error_of_the_command_line_is_a_document_too(wbpower, command):
    """Found by the option parser before the command runs (an unknown option)."""
    doc = _failed(wbpower(command, "--bogus", "--json"), "no such option: --bogus")
    assert doc["skipped"] == [] and doc["warnings"] == []


@pytest.mark.parametrize(
    ("args", "word"),
    [
        (["fit", "{logs}", "--jobs", "-1"], "--jobs"),  # click's range check of a shared option
        (["diagnose", "{logs}", "--supply-voltage", "0"], "--supply-voltage"),  # ReadOptions'
        (["inspect", "{logs}", "--time-unit", "days"], "--time-unit"),
        (["segment", "{logs}/idle_r1.csv.gz", "--sample-period", "-1"], "--sample-period"),
    ],
)
def test_errors_of_the_shared_reading_options_are_documents(wbpower, logs, args, word):
    _failed(wbpower(*(a.format(logs=logs) for a in args), "--json"), word)


def test_every_command_prints_one_document_when_it_succeeds(wbpower, tmp_path, logs, model_file):
    one = logs / f"{MOTION[0]}.csv.gz"
    cases = {
        "inspect": (["inspect", one], "logs"),
        "segment": (["segment", one], "phases"),
        "fit": (["fit", logs, "-j", "1"], "cruise"),
        "diagnose": (["diagnose", logs, "-j", "1"], "findings"),
        "energy": (["energy", "--speed", "0.8", "--dist", "10", "--steps", "10"], "energy_J"),
        "lifetime": (["lifetime", "--rate", "100"], "lifetime_s"),
        "simulate": (
            ["simulate", "-o", tmp_path / "sim", "--speeds", "0.5", "--trips", "2x1"]
            + ["--repeats", "1", "--modes", "", "--sample-period", "0.01"],
            "runs",
        ),
        "report": (["report", logs, "-o", tmp_path / "report", "-j", "1"], "report"),
        "export": (
            ["export", "--model", model_file, "--to", "rmf", "--turn-rate", "0.5"],
            "parameters",
        ),
        "docs": (["docs", "causes"], "text"),
    }
    assert set(cases) == set(COMMANDS)
    for command, (args, key) in cases.items():
        doc = _document(wbpower(*args, "--json"), 0)
        assert doc["error"] is None and doc["skipped"] == [], (command, doc["skipped"])
        assert key in doc, (command, sorted(doc))


def test_the_document_holds_the_warnings_of_the_reader(wbpower, tmp_path, logs):
    """A log without its sample period: the reader's assumption is a warning, in `--json`."""
    text = gzip.open(logs / "idle_r1.csv.gz", "rt").read()
    kept = [line for line in text.splitlines() if "sample_period_s" not in line]
    (tmp_path / "idle_r9.csv").write_text("\n".join(kept) + "\n")
    for name in MOTION:
        shutil.copy(logs / f"{name}.csv.gz", tmp_path)
    for args in (["segment", tmp_path / "idle_r9.csv"], ["fit", tmp_path], ["diagnose", tmp_path]):
        result = wbpower(*args, "--json")
        doc = _document(result, 0)
        said = [w for w in doc["warnings"] if "idle_r9.csv" in w and "assumed" in w]
        assert said, (args[0], doc["warnings"])
        assert f"wbpower: warning: {said[0]}" in result.stderr


# -- 2. a batch names every input it leaves out, with its own reason -------------------------
#: file -> a word of its reason; read-time reasons (`inspect` gives them too) first
READ_TIME = {
    "empty.csv": "the file is empty",
    "text.csv": "'abc' where a number belongs",
    "reversed.csv": "--flip-current",
    "speed0.csv": "speed",
    "v0.30_d10_s1_r1.csv.gz": "is also the run_id of",
}
AFTER_READING = {
    "still.csv": "no motion found",
    "starts_moving.csv": "segmentation in doubt",
}


def _header(run_id: str, mode: str, **meta: object) -> str:
    lines = ["# wbpower-log: 1", f"# run_id: {run_id}", f"# mode: {mode}"]
    lines += [f"# {key}: {value}" for key, value in meta.items()]
    return "\n".join([*lines, "# sample_period_s: 0.001", ""])


def _bad_files(folder: Path, logs: Path) -> None:
    """Files refused for seven different reasons, beside good ones."""
    rng = np.random.default_rng(0)
    motion = {"speed_mps": 0.5, "distance_m": 10, "steps": 1}
    (folder / "empty.csv").write_text("")
    (folder / "text.csv").write_text(_header("text", "idle") + "power_W\n23.1\nabc\n23.3\n")
    current = "".join(f"{-2 + 0.01 * x:.4f},12.0\n" for x in rng.standard_normal(2000))
    (folder / "reversed.csv").write_text(_header("rev", "idle") + "current_A,voltage_V\n" + current)
    idle = "".join(f"{23.3 + 0.1 * x:.3f}\n" for x in rng.standard_normal(20000))
    speed0 = {**motion, "speed_mps": 0}
    (folder / "speed0.csv").write_text(_header("speed0", "motion", **speed0) + "power_W\n" + idle)
    (folder / "still.csv").write_text(_header("still", "motion", **motion) + "power_W\n" + idle)
    # another log under the run_id of v0.30_d10_s1_r1: the one the reader meets second is
    # left out
    text = gzip.open(SAMPLE_LOGS / "v0.70_d10_s1_r3.csv.gz", "rt").read()
    (folder / "same_run_id.csv").write_text(
        re.sub(r"# run_id: .*", "# run_id: v0.30_d10_s1_r1", text)
    )
    # a motion log cut 3 s into its motion: it starts moving (a doubted segmentation); 1 mW
    # added to each reading, so that it is another recording, not a piece of the log beside
    # it (which is analysed once, as that log: test_pipeline_pieces.py)
    text = gzip.open(logs / "v0.50_d10_s1_r1.csv.gz", "rt").read().splitlines()
    head = [line.replace("v0.50_d10_s1_r1", "starts") for line in text if line.startswith("#")]
    rows = [line for line in text if not line.startswith("#")]
    power = np.array(rows[1:], dtype=float)
    moving = int(np.argmax(power > power[:200].mean() + 8))
    body = [f"{value + 0.001:.4f}" for value in power[moving + 3000 :]]
    (folder / "starts_moving.csv").write_text("\n".join([*head, rows[0], *body]) + "\n")


def _reasons(result, doc: dict, folder: Path) -> dict[str, str]:
    """file name -> reason, checked to be the same on stderr and in `skipped`, each reason
    naming its own file."""
    said = {}
    for item in doc["skipped"]:
        name = Path(item["file"]).name
        assert name not in said, f"{name} skipped twice"
        assert item["reason"].startswith(f"{item['file']}: "), item
        assert f"wbpower: skipped: {item['reason']}\n" in result.stderr, item
        said[name] = item["reason"]
    on_stderr = re.findall(r"^wbpower: skipped: (.*)$", result.stderr, re.MULTILINE)
    assert len(on_stderr) == len(said), (on_stderr, said)
    return said


def _check_batch(result, doc: dict, folder: Path, expected: dict[str, str]) -> None:
    said = _reasons(result, doc, folder)
    assert set(said) == set(expected), (sorted(said), sorted(expected))
    for name, word in expected.items():
        assert word in said[name], (name, said[name])
    assert len(set(expected.values())) >= 5  # five different reasons at least
    assert not any("other reasons" in line for line in result.stderr.splitlines()[:-1]), (
        result.stderr
    )


@pytest.fixture(scope="module")
def batch(tmp_path_factory, logs) -> Path:
    folder = tmp_path_factory.mktemp("batch")
    for log in logs.iterdir():
        shutil.copy(log, folder)
    _bad_files(folder, logs)
    return folder


@pytest.mark.parametrize("command", ["inspect", "fit", "diagnose", "report"])
def test_a_batch_names_each_skipped_input_with_its_own_reason(wbpower, batch, command, tmp_path):
    args = [command, batch, "--json"] + (["-o", tmp_path / "out"] if command == "report" else [])
    result = wbpower(*args)
    doc = _document(result, 1)
    assert doc["error"] is None
    expected = READ_TIME if command == "inspect" else {**READ_TIME, **AFTER_READING}
    # the run_id kept is the first met: the other of the two is the one skipped
    _check_batch(result, doc, batch, expected)


@pytest.mark.parametrize("command", ["fit", "diagnose", "report"])
def test_a_batch_with_nothing_usable_still_names_each_input(wbpower, logs, command, tmp_path):
    """No usable run at all: fit and diagnose fail (exit 2: today's worst case for CI was an
    empty stdout) and still list every input with its reason (not "3 for other reasons");
    report writes what it can (exit 1). The run that starts moving is left out here: its
    speed column makes it free driving, which the drive model uses (cli.md), so with it the
    batch is not "nothing usable" for fit."""
    folder = tmp_path / "bad"
    folder.mkdir()
    _bad_files(folder, logs)
    (folder / "same_run_id.csv").unlink()  # alone, it is not a duplicate
    (folder / "starts_moving.csv").unlink()  # usable by the drive model (above)
    expected = {**READ_TIME, **AFTER_READING}
    del expected["v0.30_d10_s1_r1.csv.gz"]
    del expected["starts_moving.csv"]
    args = [command, folder, "--json"] + (["-o", tmp_path / "out"] if command == "report" else [])
    result = wbpower(*args)
    doc = _document(result, 1) if command == "report" else _failed(result)
    _check_batch(result, doc, folder, expected)


def test_a_result_json_cannot_hold_is_an_error_document_not_a_traceback(wbpower, monkeypatch):
    """The document is printed when the command ends; what it holds is made JSON when the
    command hands it over, so a bad value is the command's one-line error."""
    from wifibot_power.energy import EnergyReport

    monkeypatch.setattr(EnergyReport, "summary", lambda self: {"energy_J": object()})
    result = wbpower("energy", "--speed", "0.8", "--dist", "10", "--json")
    doc = _failed(result, "internal error")
    assert "energy_J" not in doc


def test_print_json_keeps_what_json_safe_would_make_of_odd_keys_and_leaves(capsys):
    """A result with a tuple key, a numpy array, a path and NaN prints as `json_safe` makes
    it; a value nothing can encode is the command's one-line error."""
    from wifibot_power.cli.json_document import DOCUMENT, JsonDocument, print_json

    document = JsonDocument()
    token = DOCUMENT.set(document)
    try:
        print_json({("a", 1): np.array([1.0, np.nan]), "p": Path("x/y.csv"), "f": np.float32(2)})
        with pytest.raises(TypeError):
            print_json({"bad": object()})
    finally:
        DOCUMENT.reset(token)
    document.emit()
    printed = json.loads(capsys.readouterr().out)
    assert printed["('a', 1)"] == [1.0, None]
    assert printed["p"] == "x/y.csv" and printed["f"] == 2.0


def test_print_json_refuses_at_once_what_would_fail_when_printed():
    """np.datetime64 becomes a datetime under `json_safe`, which JSON cannot hold: refused by
    `print_json` (the command's one-line error), not a traceback when the document is
    printed at the end."""
    from wifibot_power.cli.json_document import DOCUMENT, JsonDocument, print_json

    document = JsonDocument()
    token = DOCUMENT.set(document)
    try:
        with pytest.raises(TypeError, match="not JSON serializable"):
            print_json({"started": np.datetime64("2026-11-28T03:00")})
    finally:
        DOCUMENT.reset(token)
    assert document.result is None
