"""No table ever cuts a number, at 80, 100 or 120 columns, on every command's human output.

Each command is run in-process with rich's console width set (as a terminal of that width
would), and checked three ways:
- no '…' (rich's mark of a cut cell) and no line wider than the terminal;
- every number of the one-table `--wide` rendering appears whole in the narrow one (a
  number folded over two lines, or cut, would not);
- the numbers the JSON gives (`--json`, the contract) appear in the text, to the decimals
  the text shows them with (unit changes such as s -> h written out below).
`inspect`, `segment`, `fit` and `diagnose` are computed once (monkeypatched), so the widths
cost no re-reading.
"""

from __future__ import annotations

import json
import re
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

from wifibot_power.cli import app, common

ROOT = Path(__file__).resolve().parents[1]
SAMPLE_LOGS = ROOT / "sample_logs"
ONE_LOG = SAMPLE_LOGS / "v0.50_d10_s10_r1.csv.gz"
WIDTHS = (80, 100, 120)
NUMBER = re.compile(r"(?<![\w.])[-+]?\d[\d,]*(?:\.\d+)?(?:e[-+]?\d+)?(?![\w])")


def _numbers(text: str) -> Counter[str]:
    return Counter(NUMBER.findall(text))


def _shown(value: float, text: str) -> bool:
    """Whether `value` appears in `text` as a number rounded to the digits it shows."""
    for token in NUMBER.findall(text):
        clean = token.replace(",", "").lstrip("+")
        try:
            shown = float(clean)
        except ValueError:
            continue
        if "e" in clean:
            mantissa = clean.split("e")[0]
            digits = len(mantissa.split(".")[1]) if "." in mantissa else 0
            if abs(shown - value) <= 0.51 * 10 ** (-digits) * abs(shown) + 1e-300:
                return True
            continue
        digits = len(clean.split(".")[1]) if "." in clean else 0
        if abs(shown - value) <= 0.5 * 10 ** (-digits) * (1 + 1e-9) + 1e-12:
            return True
    return False


def _run(args: list[str], width: int, monkeypatch) -> str:
    monkeypatch.setattr(common.stdout, "width", width)
    result = CliRunner().invoke(app, args)
    assert result.exception is None or isinstance(result.exception, SystemExit), result
    assert result.exit_code in (0, 1), result.stderr
    return result.stdout


# each case: the command's args, and (from its JSON) the values the text must show
def _inspect(doc) -> list[float]:
    return [
        v
        for row in doc["logs"]
        for v in (
            row["samples"],
            row["sample_period_s"] * 1e3,
            row["duration_s"],
            row["mean_power_W"],
            row["energy_J"],
        )
    ]


def _lifetime(doc) -> list[float]:
    rows = doc["rows"] if "rows" in doc else [doc]
    return [
        v
        for r in rows
        for v in (
            r["lifetime_s"] / 3600,
            r["baseline_s"] / 3600,
            r["improvement_pct"],
            r["e0a_J"] / 1e3,
            r["e0b_J"] / 1e3,
            r["distance_m"],
            r["speed_mps"],
            r["rate_mbps"],
            r["p_a_high_W"],
            r["p_a_low_W"],
            r["p_b_W"],
            r["travel_energy_J"],
        )
    ]


def _fit(doc) -> list[float]:
    out = [doc["idle_W"], *doc["idle_ci95"], *doc["components_W"].values()]
    for line in ("accel", "cruise"):
        part = doc[line]
        out += [part["intercept_W"], part["slope_W_per_mps"], part["r2"]]
        out += [*part["intercept_ci95"], *part["slope_ci95"]]
    return out


def _energy(doc) -> list[float]:
    rows = doc["rows"] if "rows" in doc else [doc]
    out = []
    for r in rows:
        out += [r["energy_J"], r["one_step_energy_J"], r["overhead_pct"], r["speed_mps"]]
        if "rows" not in doc:
            out += [r["time_s"], r["one_step_time_s"]]
    return out


def _segment(doc) -> list[float]:
    return [
        v
        for p in doc["phases"]
        for v in (p["t_start_s"], p["t_end_s"], p["duration_s"], p["mean_power_W"], p["energy_J"])
    ]


