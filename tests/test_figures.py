"""Figures (wifibot_power/figures/): each checked through matplotlib's own objects (axis
labels with units, one shaded span per phase, the paper's line, a point per run), not only
that a file was written."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from wifibot_power.figures import (
    FIGURES,
    PHASE_COLOURS,
    figure5,
    figure7,
    findings_figure,
    heldout_error_figure,
    power_speed_figure,
    save_figure,
    trace_figure,
    trace_view,
)
from wifibot_power.figures.trace import envelope
from wifibot_power.model import paper_model
from wifibot_power.phases import Phase, Segmentation, Spike
from wifibot_power.run import Run, RunMeta

SAMPLE_LOGS = Path(__file__).resolve().parents[1] / "sample_logs"
#: a subset of sample_logs/ that fit and diagnose can use: 2 speeds x (10 m in 1 and 10 steps,
#: 3 repeats; 2 m in 1 step, 1 repeat) + the idle runs = 16 logs (the whole set takes ~5x)
SUBSET = (
    [f"v{v}_d10_s{s}_r{r}.csv.gz" for v in ("0.30", "0.90") for s in (1, 10) for r in (1, 2, 3)]
    + [f"v{v}_d2_s1_r1.csv.gz" for v in ("0.30", "0.90")]
    + ["idle_r1.csv.gz", "idle_r2.csv.gz"]
)


def _labels(ax) -> tuple[str, str]:
    return ax.get_xlabel(), ax.get_ylabel()


def _has_unit(label: str) -> bool:
    return "[" in label and label.rstrip().endswith("]")


@pytest.fixture(scope="module")
def subset_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("subset")
    for name in SUBSET:
        shutil.copy(SAMPLE_LOGS / name, folder / name)
    return folder


@pytest.fixture(scope="module")
def report(subset_dir: Path):
    from wifibot_power.report import build_report

    return build_report([subset_dir], jobs=1)


# -- the trace --------------------------------------------------------------------------------
def test_envelope_is_the_min_and_max_of_each_column() -> None:
    rng = np.random.default_rng(1)
    values = rng.normal(size=100_003)
    time_s = np.arange(values.size) * 1e-3
    env = envelope(time_s, values, columns=1000)
    starts = np.linspace(0, values.size, 1001).astype(int)
    assert env.time_s.size == 1000
    for k in (0, 1, 500, 999):  # brute force on a few columns
        chunk = values[starts[k] : starts[k + 1]]
        assert env.low[k] == chunk.min() and env.high[k] == chunk.max()
        assert env.mean[k] == pytest.approx(chunk.mean())
    assert env.low.min() == values.min() and env.high.max() == values.max()
    short = envelope(time_s[:10], values[:10], columns=1000)  # fewer samples than columns
    assert_allclose(short.low, values[:10])


def _motion_run(with_speed: bool) -> tuple[Run, Segmentation]:
    dt = 0.01
    t = np.arange(1000) * dt
    power = np.full(t.size, 23.3)
    power[200:300] = np.linspace(24, 31, 100)
    power[300:800] = 29.5
    speed = np.zeros(t.size)
    speed[200:300] = np.linspace(0, 0.5, 100)
    speed[300:800] = 0.5
    meta = RunMeta("r1", mode="motion", speed_mps=0.5, distance_m=2.5, steps=1, sample_period_s=dt)
    run = Run("r1.csv", "canonical", meta, t, power, speed_mps=speed if with_speed else None)
    bounds = [("idle", 0, 0, 200), ("accel", 1, 200, 300), ("cruise", 1, 300, 800),
              ("idle", 1, 800, 1000)]  # fmt: skip
    phases = tuple(
        Phase(step, name, a, b, a * dt, b * dt, float(power[a:b].mean()), 0.0)
        for name, step, a, b in bounds
    )
    return run, Segmentation("r1", phases, spikes=(Spike(2.0, 0.02, 40.0, 0.1),))


@pytest.mark.parametrize("with_speed", [True, False])
def test_trace_has_one_span_per_phase_units_spikes_and_speed(with_speed: bool) -> None:
    run, segmentation = _motion_run(with_speed)
    figure = trace_figure(trace_view(run, segmentation))
    ax = figure.axes[0]
    spans = [p for p in ax.patches if str(p.get_gid()).startswith("phase:")]
    assert [s.get_gid().split(":")[1] for s in spans] == ["idle", "accel", "cruise", "idle"]
    for span, phase in zip(spans, segmentation.phases, strict=True):
        assert span.get_facecolor()[:3] == pytest.approx(_rgb(PHASE_COLOURS[phase.phase]))
        x0 = span.get_x() if hasattr(span, "get_x") else span.get_xy()[0][0]
        assert x0 == pytest.approx(phase.t_start_s)
    assert _labels(ax) == ("time [s]", "power [W]")
    spikes = [line for line in ax.lines if line.get_gid() == "spikes"]
    assert len(spikes) == 1 and list(spikes[0].get_ydata()) == [40.0]
    assert {t.get_text() for t in ax.texts} >= {"idle", "cruise"}  # wide phases labelled
    if with_speed:
        assert len(figure.axes) == 2 and figure.axes[1].get_ylabel() == "speed [m/s]"
        assert max(figure.axes[1].lines[0].get_ydata()) == pytest.approx(0.5)
    else:
        assert len(figure.axes) == 1


def _rgb(colour: str) -> tuple[float, float, float]:
    from matplotlib.colors import to_rgb

    return to_rgb(colour)


def test_trace_of_a_long_log_draws_a_bounded_envelope() -> None:
    """2 M samples: the figure holds at most 2 * COLUMNS points, whatever the length, and
    the envelope still spans the samples' extremes (the spike survives the reduction)."""
    from wifibot_power.figures.trace import COLUMNS

    n = 2_000_000
    t = np.arange(n) * 1e-4
    power = np.full(n, 23.0)
    power[1_234_567] = 99.0  # one sample: the envelope must keep it
    meta = RunMeta("long", sample_period_s=1e-4)
    run = Run("long.csv", "canonical", meta, t, power)
    phase = Phase(1, "level", 0, n, 0.0, n * 1e-4, 23.0, 0.0)
    figure = trace_figure(run, Segmentation("long", (phase,)))
    ax = figure.axes[0]
    assert all(line.get_xydata().shape[0] <= 2 * COLUMNS for line in ax.lines)
    fill = ax.collections[-1]
    assert fill.get_paths()[0].vertices[:, 1].max() == 99.0


