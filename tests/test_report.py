"""`wbpower report` and `--plot` (cli.md, "Figures"): what report.html holds, that it stands
alone, that it loads in a real browser, and that each command draws its one figure."""

from __future__ import annotations

import base64
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest
from test_figures import SAMPLE_LOGS, SUBSET, report, subset_dir  # noqa: F401 - fixtures

from wifibot_power.report import build_report, write_report

IMG = re.compile(r'<img alt="[^"]*" src="data:image/png;base64,([A-Za-z0-9+/=]+)">')


@pytest.fixture(scope="module")
def written(report, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[Path]]:  # noqa: F811
    """The report of the subset, written once for the tests that read it."""
    folder = tmp_path_factory.mktemp("report")
    return folder, write_report(report, folder, jobs=2)


def test_report_html_embeds_every_figure_of_cli_md(report, written) -> None:  # noqa: F811
    """The model figures embedded as PNG and written as PNG and SVG; each run's trace as a
    PNG file, shown in the page by the trace view (its data embedded), not as 16 images."""
    tmp_path, written = written
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    pngs = sorted((tmp_path / "figures").glob("*.png"))
    svgs = sorted((tmp_path / "figures").glob("*.svg"))
    assert sorted(p for p in written if p.suffix in (".png", ".svg")) == sorted(pngs + svgs)
    names = {p.stem for p in pngs}
    # cli.md's list: each run's trace, P(v), the diagnosis views, Figures 5 and 7
    models = {"power_speed", "heldout_error", "findings", "figure5", "figure7"}
    assert models <= names
    traces = [p for p in pngs if p.stem.startswith("trace_")]
    assert len(traces) == len(report.traces) == 16
    assert {p.stem for p in svgs} == names - {p.stem for p in traces}  # SVG: model figures
    assert all(p.read_bytes().lstrip().startswith(b"<?xml") for p in svgs)
    embedded = IMG.findall(page)
    assert len(embedded) == len(pngs) - len(traces) == page.count("<img ")
    assert sorted(base64.b64decode(e) for e in embedded) == sorted(
        p.read_bytes() for p in pngs if not p.stem.startswith("trace_")
    )
    # self-contained: nothing is fetched from anywhere (links only within the page)
    assert not re.search(r'(src|href)="(?!data:|#)', page)
    assert not re.search(r"https?://", page)
    assert page.count('data-run="') >= 16 and '<canvas id="wb-canvas"' in page
    assert "not drawn" not in page.lower()
    assert "Stop-and-go overhead" in page and "cruise_ripple" in page


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()
    }


@pytest.fixture
def old_report(written, tmp_path: Path) -> Path:
    """A copy of the subset's report (16 traces and the model figures), as a report an
    earlier `report -o DIR` left in DIR, beside a file of the user's."""
    folder = tmp_path / "out"
    shutil.copytree(written[0], folder)
    (folder / "notes.txt").write_text("the user's, not the report's")
    return folder


def test_report_interrupted_while_writing_leaves_the_old_report(
    old_report: Path, real_n6705: Path, monkeypatch
) -> None:
    """cli.md: "Interrupted (Ctrl-C), a command ... writes nothing partial": a Ctrl-C after
    the new report's figure is written, as its page is: the old report.html and figures/ are
    untouched, none of the new mixed in, nothing left beside DIR."""
    import wifibot_power.outputs
    from wifibot_power.io import ReadOptions

    before = _snapshot(old_report)
    built = build_report([real_n6705], ReadOptions(supply_voltage_V=12.6))
    real_write = wifibot_power.outputs.write_atomic
    calls = []

    def ctrl_c_at_the_second_file(path, write):
        calls.append(path)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real_write(path, write)

    monkeypatch.setattr(wifibot_power.outputs, "write_atomic", ctrl_c_at_the_second_file)
    with pytest.raises(KeyboardInterrupt):
        write_report(built, old_report)
    assert len(calls) == 2  # the figure, then the page
    assert _snapshot(old_report) == before
    assert sorted(p.name for p in old_report.parent.iterdir()) == ["out"]


