"""A run_id names one run of a batch (log-format.md "Bad input"): logs/day1/run1.csv and
logs/day2/run1.csv are both analysed, under run_ids from their paths; two different logs
that say they have one run_id are a contradiction, and the later one is left out; copies of
one log stay what they were, one log analysed once with a warning. Before this, two logs
with one run_id were silently merged wherever run_id keyed a run (diagnose kept one trace
for both: the audit's cruise_ripple at 6.8% and unnamed instead of 17.2%)."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from wifibot_power.cache import ParseCache, ResultMemo
from wifibot_power.diagnose import diagnose_logs, diagnose_runs
from wifibot_power.errors import LogError
from wifibot_power.io import ReadOptions
from wifibot_power.io.batch import map_runs
from wifibot_power.io.discover import find_logs
from wifibot_power.run import Run
from wifibot_power.simulate import SimConfig, simulate_runs, write_simulation


def write_idle_log(path: Path, seed: int, run_id: str | None = None) -> Path:
    """An idle log of 200 samples of its own (`seed`), with `run_id` in its metadata if given."""
    path.parent.mkdir(parents=True, exist_ok=True)
    power_W = 23.0 + np.random.default_rng(seed).normal(0.0, 0.3, 200)
    head = ["# wbpower-log: 1", "# mode: idle", "# sample_period_s: 0.01"]
    if run_id is not None:
        head.insert(1, f"# run_id: {run_id}")
    path.write_text("\n".join([*head, "power_W", *(f"{p:.4f}" for p in power_W)]) + "\n")
    return path


def run_ids(paths: list[Path], jobs: int = 1) -> tuple[list[tuple[str, str]], list]:
    """(file, run_id) of each run `map_runs` keeps, and what it skipped."""
    results, skipped = map_runs(
        paths, ReadOptions(), lambda run: (Path(run.file).name, run.meta.run_id), jobs=jobs
    )
    return results, skipped


# --- (a) run_ids that come from the file name and collide: made from the paths ---------------


@pytest.mark.parametrize("jobs", [1, 2])
def test_logs_with_one_file_name_in_two_folders_are_both_analysed(tmp_path: Path, jobs: int):
    logs = tmp_path / "logs"
    write_idle_log(logs / "day1" / "run1.csv", seed=1)
    write_idle_log(logs / "day2" / "run1.csv", seed=2)
    write_idle_log(logs / "day2" / "run2.csv", seed=3)  # a name of its own: its stem
    results, skipped = run_ids([logs], jobs=jobs)
    assert skipped == []
    assert [run_id for _, run_id in results] == ["day1/run1", "day2/run1", "run2"]


def test_path_run_ids_are_decided_before_reading(tmp_path: Path):
    """In the batch's sources, whatever order the workers finish in (`--jobs`)."""
    logs = tmp_path / "logs"
    first = write_idle_log(logs / "day1" / "run1.csv", seed=1)
    second = write_idle_log(logs / "day2" / "run1.csv.gz", seed=2)
    sources, _ = find_logs([logs])
    assert [(s.path, s.default_run_id) for s in sources] == [
        (first, "day1/run1"),
        (second, "day2/run1"),
    ]
    # named one by one: the paths as given (without the log suffix), which tell them apart
    sources, _ = find_logs([first, second])
    assert [s.default_run_id for s in sources] == [
        first.with_name("run1").as_posix(),
        second.with_name("run1").as_posix(),
    ]


def test_a_path_run_id_never_replaces_an_explicit_one(tmp_path: Path):
    logs = tmp_path / "logs"
    write_idle_log(logs / "day1" / "run1.csv", seed=1, run_id="morning")
    write_idle_log(logs / "day2" / "run1.csv", seed=2)
    (logs / "day3").mkdir()
    write_idle_log(logs / "day3" / "run1.csv", seed=3)
    (logs / "runs.csv").write_text("file,run_id\nday3/run1.csv,evening\n")
    results, skipped = run_ids([logs])
    assert skipped == []
    assert [run_id for _, run_id in results] == ["morning", "day2/run1", "evening"]