# -- P(v) -------------------------------------------------------------------------------------
def test_power_speed_points_lines_band_and_paper(report) -> None:
    fit = report.fit
    figure = power_speed_figure(fit)
    motion = fit.runs[(fit.runs["mode"] == "motion") & fit.runs["usable"]]
    assert len(figure.axes) == 2
    for ax, column, model_line, paper_line in zip(
        figure.axes,
        ("accel_mean_power_W", "cruise_mean_power_W"),
        (fit.model.accel, fit.model.cruise),
        ((23.9, 14.8), (23.9, 11.2)),  # the paper's Eq. 2 and Eq. 4
        strict=True,
    ):
        assert _labels(ax) == ("speed [m/s]", "mean power [W]")
        (points,) = [line for line in ax.lines if line.get_gid() == "runs"]
        assert len(points.get_xdata()) == len(motion) == 14
        assert_allclose(sorted(points.get_ydata()), sorted(motion[column]))
        (paper,) = [line for line in ax.lines if line.get_gid() == "paper"]
        x, y = paper.get_xdata(), paper.get_ydata()
        assert_allclose(y, paper_line[0] + paper_line[1] * x, rtol=1e-12)
        (fitted,) = [line for line in ax.lines if line.get_gid() == "fit"]
        assert_allclose(
            fitted.get_ydata(), model_line.intercept + model_line.slope * fitted.get_xdata()
        )
        band = [c for c in ax.collections if c.get_label() == "95% band"]
        assert len(band) == 1
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert any(t.startswith("paper") for t in labels) and any("95%" in t for t in labels)


def test_mean_band_is_the_textbook_interval() -> None:
    """y = 1 + 2x + e at x = 0, 1, 2, 3 with e = (+1, -1, -1, +1) · 0.1: OLS gives the line
    1 + 2x exactly (e is orthogonal to 1 and x), s² = 0.04 / 2, S_xx = 5, so at x = 1.5
    (the mean) the half width is t_{0.975,2} · s · sqrt(1/4)."""
    from wifibot_power.figures.power_speed import mean_band
    from wifibot_power.model import LinearFit

    x = np.array([0.0, 1, 2, 3])
    y = 1 + 2 * x + 0.1 * np.array([1, -1, -1, 1])
    low, high = mean_band(x, y, LinearFit(1.0, 2.0), np.array([1.5]))
    half = 4.302652729911275 * math.sqrt(0.04 / 2) * 0.5
    assert_allclose([low[0], high[0]], [4.0 - half, 4.0 + half], rtol=1e-9)