def test_report_replaces_the_old_figures_whole(old_report: Path, real_n6705: Path) -> None:
    """A new report into a folder holding an older one: figures/ holds the new report's
    figures only (none of the 16 old traces left mixed in); other files stay."""
    from wifibot_power.io import ReadOptions

    built = build_report([real_n6705], ReadOptions(supply_voltage_V=12.6))
    written = write_report(built, old_report)
    assert written == [
        old_report / "figures" / "trace_n6705c_dlog1.png",
        old_report / "report.html",
    ]
    assert sorted(_snapshot(old_report)) == [
        "figures/.wbpower-figures",  # what a later report may replace (issue 29)
        "figures/trace_n6705c_dlog1.png",
        "notes.txt",
        "report.html",
    ]
    page = (old_report / "report.html").read_text(encoding="utf-8")
    assert not IMG.findall(page) and page.count('class="wb-run-phases"') == 1  # the new run
    assert sorted(p.name for p in old_report.parent.iterdir()) == ["out"]


def test_report_of_a_log_without_motion_metadata_draws_its_trace(
    real_n6705: Path, tmp_path: Path
) -> None:
    """The real N6705C export: no mode, speed or steps, so no fit and no diagnosis; the
    report still draws its trace (steady levels), gives the level and spike tables `segment`
    prints, says once why the rest is not drawn, and links no figure it did not draw."""
    from wifibot_power.io import ReadOptions, read_log
    from wifibot_power.segment import segment_run

    options = ReadOptions(supply_voltage_V=12.6)
    built = build_report([real_n6705], options)
    assert built.fit is None and built.diagnosis is None
    write_report(built, tmp_path)
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == [
        ".wbpower-figures",
        "trace_n6705c_dlog1.png",
    ]
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert not IMG.findall(page)  # its trace is in the trace view
    # the fit's own reason for the run, as `fit` gives it, once in the page
    reason = "no mode or speed in its metadata, so it cannot be fitted"
    assert reason in built.fit_problem
    assert page.count(reason) == 1
    for name in ("power_speed", "figure5", "figure7", "heldout_error", "findings"):
        assert f'id="{name}"' not in page and f'href="#{name}"' not in page
    # the levels and spikes as `segment` finds them (segmented here, independently)
    run = read_log(real_n6705, options)
    run = run[0] if isinstance(run, list) else run
    segmentation = segment_run(run)
    assert len(segmentation.phases) >= 5 and segmentation.spikes
    for p in segmentation.phases:
        assert f"<td>{p.t_start_s:.4f}</td><td>{p.t_end_s:.4f}</td>" in page
        assert f"<td>{p.mean_power_W:.3f}</td><td>{p.energy_J:.2f}</td>" in page
    for spike in segmentation.spikes:
        assert f"<td>{spike.peak_W:.3f}</td><td>{spike.energy_above_level_J:.4f}</td>" in page
    view = built.traces[0]
    assert {p.phase for p in view.phases} == {"level"} and len(view.phases) >= 5


def test_report_command_on_a_log_that_is_no_robot_run(wbpower, real_n6705, tmp_path) -> None:
    """issue 28: on the N6705C export (an expected situation: not a robot log) `report`
    exits 0, says the reason once on stderr, and lists what it drew."""
    result = wbpower("report", real_n6705, "--supply-voltage", "12.6", "-o", tmp_path / "o")
    assert result.exit_code == 0, result.stderr
    reason = "no mode or speed in its metadata"
    assert result.stderr.count(reason) == 1
    assert "power_speed, figure5, figure7, heldout_error, findings" in result.stderr
    as_json = wbpower(
        "report", real_n6705, "--supply-voltage", "12.6", "-o", tmp_path / "p", "--json"
    )
    assert as_json.exit_code == 0
    import json

    document = json.loads(as_json.stdout)
    assert document["skipped"] == [] and document["n_runs"] == 1
    assert [Path(f).name for f in document["figures"]] == ["trace_n6705c_dlog1.png"]
    assert reason in document["not_fitted"][0]["reason"]


def test_report_command_on_too_few_runs_to_diagnose(wbpower, tmp_path: Path) -> None:
    """Two speeds, one run each, and the idle runs: enough to fit (Figures 5 and 7 are drawn
    from the fitted model), too few to diagnose (6 motion runs needed): the report says so
    in place of the diagnosis figures, on stderr too, and exits 0 (nothing was skipped)."""
    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("v0.30_d2_s1_r1.csv.gz", "v0.90_d2_s1_r1.csv.gz", "idle_r1.csv.gz"):
        shutil.copy(SAMPLE_LOGS / name, logs / name)
    result = wbpower("report", logs, "-o", tmp_path / "out", "--jobs", "1")
    assert result.exit_code == 0, result.stderr
    assert result.stdout.strip() == f"report: {tmp_path / 'out' / 'report.html'}"
    names = sorted(p.stem for p in (tmp_path / "out" / "figures").glob("*.png"))
    # the drive model from the step runs' phases: its terms and held-out power (two runs:
    # too few trips for held-out energies)
    assert names == [
        "drive_power",
        "drive_terms",
        "figure5",
        "figure7",
        "power_speed",
        "trace_idle_r1",
        "trace_v0.30_d2_s1_r1",
        "trace_v0.90_d2_s1_r1",
    ]
    assert "heldout_error, findings: not drawn: " in result.stderr
    assert "diagnose needs at least 6 motion runs" in result.stderr
    # two speeds fit a line but cannot check it: the report warns as fit does, on stderr
    # and in report.html (found in review: the report showed the line without a word)
    weak = "distinct speed level(s)"
    assert f"warning: the motion runs hold 2 {weak}" in result.stderr
    page = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert f"warning: the motion runs hold 2 {weak}" in page


