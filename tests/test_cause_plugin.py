"""A cause that needs trace windows, per-run trace data, a session covariate and a figure
panel is one module behind `Cause` plus one registry line (issue 24): a toy one, defined
in this file alone, registered for the test, and carried end to end by the library and the
CLI (its statistics in the worker, its covariate in the table, its trace metric, its
finding, its panel), with no other module knowing its name or fields."""

from __future__ import annotations

import json

import matplotlib
import numpy as np
import pytest
from numpy.testing import assert_allclose
from test_diagnose import GRID
from typer.testing import CliRunner

from wifibot_power.causes import (
    POWER_TRACE,
    Cause,
    Check,
    Evidence,
    PanelView,
    RunTable,
    RunView,
    registered,
)
from wifibot_power.cli import app
from wifibot_power.diagnose import diagnose_runs
from wifibot_power.simulate import SimConfig, simulate_runs, write_simulation

matplotlib.use("Agg")

WINDOW_S = 0.1


class CruiseOnset(Cause):
    """A made-up cause, for the plugin test: the energy in the first 0.1 s of each cruise
    (a trace window), each run's cruise samples (its trace data), twice its place in the
    session (a session covariate), a made-up trace metric and a panel of its own. Plausible:
    anything from 0 to 1e6 J."""

    name = "cruise_onset_toy"
    physics = "toy"
    term = "none"
    unit = "J"
    parameter = "onset_J"
    parameters = ("onset_J",)
    metric = POWER_TRACE
    min_size = 1e-6
    plausible = (0.0, 1e6)
    signature = "toy"
    default_size = 1.0
    realistic_range = (1.0, 1.0)
    columns = ("onset_window_J", "onset_window_s", "onset_session_x2")
    table_columns = ("onset_window_J", "onset_session_x2")

    def _windows(self, view: RunView) -> tuple[list[int], list[int]]:
        w = max(1, round(WINDOW_S / view.run.sample_period_s))
        starts = view.steps.accel_end
        return starts, [min(i + w, j) for i, j in zip(starts, view.steps.cruise_end, strict=True)]

    def energy_windows(self, view: RunView) -> tuple[list[int], list[int]]:
        return self._windows(view)

    def run_stats(self, view: RunView) -> dict[str, float]:
        starts, ends = self._windows(view)
        seconds = sum(e - s for s, e in zip(starts, ends, strict=True)) * view.run.sample_period_s
        return {
            "onset_window_J": float(view.window_energies_J(self).sum()),
            "onset_window_s": seconds,
        }

    def run_trace(self, view: RunView) -> np.ndarray | None:
        cruises = [p for p in view.segmentation.phases if p.phase == "cruise"]
        return np.array([p.i_end - p.i_start for p in cruises]) if cruises else None

    def session_columns(self, runs):
        return {"onset_session_x2": 2.0 * runs["session_order"].to_numpy(np.float64)}

    def evidence(self, table: RunTable) -> Evidence:
        mean_J = float(np.mean(table.runs["onset_window_J"]))
        return Evidence(self.name, True, 1e-9, mean_J, (mean_J, mean_J), {"onset_J": mean_J})

    def checks(self, table: RunTable, evidence: Evidence) -> list[Check]:
        return [Check("toy", True, "always")]

    def heldout_trace_gain_pct(self, runs, folds, traces) -> float:
        # the share of held-out runs whose trace data came through, as a percentage
        return 100.0 * np.mean([run_id in traces for run_id in runs["run_id"]])

    def energy_J(self, params, trip):
        return 0.0, 0.0

    def panels(self, view: PanelView):
        def draw(ax):
            x = view.runs["onset_session_x2"].to_numpy(np.float64)
            ax.plot(x, view.runs["onset_window_J"], "o", gid="toy")
            ax.set_title(view.title)

        return [draw]


@pytest.fixture(scope="module")
def sims():
    return simulate_runs(SimConfig(**{**GRID, "repeats": 1}, seed=9))


def test_a_toy_cause_with_windows_a_covariate_and_a_panel_is_one_class(sims) -> None:
    from wifibot_power.figures.diagnosis import findings_figure

    toy = CruiseOnset()
    with registered(toy):
        result = diagnose_runs([s.run for s in sims])
        assert [f.cause for f in result.findings][-1] == toy.name
        runs = result.runs.set_index("run_id")
        # its statistics, made in the worker: the energy of its windows, by hand here
        sim = next(s for s in sims if s.run.meta.mode == "motion")
        run = sim.run
        from wifibot_power.fit import segment_checked

        view = RunView(run, segment_checked(run), None)  # no shared energy: summed by hand
        starts, ends = toy._windows(view)
        by_hand_J = sum(run.power_W[s:e].sum() for s, e in zip(starts, ends, strict=True))
        assert_allclose(
            runs.at[run.meta.run_id, "onset_window_J"],
            by_hand_J * run.sample_period_s,
            rtol=1e-9,
        )
        # its covariate, from the batch's session order; its trace data, by run_id
        assert_allclose(runs["onset_session_x2"], 2.0 * runs["session_order"])
        assert set(result.traces[toy.name]) == set(runs.index)
        (finding,) = [f for f in result.findings if f.cause == toy.name]
        assert finding.gain_pct == pytest.approx(100.0)  # every held-out run's data came
        # its panel, drawn by the findings figure
        figure = findings_figure(result, result.traces)
        assert any(line.get_gid() == "toy" for ax in figure.axes for line in ax.lines)


def test_the_toy_cause_goes_through_the_cli(sims, tmp_path) -> None:
    from wifibot_power.simulate import SimConfig as Config

    write_simulation(Config(**{**GRID, "repeats": 1}, seed=9), tmp_path / "logs")
    with registered(CruiseOnset()):
        result = CliRunner().invoke(
            app, ["diagnose", str(tmp_path / "logs"), "--json", "--jobs", "1"]
        )
    assert result.exit_code == 0, result.output
    document = json.loads(result.stdout)
    assert "cruise_onset_toy" in document["extended"]["causes"]
    (candidate,) = [c for c in document["candidates"] if c["cause"] == "cruise_onset_toy"]
    assert candidate["named"] and candidate["estimate"] > 0
