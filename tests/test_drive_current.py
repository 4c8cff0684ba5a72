"""The drive model on a current-proxy log (drive/stats.py `current_proxy`, docs/drive-model.md,
"Current-only logs"): a log whose "power" is a nominal voltage times motor currents grows
with the motors' torque, so its terms take their force form (a constant rolling force while
translating, a viscous |v|, m a sign(v), a scrubbing moment while turning). Checked on a
proxy built from known forces (the design times the true coefficients gives its energy
exactly; the fit finds them) and, where /work/real_drive holds them, on the Husky logs."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from wifibot_power.drive import drive_stats, fit_drive
from wifibot_power.drive.identify import least_squares
from wifibot_power.drive.model import DriveModel
from wifibot_power.drive.stats import DriveStats, current_proxy
from wifibot_power.drive.windows import assemble, run_windows
from wifibot_power.run import Run, RunMeta

#: the true force-form coefficients of the proxy [W]: V_nom I = idle + u_0 F (stats.py)
TRUE = {"idle": 10.0, "rolling": 60.0, "viscous": 40.0, "mass": 150.0, "braking": 30.0}


def _proxy_run(run_id: str = "rev", knots_v=(0, 0, 0.6, 0.6, -0.6, -0.6, 0, 0), proxy=True):
    """1 kHz: stand, speed up to 0.6 m/s, hold, brake through 0 to -0.6 m/s (reversing), hold,
    brake to a stop; the proxy from the true forces: idle, a constant rolling force while
    translating, a viscous |v|, m |a| speeding up and m_b |a| braking (torque magnitudes)."""
    period_s = 1e-3
    knots_t = [0, 1, 1.6, 4, 5.2, 8, 8.6, 10]
    t = np.arange(0, 10, period_s)
    v = np.interp(t, knots_t, list(knots_v))
    a_sign = np.gradient(v, period_s) * np.sign(v)  # d|v|/dt
    power = (
        TRUE["idle"]
        + TRUE["rolling"] * (np.abs(v) > 1e-3)
        + TRUE["viscous"] * np.abs(v)
        + TRUE["mass"] * np.maximum(a_sign, 0)
        + TRUE["braking"] * np.minimum(a_sign, 0)
    )
    extra = {"surface": "floor"}
    if proxy:
        extra["voltage_assumed_V"] = "24 (nominal: motor currents only)"
    meta = RunMeta(run_id=run_id, sample_period_s=period_s, extra=extra)
    return Run(f"{run_id}.csv", "wbpower-csv", meta, t, power, speed_mps=v)


def test_a_logs_voltage_assumed_metadata_makes_it_a_current_proxy(tmp_path: Path, wbpower):
    """Through the reader, as a user's file: its '# voltage_assumed_V:' line (the converters'
    key, which the reader lower-cases like every metadata key) makes the log a current proxy,
    and `fit` says it takes the force form. (It did not: `current_proxy` looked for the key
    as written, so every converted Husky log was fitted as a power log through the CLI,
    while the validation script, which builds its runs by hand, got the force form.)"""
    import json

    from wifibot_power.io import ReadOptions, read_log

    run = _proxy_run()
    rows = "\n".join(
        f"{t:.4f},{p:.4f},{v:.5f}"
        for t, p, v in zip(run.time_s, run.power_W, run.speed_mps, strict=True)
    )
    for name, header in (
        ("proxy.csv", "# voltage_assumed_V: 24 (nominal: motor currents only)\n"),
        ("power.csv", ""),
    ):
        (tmp_path / name).write_text(
            f"# run_id: {name}\n# surface: floor\n{header}time_s,power_W,speed_mps\n{rows}\n"
        )
    assert drive_stats(read_log(tmp_path / "proxy.csv", ReadOptions())).current_proxy
    assert not drive_stats(read_log(tmp_path / "power.csv", ReadOptions())).current_proxy
    for names, said in ((["proxy.csv"], True), (["power.csv"], False)):
        result = wbpower("fit", *(str(tmp_path / n) for n in names), "--json")
        warnings = json.loads(result.stdout)["drive"]["warnings"]
        assert any("hold motor currents only" in w for w in warnings) is said


def test_current_proxy_is_read_from_the_metadata_and_cached():
    stats = drive_stats(_proxy_run())
    assert stats.current_proxy
    assert not drive_stats(_proxy_run(proxy=False)).current_proxy
    back = DriveStats.from_json(stats.to_json())
    assert back.current_proxy
    old = stats.to_json()
    del old["current_proxy"]  # a parse cache written before the flag: a power log
    assert not DriveStats.from_json(old).current_proxy


def test_force_form_regressors_give_the_energy():
    # the design times the true coefficients integrates to the proxy's energy; worked by hand:
    # d|v|/dt speeding up: 0.6 m/s twice (forwards, backwards), braking the same twice
    run = _proxy_run()
    windows = assemble([run_windows(drive_stats(run))], 0)
    true = {
        "idle_W": TRUE["idle"],
        "rolling_W_per_mps[floor]": TRUE["rolling"],
        "quadratic_W_per_mps2": TRUE["viscous"],
        "effective_mass_kg": TRUE["mass"],
        "braking_mass_kg": TRUE["braking"],
    }
    coef = np.array([true.get(c, 0.0) for c in windows.columns])
    predicted_J = float(np.sum(windows.design @ coef) * windows.window_s)
    measured_J = float(np.sum(windows.power_W) * windows.window_s)
    assert_allclose(predicted_J, measured_J, rtol=5e-3)
    up = windows.design[:, windows.columns.index("effective_mass_kg")]
    down = windows.design[:, windows.columns.index("braking_mass_kg")]
    assert_allclose(np.sum(up) * windows.window_s, 1.2, rtol=0.02)
    assert_allclose(np.sum(down) * windows.window_s, -1.2, rtol=0.02)


def test_force_form_fit_finds_the_forces():
    # runs at three cruise speeds so that the constant force and the viscous one part
    runs = []
    for k, top in enumerate((0.3, 0.6, 0.9, 0.45, 0.75, 1.0)):
        runs.append(_proxy_run(f"r{k}", (0, 0, top, top, -top, -top, 0, 0)))
    model = fit_drive(runs)
    assert_allclose(model.terms["effective_mass_kg"].value, TRUE["mass"], rtol=0.05)
    assert_allclose(model.terms["braking_mass_kg"].value, TRUE["braking"], rtol=0.1)
    assert_allclose(model.terms["quadratic_W_per_mps2"].value, TRUE["viscous"], rtol=0.1)
    # the fitted constant is 9.43 W, but its interval (± 0.10 W) misses the logs' standing
    # power, exactly 10 W here (the moving terms' small biases, rolling 60.55 W and mass
    # 151.2 against 60 and 150, leave it 0.57 W low): it is reported as not determined (identify.py
    # `idle_against_standing`) and still predicts
    assert_allclose(model.coefficient("idle_W"), TRUE["idle"], atol=1.0)
    assert "idle_W" not in model.terms
    assert any("the logs' standing power, 10 ± 0 W" in r for r in model.not_determined)
    # the constant force while translating: the rolling term, or the step on moving (the
    # two regressors are one here: no turning)
    constant = model.surfaces["floor"]["rolling_W_per_mps"].value
    if "drive_on_W" in model.terms:
        constant += model.terms["drive_on_W"].value
    assert_allclose(constant, TRUE["rolling"], rtol=0.05)
    assert any("force form" in w for w in model.warnings)


DRIVE = Path(os.environ.get("WBPOWER_REAL_DRIVE") or "/work/real_drive") / "borealtc"


@pytest.mark.skipif(not DRIVE.is_dir(), reason=f"no converted BorealTC logs in {DRIVE}")
def test_force_form_fits_a_real_current_log_as_well():
    # the Husky logs' "power" is 24 V x motor current. The force form is chosen by physics,
    # not by this data: fitted per surface on every other log as `fit` reads them, it leaves
    # 4% less squared residual on the windows than P = F v's (0.961; 7% more on the
    # validation script's own trips before the thirteenth session: the data hardly choose
    # between them); a force form without the rate-dependent part of turning (the Coulomb
    # part alone) left 37% more then and failed this
    from scripts import load_script

    root = Path(__file__).resolve().parents[1]
    script = load_script("validate_drive_real", root / "benchmarks" / "validate_drive_real.py")
    runs = script.runs_of(sorted(DRIVE.rglob("*.csv.gz"))[::2])  # as `fit` reads them
    assert runs and all(current_proxy(run) for run in runs)
    stats = [drive_stats(run) for run in runs]
    surfaces = sorted({script.group_of(run, "borealtc") for run in runs})
    sse = {True: 0.0, False: 0.0}
    for proxy in (True, False):
        for surface in surfaces:  # one fit per surface, as the validation's per-group rows
            forms = [
                DriveStats(**{**s.__dict__, "current_proxy": proxy})
                for s, run in zip(stats, runs, strict=True)
                if script.group_of(run, "borealtc") == surface
            ]
            table = assemble([run_windows(s) for s in forms], 2)
            X, y = table.design, table.power_W
            used = np.any(X != 0, axis=0)
            coef = least_squares(X[:, used], y)
            sse[proxy] += float(np.sum(np.square(y - X[:, used] @ coef)))
    assert sse[True] < 1.15 * sse[False], sse


def test_force_form_turning_moment_is_its_own_term():
    # a current log holds no drivers' step: in the force form the constant (Coulomb) part of
    # the scrubbing moment has its own column, turning_coulomb_W, the share of the window
    # turning (0 driving straight), and the step on moving has none; the power form's step
    # is the share moving or turning (1 in both), and it has no turning_coulomb_W
    period_s = 1e-2
    t = np.arange(0, 12, period_s)
    v = np.where((t >= 2) & (t < 6), 0.5, 0.0)  # straight 2-6 s
    yaw = np.where((t >= 7) & (t < 11), 1.0, 0.0)  # spin in place 7-11 s
    columns = {}
    for proxy in (True, False):
        extra = {"surface": "floor", "voltage_assumed_V": "24"} if proxy else {"surface": "floor"}
        meta = RunMeta(run_id="spin", sample_period_s=period_s, extra=extra)
        run = Run("spin.csv", "wbpower-csv", meta, t, 10 + 0 * t, speed_mps=v, yaw_rate_radps=yaw)
        windows = assemble([run_windows(drive_stats(run))], 0)
        mid = (np.arange(windows.size) + 0.5) * windows.window_s
        straight, spin = (mid > 3) & (mid < 5), (mid > 8) & (mid < 10)
        for name in ("drive_on_W", "turning_coulomb_W[floor]"):
            column = windows.design[:, windows.columns.index(name)]
            columns[proxy, name] = (column[straight], column[spin])
    assert_allclose(columns[True, "turning_coulomb_W[floor]"], [[0.0] * 4, [1.0] * 4])
    assert_allclose(columns[True, "drive_on_W"], 0.0)
    assert_allclose(columns[False, "drive_on_W"], 1.0)
    assert_allclose(columns[False, "turning_coulomb_W[floor]"], 0.0)


def test_force_form_fit_names_the_constant_turning_moment():
    # proxies of straight runs and of spins at several rates: V_nom I = idle + the rolling
    # force while the wheels turn (a spin's sides each drive their own way, rolling
    # included: windows.py `_force_form`) + a Coulomb moment while turning + a part growing
    # with the rate; the straight runs tell the rolling force from the moment, the fit gives
    # the constant moment its own named term and says why the step on moving has no number
    period_s = 1e-2
    t = np.arange(0, 12, period_s)
    runs = []
    extra = {"surface": "floor", "voltage_assumed_V": "24"}
    for k, rate in enumerate((0.3, 0.6, 0.9, 1.2, 0.45, 0.75)):
        yaw = np.interp(t, [0, 2, 2.5, 9, 9.5, 12], [0, 0, rate, rate, 0, 0])
        power = 10 + (40 + 80) * (np.abs(yaw) > 1e-3) + 50 * np.abs(yaw)
        meta = RunMeta(run_id=f"s{k}", sample_period_s=period_s, extra=extra)
        runs.append(
            Run(f"s{k}.csv", "wbpower-csv", meta, t, power, speed_mps=0 * t, yaw_rate_radps=yaw)
        )
    for k, speed in enumerate((0.3, 0.6, 0.9)):
        v = np.interp(t, [0, 2, 2.5, 9, 9.5, 12], [0, 0, speed, speed, 0, 0])
        power = 10 + 40 * (np.abs(v) > 1e-3)
        meta = RunMeta(run_id=f"d{k}", sample_period_s=period_s, extra=extra)
        runs.append(
            Run(f"d{k}.csv", "wbpower-csv", meta, t, power, speed_mps=v, yaw_rate_radps=0 * t)
        )
    model = fit_drive(runs)
    floor = model.surfaces["floor"]
    assert_allclose(floor["turning_coulomb_W"].value, 80.0, rtol=0.05)
    assert_allclose(floor["turning_Nm"].value, 50.0, rtol=0.1)
    assert "drive_on_W" not in model.terms
    assert any(r.startswith("drive_on_W: a motor current") for r in model.not_determined)
    assert any("turning_coulomb_W" in w for w in model.warnings)
    # a power log has no such term, and says nothing of it
    plain = fit_drive([as_power_log(r) for r in runs])
    assert all("turning_coulomb_W" not in named for named in plain.surfaces.values())
    assert not any("turning_coulomb_W" in r for r in plain.not_determined)


def as_power_log(run: Run) -> Run:
    extra = {k: v for k, v in run.meta.extra.items() if k != "voltage_assumed_V".lower()}
    meta = RunMeta(run_id=run.meta.run_id, sample_period_s=run.meta.sample_period_s, extra=extra)
    return Run(run.file, run.format, meta, run.stamps_s, run.power_W, speed_mps=run.speed_mps,
               yaw_rate_radps=run.yaw_rate_radps)  # fmt: skip


def _proxy_model():
    runs = [
        _proxy_run(f"r{k}", (0, 0, top, top, -top, -top, 0, 0))
        for k, top in enumerate((0.3, 0.6, 0.9, 0.45, 0.75, 1.0))
    ]
    return fit_drive(runs), runs


def test_a_proxy_models_terms_carry_the_force_forms_units_and_kind():
    """A current proxy's terms are forces times the motors' no-load speed: printed in those
    units (its effective_mass_kg is W/(m/s^2), no mass), and the model says what its power
    is (`power_kind`), kept in model.json; a power log's model keeps the physical units."""
    from wifibot_power.drive.terms import FORCE_FORM_UNITS, TERM_BY_NAME

    model, runs = _proxy_model()
    assert model.power_kind == "current_proxy"
    assert model.terms["effective_mass_kg"].unit == "W/(m/s^2)"
    for name, term in model.terms.items():
        assert term.unit == FORCE_FORM_UNITS[name]
    back = DriveModel.from_json(model.to_json())
    assert back.power_kind == "current_proxy"
    assert model.to_json()["power_kind"] == "current_proxy"
    assert "power_kind" not in model.summary()  # cli.md's drive object: its warnings say it
    power = fit_drive([_proxy_run(r.meta.run_id, proxy=False) for r in runs])
    assert power.power_kind == "power"
    assert power.terms["effective_mass_kg"].unit == TERM_BY_NAME["effective_mass_kg"].unit == "kg"
    mixed = fit_drive([*runs[:3], *(_proxy_run(f"p{k}", proxy=False) for k in range(3))])
    assert mixed.power_kind == "mixed"