def _diagnose(doc) -> list[float]:
    out = [doc["baseline"]["heldout_rmse_J"], doc["extended"]["heldout_rmse_J"], doc["gain_pct"]]
    for f in doc["findings"]:
        out += [f["gain_pct"], f["estimate"]["value"], *f["estimate"]["ci95"]]
    return out


CASES: dict[str, tuple[list[str], Callable[[object], list[float]]]] = {
    "inspect": (["inspect", str(SAMPLE_LOGS)], _inspect),
    "lifetime": (["lifetime", "--rate", "100"], _lifetime),
    "lifetime-sweep": (["lifetime", "--rate", "54", "--sweep", "e0b"], _lifetime),
    "fit": (["fit", str(SAMPLE_LOGS)], _fit),
    "energy": (["energy", "--speed", "0.8", "--dist", "10", "--steps", "10"], _energy),
    "energy-sweep": (["energy", "--sweep", "speed"], _energy),
    "segment": (["segment", str(ONE_LOG)], _segment),
    "diagnose": (["diagnose", str(SAMPLE_LOGS)], _diagnose),
}


@pytest.fixture(scope="module")
def computed():
    """fit and diagnose of sample_logs/, once for every width."""
    if not ONE_LOG.is_file():
        pytest.skip("sample_logs/ is not there (made by 'make sample-logs')")
    from wifibot_power.diagnose import diagnose_logs
    from wifibot_power.fit import fit_logs
    from wifibot_power.inspect import inspect_logs
    from wifibot_power.segment import segment_file

    return {
        "fit": fit_logs([SAMPLE_LOGS], jobs=2),
        "diagnose": diagnose_logs([SAMPLE_LOGS], jobs=2),
        "inspect": inspect_logs([SAMPLE_LOGS], common.read_options()),
        "segment": segment_file(ONE_LOG, common.read_options()),
    }


@pytest.fixture
def precomputed(computed, monkeypatch):
    import wifibot_power.diagnose
    import wifibot_power.fit

    monkeypatch.setattr(wifibot_power.fit, "fit_logs", lambda *a, **k: computed["fit"])
    import wifibot_power.cli.inspect_cmd
    import wifibot_power.segment

    monkeypatch.setattr(
        wifibot_power.diagnose, "diagnose_logs", lambda *a, **k: computed["diagnose"]
    )
    monkeypatch.setattr(
        wifibot_power.cli.inspect_cmd, "inspect_logs", lambda *a, **k: computed["inspect"]
    )
    monkeypatch.setattr(wifibot_power.segment, "segment_file", lambda *a: computed["segment"])


@pytest.mark.parametrize("case", list(CASES))
def test_no_number_is_cut_at_any_width(case, precomputed, monkeypatch):
    args, expected = CASES[case]
    doc = json.loads(_run([*args, "--json"], 200, monkeypatch))
    values = [v for v in expected(doc) if v is not None]
    assert len(values) >= 4  # a check of nothing would prove nothing
    wide = _run([*args, "--wide"], 80, monkeypatch)
    assert "…" not in wide
    wide_numbers = _numbers(wide)
    for width in WIDTHS:
        text = _run(args, width, monkeypatch)
        assert "…" not in text, f"{case} at {width} columns:\n{text}"
        too_long = [line for line in text.splitlines() if len(line) > width]
        assert not too_long, f"{case} at {width} columns: {too_long[:2]}"
        missing = wide_numbers - _numbers(text)
        assert not missing, f"{case} at {width} columns lost {dict(missing)}:\n{text}"
        lost = [v for v in values if not _shown(v, text)]
        assert not lost, f"{case} at {width} columns does not show {lost[:5]}:\n{text}"


def test_the_checks_catch_a_cut_number():
    # what rich prints when it shrinks a table: the cut cell must fail both checks
    assert not _shown(3.98954, "lifetime h 3.98…") and _shown(3.98954, "lifetime h 3.9895")
    assert _numbers("│ 254.0 │") - _numbers("│ 254… │")


def test_wide_puts_every_column_in_one_table(monkeypatch):
    text = _run(["lifetime", "--rate", "100", "--wide"], 80, monkeypatch)
    assert text.count("Relay lifetime") == 1 and "(1/2)" not in text
    narrow = _run(["lifetime", "--rate", "100"], 80, monkeypatch)
    assert "(1/2)" in narrow and "(2/2)" in narrow