# -- diagnose ---------------------------------------------------------------------------------
def test_heldout_error_figure_has_a_point_per_run_per_model(report) -> None:
    diagnosis = report.diagnosis
    figure = heldout_error_figure(diagnosis)
    assert len(figure.axes) == 4
    labels = [ax.get_xlabel() for ax in figure.axes]
    assert labels[0] == "speed [m/s]" and all(_has_unit(label) for label in labels)
    speed_ax = figure.axes[0]
    runs = diagnosis.runs
    for model in ("baseline", "extended"):
        (points,) = [line for line in speed_ax.lines if line.get_gid() == model]
        # one sign in every figure (issue 28): measured − predicted, in % of the measured
        measured, predicted = runs["measured_energy_J"], runs[f"{model}_energy_J"]
        by_hand = 100 * (measured - predicted) / measured
        assert_allclose(sorted(points.get_ydata()), sorted(by_hand), rtol=1e-9)
        assert len(points.get_ydata()) == diagnosis.n_runs == 14
    assert all(ax.get_ylabel() == "measured − predicted [%]" for ax in figure.axes)
    # the legend is the figure's, outside the panels: it covers no point
    assert not any(ax.get_legend() for ax in figure.axes) and figure.legends


def test_findings_figure_shows_the_ripple_line_and_spectrum(report) -> None:
    diagnosis = report.diagnosis
    ripple = [f for f in diagnosis.findings if f.cause == "cruise_ripple"]
    assert ripple, "sample_logs have a 1 W ripple (sample_logs/README.md)"
    figure = findings_figure(diagnosis, diagnosis.traces)
    visible = [ax for ax in figure.axes if ax.axison]
    assert len(visible) == len(diagnosis.findings) + 1  # + the ripple's spectrum
    assert len(figure.axes) == len(visible)  # no empty panel (issue 28)
    from wifibot_power.causes import CAUSES

    codes = {c.name for c in CAUSES.values()} | {p for c in CAUSES.values() for p in c.parameters}
    for ax in visible:  # titled in words: no code name (decel_phase, t_dec_s, amplitude_W)
        title = ax.get_title(loc="left")
        assert title and not [c for c in codes if c.lower() in title.lower()], title
    residual = [ax.get_ylabel() for ax in visible if "predicted" in ax.get_ylabel()]
    assert all(label.startswith("measured − predicted") for label in residual)
    (ax,) = [ax for ax in visible if ax.get_ylabel() == "ripple frequency [Hz]"]
    (line,) = [line for line in ax.lines if line.get_gid() == "fit"]
    x, y = line.get_xdata(), line.get_ydata()
    assert_allclose(y[-1] / x[-1], ripple[0].estimate["hz_per_mps"])
    (spectrum_ax,) = [ax for ax in visible if ax.get_xlabel() == "frequency [Hz]"]
    (spectrum,) = [line for line in spectrum_ax.lines if line.get_gid() == "spectrum"]
    peak_hz = spectrum.get_xdata()[np.argmax(spectrum.get_ydata())]
    # the fastest run, 0.9 m/s: the truth is 2.449 Hz per m/s (sample_logs/truth.json), and
    # the spectrum's resolution is 1 / (cruise length) ~ 0.1 Hz
    assert peak_hz == pytest.approx(0.9 * 2.449, abs=0.15)


# -- the paper's figures ----------------------------------------------------------------------
def test_figure5_lines_are_eq56_and_points_are_the_measured_overheads(report) -> None:
    from wifibot_power.energy import trip_energy

    fit = report.fit
    figure = figure5(fit.model, fit.stop_and_go)
    ax_energy, ax_over = figure.axes
    assert _labels(ax_energy) == ("speed [m/s]", "trip energy [J]")
    assert _labels(ax_over) == ("speed [m/s]", "stop-and-go overhead [%]")
    assert ax_energy.get_yscale() == "linear"  # the fit lands near the paper: no log scale
    paper_lines = [line for line in ax_energy.lines if line.get_gid() == "model:1"]
    assert len(paper_lines) == 4  # 2 m and 10 m, each in 1 step and in 1 m steps
    # the paper's 10 m in one step at 0.5 m/s by hand (Eq. 5/6): t_acc from the paper model,
    # E = P_acc t_acc + P_v (10 - v t_acc / 2) / v
    paper = paper_model()
    t_acc = paper.t_acc_s(0.5)
    by_hand = (23.9 + 14.8 * 0.5) * t_acc + (23.9 + 11.2 * 0.5) * (10 - 0.5 * t_acc / 2) / 0.5
    (line,) = [line for line in paper_lines if line.get_label() == "10 m, 1 step (paper)"]
    at = np.flatnonzero(np.isclose(line.get_xdata(), 0.5))[0]
    assert line.get_ydata()[at] == pytest.approx(by_hand, rel=1e-9)
    assert by_hand == pytest.approx(trip_energy(paper, 0.5, 10.0).energy_J)
    measured = [c for c in ax_over.containers if c.get_label().startswith("measured")]
    (bars,) = measured
    x, y = bars.lines[0].get_xdata(), bars.lines[0].get_ydata()
    assert len(x) == len(fit.stop_and_go) == 2  # 0.3 and 0.9 m/s, 10 m in 10 steps
    assert_allclose(y, [r.overhead_pct for r in fit.stop_and_go])