def test_an_older_model_file_is_read_as_a_proxy_by_its_warning():
    """A model.json written before `power_kind` was kept: its current-proxy warning says it."""
    from wifibot_power.power_kind import power_kind_of

    model, _ = _proxy_model()
    old = model.to_json()
    del old["power_kind"]
    assert power_kind_of(old) == "current_proxy"
    assert DriveModel.from_json(old).power_kind == "current_proxy"
    old["warnings"] = [
        w + "; mixed with power logs, their terms are not comparable" for w in old["warnings"]
    ]
    assert power_kind_of(old) == "mixed"
    old["warnings"] = []
    assert power_kind_of(old) == "power"


def test_a_proxy_model_is_not_exported_as_power(tmp_path, wbpower):
    """RMF's and Gazebo's parameters are power's: a model of current-only logs is refused in
    one line naming the file, and nothing is written."""
    import json

    model, _ = _proxy_model()
    path = tmp_path / "model.json"
    path.write_text(json.dumps({"drive": model.to_json()}))
    for target in ("rmf", "gazebo"):
        out = tmp_path / f"out.{target}"
        result = wbpower("export", "--model", path, "--to", target, "-o", out)
        assert result.exit_code != 0
        (line,) = result.stderr.strip().splitlines()
        assert str(path) in line and "current-only logs" in line and "power" in line
        assert not out.exists()