def test_two_folders_given_with_one_layout_get_run_ids_from_the_paths_as_given(tmp_path):
    one = write_idle_log(tmp_path / "one" / "day1" / "run1.csv", seed=1)
    two = write_idle_log(tmp_path / "two" / "day1" / "run1.csv", seed=2)
    results, skipped = run_ids([tmp_path / "one", tmp_path / "two"])
    assert skipped == []
    assert [run_id for _, run_id in results] == [
        one.with_name("run1").as_posix(),
        two.with_name("run1").as_posix(),
    ]
    # the same file named twice is one log: its run_id stays its stem (and it is a duplicate)
    results, skipped = run_ids([one, one])
    assert [run_id for _, run_id in results] == ["run1"] and skipped == []


def _ripple_folder(root: Path, run_ids: tuple[str | None, str | None]) -> Path:
    """A simulated session with a cruise ripple (no runs.csv: run_ids from the logs), two of
    whose motion runs are moved to a/x.csv and b/x.csv with `run_ids` in their metadata
    (None: no run_id line, so the file name `x` is the default of both)."""
    from test_diagnose import GRID, _size  # the grid and sizes every diagnose test uses

    seed = 31
    config = SimConfig(**GRID, effects={"cruise_ripple": _size("cruise_ripple", seed)}, seed=seed)
    logs = root / "logs"
    write_simulation(config, logs)
    (logs / "runs.csv").unlink()
    (logs / "truth.json").unlink()
    for name, folder, run_id in zip(
        ("v0.40_d5_s1_r1", "v0.90_d5_s1_r2"), ("a", "b"), run_ids, strict=True
    ):
        lines = (logs / f"{name}.csv").read_text().splitlines()
        lines = [ln for ln in lines if not ln.startswith("# run_id:")]
        if run_id is not None:
            lines.insert(1, f"# run_id: {run_id}")
        (logs / folder).mkdir()
        (logs / folder / "x.csv").write_text("\n".join(lines) + "\n")
        (logs / f"{name}.csv").unlink()
    return logs


def test_diagnose_of_two_logs_named_alike_is_that_of_the_same_logs_with_run_ids(tmp_path):
    defaults = diagnose_logs([_ripple_folder(tmp_path / "defaults", (None, None))], jobs=2)
    explicit = diagnose_logs([_ripple_folder(tmp_path / "explicit", ("a/x", "b/x"))], jobs=2)
    assert "cruise_ripple" in [f.cause for f in explicit.findings]
    assert defaults.skipped == explicit.skipped == ()
    assert json.dumps(defaults.summary(), sort_keys=True) == json.dumps(
        explicit.summary(), sort_keys=True
    )
    assert defaults.runs["run_id"].tolist() == explicit.runs["run_id"].tolist()
    assert {"a/x", "b/x"} <= set(defaults.runs["run_id"])


# --- (b) an explicit run_id another log has: contradictory input, the later log left out ------


@pytest.mark.parametrize("where", ["metadata", "runs.csv"])
def test_two_logs_saying_they_are_one_run_leave_the_later_out(tmp_path: Path, wbpower, where):
    logs = tmp_path / "logs"
    in_file = "same" if where == "metadata" else None
    first = write_idle_log(logs / "a" / "r1.csv", seed=1, run_id=in_file)
    later = write_idle_log(logs / "b" / "r2.csv", seed=2, run_id=in_file)
    write_idle_log(logs / "c" / "r3.csv", seed=3)
    if where == "runs.csv":
        (logs / "runs.csv").write_text("file,run_id\na/r1.csv,same\nb/r2.csv,same\n")
    results, skipped = run_ids([logs])
    assert results == [("r1.csv", "same"), ("r3.csv", "r3")]
    assert [s.file for s in skipped] == [str(later)]
    reason = skipped[0].reason
    assert reason.startswith(f"{later}: ") and str(first) in reason and "'same'" in reason
    assert "give each run its own run_id in its metadata or runs.csv" in reason
    cli = wbpower("inspect", "--json", logs)
    assert cli.exit_code == 1, cli.stderr
    assert [row["run_id"] for row in json.loads(cli.stdout)["logs"]] == ["same", "r3"]
    (line,) = [ln for ln in cli.stderr.splitlines() if "skipped" in ln]
    assert str(later) in line and str(first) in line