def _figure7_axes(figure) -> list:
    axes = [ax for ax in figure.axes if ax.axison]
    assert len(axes) == 4
    assert [ax.get_xlabel() for ax in axes] == [
        "E0A, initial energy of A [kJ]",
        "E0B, initial energy of B [kJ]",
        "distance B drives [m]",
        "data rate [Mbit/s]",
    ]
    assert all(ax.get_ylabel() == "lifetime gain [%]" for ax in axes)
    return axes


def _legend_labels(figure) -> list[str]:
    (legend,) = figure.legends
    assert not any(ax.get_legend() for ax in figure.axes)  # one legend, under the panels
    return [t.get_text() for t in legend.get_texts()]


def test_figure7_has_each_sweep_a_line_per_rate_and_the_paper() -> None:
    """A fit unlike the paper's (idle 30 W): each panel a solid line per rate and the
    paper's dashed, the data rates as points with no line between them, and a legend of
    the three rates and the two styles, all of which show."""
    from dataclasses import replace

    from wifibot_power.lifetime import lifetime_sweep

    paper = paper_model()
    fitted = replace(paper.with_extensions({}, source="fit"), idle_W=30.0)
    figure = figure7(fitted, paper=paper)
    e0a, _, _, rate = _figure7_axes(figure)
    assert len([line for line in e0a.lines if line.get_gid() == "model:0"]) == 3  # rates
    dashed = [line for line in e0a.lines if line.get_gid() == "model:1"]
    assert len(dashed) == 3 and all(line.get_linestyle() == "--" for line in dashed)
    (line,) = [ln for ln in dashed if ln.get_color() == "#009e73"]  # 54 Mbit/s
    rows = lifetime_sweep("e0a", paper, 54.0)
    assert_allclose(line.get_ydata(), [r.improvement_pct for r in rows])
    assert_allclose(line.get_xdata(), [r.e0a_J / 1e3 for r in rows])
    # the data-rate panel: three separate scenarios, points never joined by a line
    assert all(ln.get_linestyle() == "None" for ln in rate.lines)
    assert sorted(x for ln in rate.lines if ln.get_gid() == "model:0" for x in ln.get_xdata())
    labels = _legend_labels(figure)
    assert labels == [
        "10 Mbit/s",
        "54 Mbit/s",
        "100 Mbit/s",
        "fitted (solid, filled)",
        "paper (dashed, ring)",
    ]


def test_figure7_draws_coinciding_lines_once_and_its_legend_says_so() -> None:
    """issue 28: a fit on the paper's coefficients drew each dashed paper line on its solid
    twin and listed six lines where three showed."""
    paper = paper_model()
    fitted = paper.with_extensions({}, source="fit")
    figure = figure7(fitted, paper=paper)
    e0a, e0b, dist, rate = _figure7_axes(figure)
    for ax in (e0a, e0b, dist):
        assert [ln.get_gid() for ln in ax.lines] == ["model:0"] * 3
    labels = _legend_labels(figure)
    assert labels[:3] == ["10 Mbit/s", "54 Mbit/s", "100 Mbit/s"]
    assert labels[3].startswith("fitted = paper within 0 % points")
    assert labels[4] == "paper (ring)"  # the rate panel's rings around the fitted points
    assert [ln.get_gid() for ln in rate.lines].count("model:1") == 1