def test_a_routes_energy_from_a_proxy_model_is_predicted_in_the_force_form():
    """`energy --profile` with a proxy model: the route's design is the force form the model
    was fitted on (the same energy as the model predicts for that route logged as a proxy),
    and a warning says the energy is the proxy's, not the battery's."""
    from wifibot_power.drive.profile import route_energy

    model, runs = _proxy_model()
    route = runs[1]
    got = route_energy(model, route.time_s, route.speed_mps, surface="floor")
    _, expected_J = model.run_energy_J(drive_stats(route))
    assert_allclose(got.energy_J, expected_J, rtol=1e-9)
    assert any("current-only logs" in w for w in got.warnings)
    import dataclasses

    as_power = route_energy(
        dataclasses.replace(model, power_kind="power"),
        route.time_s,
        route.speed_mps,
        surface="floor",
    )
    as_power_J = as_power.energy_J
    assert abs(as_power_J - expected_J) > 0.01 * expected_J  # the power form differs


def test_a_proxy_routes_arcs_are_said_to_be_predicted_as_spins():
    """A proxy model keeps no track width: a route with arcs (moving and turning) is
    predicted with a spin's moment, and a warning says so; a straight route has none."""
    from wifibot_power.drive.profile import route_energy

    model, runs = _proxy_model()
    route = runs[1]
    straight = route_energy(model, route.time_s, route.speed_mps, surface="floor")
    assert not any("arcs" in w for w in straight.warnings)
    yaw = np.full(route.samples, 0.2)
    arcs = route_energy(model, route.time_s, route.speed_mps, yaw, surface="floor")
    assert any("arcs are predicted with a spin's" in w for w in arcs.warnings)