def test_report_refuses_an_output_it_cannot_write_before_reading(wbpower, tmp_path: Path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    result = wbpower("report", tmp_path / "no-such-logs", "-o", blocker)
    assert result.exit_code == 2
    assert "is a file, not a folder" in result.stderr and "no logs" not in result.stderr


@pytest.mark.parametrize(
    ("args", "suffix"),
    [
        (("segment", SAMPLE_LOGS / "v0.90_d2_s1_r1.csv.gz"), ".png"),
        (("fit", "SUBSET", "--jobs", "1"), ".svg"),
        (("diagnose", "SUBSET", "--jobs", "1"), ".png"),
        (("energy", "--sweep", "speed"), ".png"),
        (("energy", "--speed", "0.5", "--dist", "4", "--steps", "4"), ".svg"),
        (("lifetime", "--sweep", "dist", "--rate", "54"), ".png"),
        (("lifetime", "--sweep", "rate"), ".png"),
    ],
)
def test_plot_draws_each_commands_figure(
    wbpower,
    subset_dir: Path,  # noqa: F811
    tmp_path: Path,
    args: tuple,
    suffix: str,
) -> None:
    target = tmp_path / f"figure{suffix}"
    args = tuple(subset_dir if a == "SUBSET" else a for a in args)
    result = wbpower(*args, "--plot", target)
    assert result.exit_code == 0, result.stderr
    data = target.read_bytes()
    assert data.startswith(b"\x89PNG") if suffix == ".png" else b"<svg" in data[:400]
    assert f"wrote {target}" in result.stderr


def test_plot_refuses_a_suffix_it_cannot_draw_before_any_work(wbpower, tmp_path: Path) -> None:
    result = wbpower("fit", tmp_path / "nothing-here", "--plot", tmp_path / "f.pdf")
    assert result.exit_code == 2
    assert ".png or .svg" in result.stderr and "no logs" not in result.stderr


@pytest.mark.skipif(
    shutil.which("chromium") is None,
    reason="chromium is not on PATH (Debian: apt-get install chromium); the report is "
    "checked in a real browser only where one is installed",
)
def test_report_loads_every_image_in_headless_chromium(written) -> None:
    """report.html opened from disk, offline, in headless Chromium: after the load event the
    page's own script counts the images that decoded (body data-images-loaded="N/M")."""
    tmp_path, _ = written
    embedded = len(IMG.findall((tmp_path / "report.html").read_text(encoding="utf-8")))
    with tempfile.TemporaryDirectory() as profile:
        done = subprocess.run(
            [
                "chromium",
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--no-first-run",
                f"--user-data-dir={profile}",
                "--virtual-time-budget=10000",
                "--dump-dom",
                (tmp_path / "report.html").resolve().as_uri(),
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
    match = re.search(r'data-images-loaded="(\d+)/(\d+)"', done.stdout)
    assert match, done.stderr[-2000:]
    loaded, total = map(int, match.groups())
    assert total == embedded > 0
    assert loaded == total


def test_fit_prints_the_measured_overhead_and_with_runs_each_runs_energy(
    wbpower,
    subset_dir: Path,  # noqa: F811
) -> None:
    plain = wbpower("fit", subset_dir, "--jobs", "1")
    assert plain.exit_code == 0, plain.stderr
    assert "Stop-and-go overhead" in plain.stdout and "v0.30_d10_s1_r1" not in plain.stdout
    with_runs = wbpower("fit", subset_dir, "--jobs", "1", "--runs")
    assert "Stop-and-go overhead" in with_runs.stdout
    for name in SUBSET:
        assert name.removesuffix(".csv.gz") in with_runs.stdout


def test_diagnose_names_what_it_was_given_when_too_few_runs(wbpower, tmp_path: Path) -> None:
    """The batch's error named a placeholder ('input: 2 usable motion run(s)...')."""
    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("v0.30_d2_s1_r1.csv.gz", "v0.90_d2_s1_r1.csv.gz"):
        shutil.copy(SAMPLE_LOGS / name, logs / name)
    result = wbpower("diagnose", logs)
    assert result.exit_code == 2
    assert result.stderr.startswith(f"wbpower: error: {logs}: 2 usable motion run(s)")
    assert "input:" not in result.stderr


def test_report_keep_doubtful_uses_the_doubted_runs_in_fit_and_diagnose(
    subset_dir: Path,  # noqa: F811 - the fixture
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`report --keep-doubtful`, as `fit` and `diagnose` have it (real REGBOT logs are
    doubted as a whole set): a run whose segmentation is in doubt is left out of the fit
    and the diagnosis by default, and used by both with it."""
    from dataclasses import replace

    from wifibot_power.pipeline import record

    doubtful = "v0.30_d10_s1_r1"
    real = record.segment_checked

    def doubting(run, segmenter=None):
        seg = real(run)
        return replace(seg, doubts=("a doubt",)) if run.meta.run_id == doubtful else seg

    monkeypatch.setattr(record, "segment_checked", doubting)
    left_out = build_report([subset_dir], jobs=1)
    kept = build_report([subset_dir], jobs=1, keep_doubtful=True)
    assert any(doubtful in s.file for s in left_out.skipped)
    assert not any(doubtful in s.file for s in kept.skipped)
    assert kept.diagnosis.n_runs == left_out.diagnosis.n_runs + 1
    assert len(kept.fit.runs.query("usable")) == len(left_out.fit.runs.query("usable")) + 1


def test_a_report_of_logs_none_of_which_can_be_read_says_so(tmp_path: Path) -> None:
    """Found in review (fifth session): with no log read, the report guessed that the runs
    lacked speed, distance and steps in their metadata; it says that no log could be read,
    and why (the reader's reason, naming the file)."""
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "bad.csv").write_text("this,is\nnot,a log\n")
    built = build_report(logs)
    assert built.fit_problem.startswith("no log could be read: ")
    assert "bad.csv" in built.fit_problem
    assert "metadata" not in built.fit_problem


def test_the_reports_fit_names_each_phases_log(report, subset_dir: Path) -> None:  # noqa: F811
    # report's workers made the phase rows without the log's file, which fit's phases table
    # has since run_ids may repeat across folders: the column came out empty
    from wifibot_power.phases import PHASE_COLUMNS

    phases = report.fit.phases
    assert list(phases.columns) == list(PHASE_COLUMNS)
    assert len(phases) and phases["file"].notna().all()
    assert {Path(f).parent for f in phases["file"]} == {subset_dir}


def test_trace_names_of_run_ids_that_file_names_would_merge_stay_apart() -> None:
    # issue 29: run_ids `a b` and `a_b` both gave figures/trace_a_b.png: one figure lost
    from wifibot_power.report import _unique_safe

    names = _unique_safe(["a b", "a_b", "v0.5_r1", "x/y"])
    assert len(set(names.values())) == 4
    assert names["v0.5_r1"] == "v0.5_r1" and names["x/y"] == "x_y"  # alone: as before
    assert names == _unique_safe(["x/y", "a_b", "v0.5_r1", "a b"])  # not by order


def test_report_never_deletes_files_it_did_not_write(wbpower, tmp_path: Path) -> None:
    """issue 29: `report -o DIR` replaced DIR/figures whole, deleting a user's files there;
    refused before any work, the user's file intact; a report's own figures are replaced."""
    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("v0.30_d2_s1_r1.csv.gz", "v0.90_d2_s1_r1.csv.gz", "idle_r1.csv.gz"):
        shutil.copy(SAMPLE_LOGS / name, logs / name)
    out = tmp_path / "out"
    assert wbpower("report", logs, "-o", out, "--jobs", "1").exit_code == 0
    again = wbpower("report", logs, "-o", out, "--jobs", "1")  # its own figures: replaced
    assert again.exit_code == 0, again.stderr
    mine = out / "figures" / "my_notes.txt"
    mine.write_text("the user's")
    refused = wbpower("report", logs, "-o", out, "--jobs", "1")
    assert refused.exit_code == 2
    assert "my_notes.txt" in refused.stderr and "another -o DIR" in refused.stderr
    assert mine.read_text() == "the user's"


# -- the page: the trace view's data, the runs table, the provenance (issue 28) -------------
def _page_data(folder: Path) -> dict:
    import json

    page = (folder / "report.html").read_text(encoding="utf-8")
    match = re.search(r'<script type="application/json" id="wb-data">(.*?)</script>', page, re.S)
    return json.loads(match.group(1))


def test_trace_view_data_gives_each_columns_exact_energy(written, subset_dir: Path) -> None:  # noqa: F811
    """The embedded energies, summed as the page sums them, are the samples' energy at
    every column edge (summed here from the log), within float32's rounding; the display
    envelope holds every sample (min <= each sample <= max in its column)."""
    import numpy as np

    from wifibot_power.io import read_log

    data = _page_data(written[0])
    assert len(data["runs"]) == 16
    run_data = next(r for r in data["runs"] if r["id"] == "v0.90_d10_s10_r2")
    run = read_log(subset_dir / "v0.90_d10_s10_r2.csv.gz")
    run = run[0] if isinstance(run, list) else run
    power_W, dt = np.asarray(run.power_W, np.float64), run.sample_period_s
    edges_s = np.frombuffer(base64.b64decode(run_data["t"]), "<f4").astype(np.float64)
    column_J = np.frombuffer(base64.b64decode(run_data["e"]), "<f4").astype(np.float64)
    cumulative_J = np.concatenate([[0.0], np.cumsum(column_J)])
    first = np.rint(edges_s / dt).astype(np.int64)  # each column's first sample
    assert first[0] == 0 and first[-1] == power_W.size and np.all(np.diff(first) > 0)
    by_samples_J = np.concatenate([[0.0], np.cumsum(power_W)])[first] * dt
    np.testing.assert_allclose(cumulative_J, by_samples_J, rtol=2e-7, atol=1e-9)
    q = run_data["p"]
    low = q["v0"] + np.frombuffer(base64.b64decode(q["lo"]), "<u2") * q["dv"]
    high = q["v0"] + np.frombuffer(base64.b64decode(q["hi"]), "<u2") * q["dv"]
    column = np.repeat(np.arange(first.size - 1), np.diff(first))
    assert np.all(low[column] <= power_W + 1e-9) and np.all(power_W <= high[column] + 1e-9)
    assert np.max(high - low) < np.ptp(power_W)  # and is not one wide band


def test_runs_table_lists_every_run_with_its_energy(written, subset_dir: Path) -> None:  # noqa: F811
    import numpy as np

    from wifibot_power.io import read_log

    page = (written[0] / "report.html").read_text(encoding="utf-8")
    table = page[page.index('<table id="wb-runs">') :]
    table = table[: table.index("</table>")]
    rows = re.findall(r"<tr>(.*?)</tr>", table[table.index("<tbody>") :], re.S)
    ids = [re.search(r'data-run="\d+">([^<]+)</a>', r).group(1) for r in rows]
    assert sorted(ids) == sorted(n.removesuffix(".csv.gz") for n in SUBSET)
    heads = re.findall(r"<th[^>]*>([^<]+)</th>", table)
    energy = heads.index("energy J")
    for row, run_id in zip(rows, ids, strict=True):
        value = float(re.findall(r'<td data-v="([^"]*)"', row)[energy])
        run = read_log(subset_dir / f"{run_id}.csv.gz")
        run = run[0] if isinstance(run, list) else run
        assert value == pytest.approx(np.sum(run.power_W, dtype=np.float64) * run.sample_period_s)


def test_provenance_names_version_command_date_and_every_input(subset_dir: Path) -> None:  # noqa: F811
    import hashlib

    from wifibot_power import __version__
    from wifibot_power.report import render_html

    built = build_report([subset_dir], jobs=1, command=["/x/bin/wbpower", "report", "a b"])
    page = render_html(built, [])
    section = page[page.index('id="provenance"') :]
    assert f"<td class=text>{__version__}</td>" in section
    assert "<code>wbpower report &#x27;a b&#x27;</code>" in section  # as a shell reads it
    assert re.search(r"<td class=text>20\d\d-\d\d-\d\d \d\d:\d\d:\d\d UTC</td>", section)
    for name in SUBSET:
        data = (subset_dir / name).read_bytes()
        assert f"{len(data):,}</td>" in section
        assert hashlib.sha256(data).hexdigest() in section
    assert built.provenance is not None and len(built.provenance.inputs) == len(SUBSET)