def test_energy_plot_marks_the_trip_asked_about() -> None:
    from wifibot_power.energy import trip_energy

    model = paper_model()
    figure = figure5(model, distances_m=(4.0,), step_m=1.0, trip=(0.5, 4.0, 4))
    ax_energy, ax_over = figure.axes
    (star,) = [ln for ln in ax_energy.lines if ln.get_gid() == "trip"]
    assert star.get_xdata()[0] == 0.5
    by_eq56 = 4 * trip_energy(model, 0.5, 1.0).energy_J  # four 1 m steps
    assert star.get_ydata()[0] == pytest.approx(by_eq56, rel=1e-9)
    assert [ln for ln in ax_over.lines if ln.get_gid() == "trip"]


def test_one_sweep_gives_one_panel() -> None:
    figure = figure7(paper_model(), sweeps=("dist",), rates_mbps=(54.0,))
    assert len(figure.axes) == 1 and len(figure.axes[0].lines) == 1


# -- the registry and the files ---------------------------------------------------------------
def test_registry_lists_every_figure_function() -> None:
    assert set(FIGURES) == {
        "trace",
        "power_speed",
        "heldout_error",
        "findings",
        "figure5",
        "figure7",
        "drive_power",
        "drive_energy",
        "drive_terms",
    }
    assert all(spec.how_to_read and spec.title for spec in FIGURES.values())


@pytest.mark.parametrize("suffix", [".png", ".svg"])
def test_save_figure_writes_png_and_svg(tmp_path: Path, suffix: str) -> None:
    path = save_figure(figure7(paper_model(), sweeps=("rate",)), tmp_path / f"f{suffix}")
    head = path.read_bytes()[:200]
    assert head.startswith(b"\x89PNG") if suffix == ".png" else b"<svg" in head or b"<?xml" in head


def test_save_figure_refuses_other_suffixes(tmp_path: Path) -> None:
    from wifibot_power.errors import UsageError

    with pytest.raises(UsageError, match=r"\.png or \.svg"):
        save_figure(figure7(paper_model(), sweeps=("rate",)), tmp_path / "f.pdf")


def test_figure5_says_when_the_logs_hold_no_pair_and_is_silent_without_logs() -> None:
    note = "no trip in the logs in both 1 and N steps"
    with_logs = figure5(paper_model(), ())
    assert [t.get_text() for t in with_logs.axes[1].texts] == [note]
    without_logs = figure5(paper_model())  # `energy --plot`: no logs read
    assert len(without_logs.axes[1].texts) == 0
    lines = [line for line in without_logs.axes[0].lines if line.get_gid() == "model:0"]
    assert len(lines) == 4  # the paper's model drawn once, not also as "the paper's"
    assert len({line.get_color() for line in lines}) == 4  # one colour per trip


def test_findings_figure_without_a_cause_says_when_the_diagnosis_is_unexplained() -> None:
    """A findings figure said only "no cause named" beside an unexplained diagnosis (the
    REGBOT report): people look before they read, so it says unexplained too."""
    from test_diagnose import GRID

    from wifibot_power.diagnose import diagnose_runs
    from wifibot_power.figures.diagnosis import findings_figure
    from wifibot_power.simulate import SimConfig, simulate_runs

    def texts(result) -> list[str]:
        figure = findings_figure(result)
        return [t.get_text() for ax in figure.axes for t in ax.texts]

    once = diagnose_runs([s.run for s in simulate_runs(SimConfig(**{**GRID, "repeats": 1}))])
    assert once.unexplained and once.findings == ()
    assert any("no cause named" in t and "unexplained" in t for t in texts(once))
    null = diagnose_runs([s.run for s in simulate_runs(SimConfig(**GRID, seed=11))])
    assert not null.unexplained and null.findings == ()
    assert texts(null) == ["no cause named"]


def test_a_long_doubt_wraps_inside_the_trace_figure() -> None:
    """REGBOT traces carry two doubts of ~90 characters each: the title ran off the
    figure's right edge. It wraps at 150 characters, all of it kept, in doubt's red."""
    from dataclasses import replace

    run, segmentation = _motion_run(True)
    doubts = (
        "the run starts moving (0.0398 m/s over its first 9 ms): its first acceleration is "
        "not in the log",
        "the run ends moving (1.42 m/s over its last 9 ms): its last stop is not in the log",
    )
    figure = trace_figure(trace_view(run, replace(segmentation, doubts=doubts)))
    title = figure.axes[0].get_title(loc="left")
    lines = title.split("\n")
    assert max(len(line) for line in lines) <= 150 and len(lines) >= 3
    assert " ".join(lines[1:]) == "in doubt: " + "; ".join(doubts)


