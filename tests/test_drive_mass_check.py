"""The mass check (drive/plausible.py): an effective mass far under the logs' `mass_kg` plus
`payload_kg` says the speed column is too large (km/h, mph under a speed_mps header), and
nothing is said where the logs give no mass, the speeds are right, or the power is a current
proxy. The real unicycles' table: benchmarks/validate_mass_check.py."""

from __future__ import annotations

import dataclasses
import json
import math
from types import SimpleNamespace

import pytest

from wifibot_power.drive import fit_drive
from wifibot_power.drive.model import TermValue
from wifibot_power.drive.plausible import SHORTFALL, mass_warning
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, format_free_log, simulate_free
from wifibot_power.drive.stats import DriveStats, drive_stats
from wifibot_power.drive.sums import sums_of
from wifibot_power.errors import LogError
from wifibot_power.io import read_log
from wifibot_power.io.metadata import robot_mass_kg
from wifibot_power.models.drive import WorkerStats
from wifibot_power.power_kind import UNIT_DOUBT, unit_doubts
from wifibot_power.run import Run

#: 6 runs of 60 s (the simulated robot: effective_mass_kg 30 kg)
SMALL = FreeDriveConfig(runs_per_surface=3, run_s=60.0, seed=5)
KMH, MPH = 3.6, 2.23694


@pytest.fixture(scope="module")
def free_runs() -> list[Run]:
    return [as_run(r) for r in simulate_free(SMALL)]


def _with(runs: list[Run], scale: float = 1.0, payload_kg: float = 0.0, **extra: str):
    """`runs` with their speed times `scale`, a payload and `extra` metadata (mass_kg...)."""
    out = []
    for run in runs:
        meta = dataclasses.replace(
            run.meta, extra={**run.meta.extra, **extra}, payload_kg=payload_kg
        )
        out.append(dataclasses.replace(run, meta=meta, speed_mps=run.speed_mps * scale))
    return out


def _said(runs: list[Run]) -> list[str]:
    model = fit_drive(runs)
    assert model is not None
    return list(unit_doubts(model.warnings))


def test_km_h_under_speed_mps_is_said_with_its_factor(free_runs):
    said = _said(_with(free_runs, KMH, mass_kg="20"))
    assert len(said) == 1
    # m_eff 30 / 3.6^2 = 2.3 kg against 20 kg: too large by sqrt(20 / 2.3) = 2.9x or more
    assert "2.3" in said[0] and "20 kg" in said[0] and "km/h" in said[0]
    factor = float(said[0].split("too large by ")[1].split("x")[0])
    assert 2.7 <= factor <= 3.1


def test_right_units_say_nothing(free_runs):
    # the mass as large as the effective mass itself: m_eff = m is a lossless drive, allowed
    assert _said(_with(free_runs, mass_kg="30")) == []


def test_mph_is_said_on_an_efficient_drive(free_runs):
    # m_eff 30 / 2.237^2 = 6 kg against 30 kg: under a third
    assert len(_said(_with(free_runs, MPH, mass_kg="30"))) == 1


def test_the_payload_counts_in_the_mass(free_runs):
    # 10 kg alone: 6 kg is not under a third of it; with a 20 kg payload (30 kg) it is
    assert _said(_with(free_runs, MPH, mass_kg="10")) == []
    said = _said(_with(free_runs, MPH, 20.0, mass_kg="10"))
    assert len(said) == 1 and "30 kg" in said[0]


def test_no_mass_no_check(free_runs):
    assert _said(_with(free_runs, KMH)) == []


def test_a_current_proxy_is_not_checked(free_runs):
    # its effective_mass_kg is in W/(m/s^2) (the force form): no mass to compare with, even
    # a mass it would be far under
    runs = _with(free_runs, KMH, mass_kg="1e4", voltage_assumed_v="24")
    model = fit_drive(runs)
    assert model.power_kind == "current_proxy"
    assert model.terms["effective_mass_kg"].ci95[1] < 1e4 / SHORTFALL
    assert _said(runs) == []


def _stats(*masses: float) -> list[SimpleNamespace]:
    return [SimpleNamespace(mass_kg=m) for m in masses]


def _term(value: float, high: float) -> dict[str, TermValue]:
    return {"effective_mass_kg": TermValue(value, (value - (high - value), high), "kg")}