def test_a_proxy_models_reasons_give_values_in_the_force_forms_units(monkeypatch):
    """A value said in a not-determined reason (a term held at its bound: what least squares
    without the bounds gives) is in the same units as the table: the force form's for a
    current proxy (it said W/(m/s)^2 for a viscous force's W/(m/s), kg for W/(m/s^2))."""
    monkeypatch.setitem(TRUE, "viscous", -40.0)  # a negative viscous force: held at 0
    model, _ = _proxy_model()
    (reason,) = [r for r in model.not_determined if r.startswith("quadratic_W_per_mps2")]
    assert "held at its physical bound 0" in reason
    assert "W/(m/s))" in reason and "W/(m/s)^2" not in reason


def test_a_routes_energy_is_printed_to_its_intervals_decimals(tmp_path, wbpower):
    """`energy --profile`'s table says each energy to the decimals its 90% interval shows (two
    significant digits of its width: `fit_tables.interval_digits`), not a fixed 0.1 J; --json
    keeps every digit."""
    import json

    from wifibot_power.cli.fit_tables import interval_digits

    model, runs = _proxy_model()
    path = tmp_path / "model.json"
    section = model.to_json()
    section["relative_rms"] *= 100  # a noisier robot's spread: an interval ~200 J wide
    path.write_text(json.dumps({"drive": section}))
    route = tmp_path / "route.csv"
    run = runs[1]
    route.write_text(
        "time_s,speed_mps\n"
        + "".join(f"{t:.3f},{v:.4f}\n" for t, v in zip(run.time_s, run.speed_mps, strict=True))
    )
    args = ("energy", "--profile", route, "--model", path)
    doc = json.loads(wbpower(*args, "--json").stdout)
    assert doc["pi90_J"] is not None
    digits = interval_digits(doc["pi90_J"])
    assert digits == 0  # whole joules, where 0.1 J was printed
    shown = wbpower(*args).stdout
    total = next(line for line in shown.splitlines() if "total" in line)
    assert f"{doc['energy_J']:.{digits}f}" in total
    assert f"{doc['pi90_J'][0]:.{digits}f}-{doc['pi90_J'][1]:.{digits}f} J" in shown