def test_an_explicit_run_id_equal_to_a_path_run_id_is_a_contradiction_too(tmp_path: Path):
    logs = tmp_path / "logs"
    write_idle_log(logs / "day1" / "run1.csv", seed=1)
    write_idle_log(logs / "day2" / "run1.csv", seed=2)
    later = write_idle_log(logs / "later.csv", seed=3, run_id="day1/run1")
    results, skipped = run_ids([logs])
    assert [run_id for _, run_id in results] == ["day1/run1", "day2/run1"]
    assert [s.file for s in skipped] == [str(later)]


# --- copies of one log: analysed once with a warning, before any run_id rule ----------------


@pytest.mark.parametrize("run_id", [None, "same"])
def test_copies_stay_duplicates_and_a_different_log_is_judged_apart(tmp_path: Path, run_id):
    """a/x.csv and its copy b/x.csv are one log (warning, exit 0 for it); c/x.csv is another
    log: analysed under its own path run_id when run_ids are file names, left out when it
    claims the run_id the first one has."""
    logs = tmp_path / "logs"
    first = write_idle_log(logs / "a" / "x.csv", seed=1, run_id=run_id)
    (logs / "b").mkdir()
    copy = shutil.copy(first, logs / "b" / "x.csv")
    other = write_idle_log(logs / "c" / "x.csv", seed=2, run_id=run_id)
    heard: list[tuple[str, str]] = []
    results, skipped = map_runs(
        [logs],
        ReadOptions(),
        lambda run: run.meta.run_id,
        on_problems=lambda f, ps: heard.extend((f, p.kind) for p in ps),
    )
    assert heard == [(str(copy), "duplicate")]
    if run_id is None:
        assert results == ["a/x", "c/x"] and skipped == []
    else:
        assert results == ["same"]
        assert [s.file for s in skipped] == [str(other)] and str(first) in skipped[0].reason


def test_a_warm_cache_keeps_the_run_ids_and_the_contradictions(tmp_path: Path):
    """Results kept in the cache carry their run_id: a second batch decides as the first."""
    logs = tmp_path / "logs"
    write_idle_log(logs / "day1" / "run1.csv", seed=1)
    write_idle_log(logs / "day2" / "run1.csv", seed=2)
    write_idle_log(logs / "day3" / "a.csv", seed=3, run_id="day1/run1")
    cache = ParseCache(tmp_path / "cache")
    memo = ResultMemo(key="test run_id", to_json=lambda r: r, from_json=lambda r: r)
    calls: list[str] = []

    def work(run: Run) -> str:
        calls.append(run.file)
        return run.meta.run_id

    cold = map_runs([logs], ReadOptions(), work, cache=cache, memo=memo)
    warm = map_runs([logs], ReadOptions(), work, cache=cache, memo=memo)
    assert len(calls) == 3  # the second batch took every result from the cache
    assert cold == warm
    assert warm[0] == ["day1/run1", "day2/run1"]
    assert [s.file for s in warm[1]] == [str(logs / "day3" / "a.csv")]


def test_runs_given_in_memory_with_one_run_id_are_refused_by_diagnose():
    """`diagnose_runs` takes runs as they are: two with one run_id would share a trace."""
    config = SimConfig(
        speeds_mps=(0.3, 0.6, 0.9),
        trips=((2.0, 1),),
        repeats=2,
        mode_repeats=1,
        mode_duration_s=2.0,
        sample_period_s=0.01,
        seed=5,
    )
    runs = [sim.run for sim in simulate_runs(config)]
    runs[1] = dataclasses.replace(
        runs[1], meta=dataclasses.replace(runs[1].meta, run_id=runs[0].meta.run_id)
    )
    with pytest.raises(LogError, match=f"two runs have the run_id '{runs[0].meta.run_id}'"):
        diagnose_runs(runs)