def test_the_bound_is_the_upper_end_under_a_third_of_the_lightest_mass():
    assert SHORTFALL == 3.0
    assert mass_warning(_stats(30.0), _term(9.0, 10.0)) is None  # at the bound: not under
    assert mass_warning(_stats(30.0), _term(9.0, 9.99)) is not None
    # the lightest log's mass: 25 kg is not under a third of 90 kg's lighter partner (30)
    assert mass_warning(_stats(90.0, 30.0), _term(9.0, 10.5)) is None
    said = mass_warning(_stats(90.0, 29.0, math.nan), _term(9.0, 9.5))
    assert said is not None and "29 kg" in said and "lightest" in said
    # no mass, no term (not determined: not in the shown terms), no number
    assert mass_warning(_stats(math.nan), _term(1.0, 2.0)) is None
    assert mass_warning(_stats(30.0), {}) is None
    # a negative effective mass: said, without a factor it cannot have
    said = mass_warning(_stats(30.0), _term(-1.0, 0.5))
    assert said is not None and "too large (" in said


def test_mass_metadata_is_read_checked_and_carried(tmp_path, free_runs):
    meta = dataclasses.replace(free_runs[0].meta, extra={"mass_kg": "4,5"}, payload_kg=2.0)
    assert robot_mass_kg(meta) == 6.5  # a lone decimal comma, as every metadata number
    assert robot_mass_kg(dataclasses.replace(meta, extra={})) is None
    assert robot_mass_kg(dataclasses.replace(meta, extra={"mass_kg": "heavy"})) is None
    # a library caller's number, not text (a RunMeta made by hand)
    assert robot_mass_kg(dataclasses.replace(meta, extra={"mass_kg": 20})) == 22.0
    assert robot_mass_kg(dataclasses.replace(meta, extra={"mass_kg": float("nan")})) is None
    stats = drive_stats(_with(free_runs[:1], 1.0, 5.0, mass_kg="20")[0])
    assert stats.mass_kg == 25.0
    # through the cache's JSON and back; NaN (no mass) as null
    again = DriveStats.from_json(json.loads(json.dumps(stats.to_json())))
    assert again.mass_kg == 25.0
    none = drive_stats(free_runs[0])
    assert math.isnan(DriveStats.from_json(json.loads(json.dumps(none.to_json()))).mass_kg)
    # what a worker sends without the bins still holds it (no reading again to get it)
    light = WorkerStats(stats, sums_of(stats)).without_bins()
    assert light.bins_left_out and light.mass_kg == 25.0
    for bad in ("heavy", "0", "-3"):
        log = tmp_path / f"bad_{bad}.csv"
        log.write_text(f"# mass_kg: {bad}\ntime_s,power_W,speed_mps\n0,10,0\n0.1,10,0.1\n")
        with pytest.raises(LogError, match="mass_kg") as raised:
            read_log(log)
        assert str(log) in raised.value.one_line()


def test_fit_says_it_and_so_does_what_reads_its_model(tmp_path, wbpower):
    """End to end, as a user's km/h log meets it: the workers' statistics (bins left out)
    carry the mass to the fit, and `fit`, then a route's energy, an export and the report
    from its model say it: every number they give from the model is wrong with it."""
    logs = tmp_path / "logs"
    logs.mkdir()
    for run in simulate_free(SMALL):
        text = format_free_log(dataclasses.replace(run, speed_mps=run.speed_mps * KMH))
        first, rest = text.split(b"\n", 1)
        (logs / f"{run.run_id}.csv").write_bytes(first + b"\n# mass_kg: 20\n" + rest)
    out = tmp_path / "out"
    document = json.loads(wbpower("fit", logs, "--json", "-o", out).stdout)
    said = unit_doubts(document["drive"]["warnings"])
    assert len(said) == 1 and "km/h" in said[0] and said[0].startswith(UNIT_DOUBT)
    table = wbpower("fit", logs)
    assert "check the speed's unit" in " ".join((table.stdout + table.stderr).split())
    model = out / "model.json"
    log = sorted(logs.glob("*.csv"))[0]
    route = json.loads(wbpower("energy", "--profile", log, "--model", model, "--json").stdout)
    assert unit_doubts(route["warnings"]) == said
    export = wbpower("export", "--model", model, "--to", "rmf", "--turn-rate", "0.5", "--json")
    assert unit_doubts(json.loads(export.stdout)["warnings"]) == said
    report = wbpower("report", logs, "-o", tmp_path / "report")
    assert "drive model: " + said[0] in " ".join(report.stderr.split())
    page = (tmp_path / "report" / "report.html").read_text()
    assert "drive model: warning: speed unit in doubt" in page