def test_power_speed_keeps_another_robots_runs_readable_beside_the_paper() -> None:
    """REGBOT's runs are 0.5-2 W; the paper's lines (24-50 W) set the scale and squashed
    them flat. The scale is the runs' and the fit's when the paper's line lies more than
    twice their span away, and the legend says the paper's line is off the scale; with the
    Wifibot's own runs (the test above) the paper's line stays in view."""
    from matplotlib.figure import Figure

    from wifibot_power.figures.power_speed import _panel
    from wifibot_power.model import LinearFit

    speed = np.array([0.7, 0.72, 0.74, 1.4, 1.5, 1.6, 1.87])
    power = 0.4 + 0.9 * speed
    ax = Figure().subplots()
    _panel(ax, speed, power, LinearFit(0.4, 0.9), LinearFit(23.9, 11.2), "#1f77b4", "cruise")
    low, high = ax.get_ylim()
    assert low < power.min() and power.max() < high < 5.0
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "paper: 23.9 + 11.2 v (off this scale, above)" in labels
    near = Figure().subplots()
    _panel(near, speed, 23.0 + 11.0 * speed, LinearFit(23.0, 11.0), LinearFit(23.9, 11.2), "k", "")
    assert "paper: 23.9 + 11.2 v" in [t.get_text() for t in near.get_legend().get_texts()]
    # a falling fit reads with a minus sign, not "+ -0.07"
    falling = Figure().subplots()
    _panel(
        falling, speed, 1.38 - 0.07 * speed, LinearFit(1.38, -0.07), LinearFit(23.9, 14.8), "k", ""
    )
    assert "fit: 1.38 − 0.07 v" in [t.get_text() for t in falling.get_legend().get_texts()]


def test_figure5_draws_a_model_only_where_it_holds() -> None:
    """REGBOT's fitted model (cruise -0.65 + 1.43 v W, fitted at 0.7-1.87 m/s) gave negative
    trip energies at 0.1 m/s and overheads of 3700%: each model is drawn over the speeds it
    was fitted on and where its energies are positive, the sweep reaches the fitted speeds,
    the legend says each model's range, and the energy scale is logarithmic where the two
    models differ a hundredfold (linear for the Wifibot's own fit: the test above)."""
    from dataclasses import replace

    from wifibot_power.model import LinearFit

    regbot = replace(
        paper_model(),
        accel=LinearFit(1.38, -0.07),
        cruise=LinearFit(-0.65, 1.43),
        idle_W=0.14,
        speed_range_mps=(0.7, 1.87),
        source="fitted",
    )
    figure = figure5(regbot, ())
    ax_energy, ax_over = figure.axes
    fitted = [line for line in ax_energy.lines if line.get_gid() == "model:0"]
    for line in fitted:
        x, y = np.asarray(line.get_xdata()), np.asarray(line.get_ydata(), float)
        assert np.isnan(y[x < 0.7 - 1e-9]).all() and (y[np.isfinite(y)] > 0).all()
        assert x.max() == pytest.approx(1.87) and np.isfinite(y[x >= 0.7]).all()
        assert "over 0.7-1.9 m/s" in line.get_label()
    paper_lines = [line for line in ax_energy.lines if line.get_gid() == "model:1"]
    for line in paper_lines:
        x, y = np.asarray(line.get_xdata()), np.asarray(line.get_ydata(), float)
        assert np.isnan(y[x > 0.9 + 1e-9]).all() and np.isfinite(y[x <= 0.9 + 1e-9]).all()
    # the overhead, where the one-step energy crossed 0, read 3700%: not drawn there
    for line in [line for line in ax_over.lines if line.get_gid() == "model:0"]:
        x, y = np.asarray(line.get_xdata()), np.asarray(line.get_ydata(), float)
        assert np.isnan(y[x < 0.7 - 1e-9]).all() and np.isfinite(y[x >= 0.7]).all()
    assert ax_energy.get_yscale() == "log"


def test_figure7_says_the_idle_power_each_model_stands_on() -> None:
    """Eq. 7-11 take a model's idle power as the whole robot's at rest: REGBOT's motor-only
    logs fit 0.14-1.4 W and drew a lifetime gain of 34% beside the paper's 3-4%, with nothing
    on the figure to say why. The title gives each model's idle power."""
    from dataclasses import replace

    motors_only = replace(paper_model(), idle_W=0.14, source="fit")
    figure = figure7(motors_only, sweeps=("rate",))
    title = figure.get_suptitle()
    assert "idle power" in title and "fitted 0.14 W" in title and "paper 23.3 W" in title