# -- piped output: COLUMNS honoured, 80 columns when it is not set (issue 28) ----------------
PIPED = {
    "inspect": ["inspect", str(SAMPLE_LOGS)],
    "fit": ["fit", str(SAMPLE_LOGS), "-j", "2"],
    "diagnose": ["diagnose", str(SAMPLE_LOGS), "-j", "2"],
    "energy": ["energy", "--speed", "0.8", "--dist", "10", "--steps", "10"],
    "energy-sweep": ["energy", "--sweep", "speed"],
    "lifetime": ["lifetime", "--rate", "100"],
    "lifetime-sweep": ["lifetime", "--rate", "54", "--sweep", "e0b"],
}


def _piped(args: list[str], columns: str | None) -> str:
    """`wbpower ARGS | cat`: stdout a pipe, COLUMNS as given (unset: None)."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
    if columns is not None:
        env["COLUMNS"] = columns
    done = subprocess.run(
        [sys.executable, "-m", "wifibot_power", *args],
        capture_output=True,
        text=True,
        env=env,
        stdin=subprocess.DEVNULL,
        timeout=600,
    )
    assert done.returncode in (0, 1), done.stderr
    return done.stdout


@pytest.mark.parametrize("case", list(PIPED))
def test_piped_output_fits_80_columns_and_cuts_no_number(case):
    if not ONE_LOG.is_file():
        pytest.skip("sample_logs/ is not there (made by 'make sample-logs')")
    args = PIPED[case]
    wide = _piped([*args, "--wide"], "80")
    texts = {}
    for columns, width in (("80", 80), (None, 80), ("100", 100)):
        text = texts[columns] = _piped(args, columns)
        assert "…" not in text
        too_long = [line for line in text.splitlines() if len(line) > width]
        assert not too_long, f"{case}, COLUMNS={columns}: {too_long[:2]}"
        missing = _numbers(wide) - _numbers(text)
        assert not missing, f"{case}, COLUMNS={columns} lost {dict(missing)}:\n{text}"
    assert texts[None] == texts["80"]  # 80 columns when COLUMNS is not set
    if max(map(len, wide.splitlines())) > 80:  # COLUMNS is used, not a fixed width
        assert texts["100"] != texts["80"]


def test_names_are_never_broken_mid_word(precomputed, monkeypatch):
    """inspect at 50 columns: the table is split, each file name stays whole on its line; and
    a listing of many logs of one kind is a line per log (what they share said once)."""
    text = _run(["inspect", str(SAMPLE_LOGS)], 50, monkeypatch)
    names = sorted(p.name for p in SAMPLE_LOGS.glob("*.csv.gz"))
    assert len(names) > 80
    for name in names:
        assert re.search(rf"│ {re.escape(name)} +│", text), name
    wide80 = _run(["inspect", str(SAMPLE_LOGS)], 80, monkeypatch)
    assert len(wide80.splitlines()) <= len(names) + 8, len(wide80.splitlines())
    assert "format: wbpower-csv" in wide80 and "run_id: the file's name" in wide80


def test_a_name_column_is_never_narrower_than_its_longest_word():
    """Laid out at 60 columns, a file name column with numbers beside it: the numbers move to
    a second table rather than the names being broken across lines ("v0.10_d10_s10_" /
    "r1.csv.gz", issue 28)."""
    from rich.console import Console

    from wifibot_power.cli.tables import Col, tables

    names = [f"v0.{k}0_d10_s10_r{k}.csv.gz" for k in range(1, 8)]
    cols = (Col("file", "text", key=True), *(Col(f"value {k}") for k in range(5)))
    rows = [[name, *(f"{1234.5678 * k:.4f}" for k in range(5))] for name in names]
    console = Console(width=60, record=True, file=open("/dev/null", "w"))  # noqa: SIM115
    for table in tables("t", cols, rows, width=60):
        console.print(table)
    text = console.export_text()
    assert all(len(line) <= 60 for line in text.splitlines())
    parts = len(re.findall(r"^t \(\d/\d\)", text, re.MULTILINE))
    assert parts >= 2  # the layout was tight: the numbers moved, not the names broken
    for name in names:
        assert text.count(f"│ {name} ") == parts, name  # whole, in every part
    assert _numbers(" ".join(" ".join(row[1:]) for row in rows)) <= _numbers(text)
