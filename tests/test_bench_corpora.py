"""The bench's corpus layouts (benchmarks/corpora.py) are what they claim: each reads back, through
wbpower's reader, as the format it names and with the simulated power, and the N6705 layout
has the real export's structure line for line. (The bench's figures mean nothing otherwise:
a layout the reader misreads or refuses would be timed on the wrong path.)"""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest
from scripts import load_script

from wifibot_power.io.reader import read_log
from wifibot_power.io.writer import write_log
from wifibot_power.simulate import SimConfig, iter_simulation, realism

ROOT = Path(__file__).resolve().parents[1]


corpora = load_script("corpora", ROOT / "benchmarks" / "corpora.py")


@pytest.fixture(scope="module")
def sim():
    """One short motion run (2 m at 0.5 m/s, ~80 000 samples at 0.1024 ms)."""
    config = SimConfig(
        speeds_mps=(0.5,), trips=((2.0, 1),), repeats=1, modes=(), seed=7, **realism("lab")
    )
    return next(iter(iter_simulation(config)))


#: layout -> (format the reader must detect, power read as voltage x current?)
EXPECTED = {
    "time_power": ("wbpower-csv", False),
    "time_voltage_current": ("wbpower-csv", True),
    "n6705": ("n6705", True),
    "full_gz": ("wbpower-csv", False),
    "power": ("wbpower-csv", False),
}


#: layout -> how its first line after the '#' metadata starts (the columns it was meant to have)
FIRST_LINE = {
    "time_power": b"time_s,power_W",
    "time_voltage_current": b"time_s,voltage_V,current_A",
    "n6705": b"N6705",
    "full_gz": b"time_s,voltage_V,current_A,power_W",
    "power": b"power_W",
}


@pytest.mark.parametrize("layout", sorted(corpora.LAYOUTS))
def test_each_layout_reads_back_as_its_format_with_the_simulated_power(
    layout: str, sim, tmp_path: Path
) -> None:
    fmt, product = EXPECTED[layout]
    # what rounding the written values allows: power has 4 decimals (<= 5e-5 W off); volts
    # with 4 and amps with 5 decimals make V x I off by up to max|I| x 5e-5 + max|V| x 5e-6
    current_A = sim.run.power_W / sim.voltage_V
    tolerance_W = 5e-5 + 1e-12
    if product:
        tolerance_W = np.max(np.abs(current_A)) * 5e-5 + np.max(sim.voltage_V) * 5e-6 + 1e-8
    meta = sim.run.meta
    suffix, data = corpora.LAYOUTS[layout](meta, sim.run.power_W, sim.voltage_V)
    path = tmp_path / f"{meta.run_id}{suffix}"
    write_log(path, data)  # as the corpus is written (`write_simulation`): gzip by the name
    run = read_log(path)
    assert run.format == fmt
    on_disk = path.read_bytes()
    assert on_disk.startswith(b"\x1f\x8b") == (layout == "full_gz")  # gzip's magic bytes
    assert (gzip.decompress(on_disk) if layout == "full_gz" else on_disk) == data
    first = next(line for line in data.split(b"\n") if not line.startswith(b"#"))
    assert first.startswith(FIRST_LINE[layout])  # e.g. no time column in `power`
    assert run.samples == sim.run.power_W.size
    assert run.sample_period_s == pytest.approx(meta.sample_period_s, rel=1e-9)
    assert np.max(np.abs(run.power_W - sim.run.power_W)) <= tolerance_W
    if fmt == "wbpower-csv":  # the canonical logs carry their metadata; the N6705 has none
        assert (run.meta.speed_mps, run.meta.distance_m) == (0.5, 2.0)


def test_n6705_layout_has_the_real_exports_structure(sim, real_n6705: Path) -> None:
    """Same preamble line for line (title, blank, three quoted lines, blank, quoted header
    names), same line ends; only the values and the output numbers differ."""
    _, data = corpora.n6705(sim.run.meta, sim.run.power_W, sim.voltage_V)
    ours = data.decode().split("\n")[:8]
    real = real_n6705.read_bytes().decode().split("\n")[:8]
    assert b"\r" not in data and b"\r" not in real_n6705.read_bytes()

    def shape(line: str) -> str:
        if not line:
            return "blank"
        if line.startswith('"'):
            return "quoted:" + line.split(":", 1)[0]
        if line.startswith("Sample,"):
            return "header:" + ",".join(
                c[:1] + c[1:].rstrip(' 0123456789"') for c in line.split(",")
            )
        return "first" if line.startswith("N6705") else "data:" + str(line.count(","))

    assert [shape(x) for x in ours] == [shape(x) for x in real]


def test_quick_subset_keeps_the_first_repeat_and_its_manifest_rows(tmp_path: Path) -> None:
    folder = tmp_path / "full"
    folder.mkdir()
    names = ["v0.10_d2_s1_r1.csv", "v0.10_d2_s1_r2.csv", "idle_r1.csv", "idle_r2.csv"]
    for name in names:
        (folder / name).write_text("x\n")
    (folder / "runs.csv").write_text("file,run_id\n" + "".join(f"{n},{n[:-4]}\n" for n in names))
    sub = corpora.quick_subset(folder, tmp_path / "quick")
    assert sorted(p.name for p in corpora.log_files(sub)) == ["idle_r1.csv", "v0.10_d2_s1_r1.csv"]
    rows = (sub / "runs.csv").read_text().splitlines()
    assert rows == ["file,run_id", "v0.10_d2_s1_r1.csv,v0.10_d2_s1_r1", "idle_r1.csv,idle_r1"]


def test_a_corpus_is_written_through_the_simulators_writer_in_its_layout(tmp_path: Path) -> None:
    """`write_simulation(render=...)` (benchmarks/corpora.py's corpora): each run in the
    layout's format under the layout's suffix, the manifest naming those files, and the
    writer named in truth.json."""
    from wifibot_power.simulate import load_truth, write_simulation

    config = SimConfig(speeds_mps=(0.5,), trips=((2.0, 1),), repeats=1, modes=(), seed=7)
    written = write_simulation(
        config, tmp_path, render=corpora.LAYOUTS["full_gz"], generator="a corpus"
    )
    (log,) = tmp_path.glob("*.csv.gz")
    assert gzip.decompress(log.read_bytes()).startswith(b"#")  # gzipped once, by the name
    assert read_log(log).format == "wbpower-csv"
    assert log.name in (tmp_path / "runs.csv").read_text()
    truth = load_truth(tmp_path / "truth.json")
    assert truth["generator"] == "a corpus" and written["runs"] == 1


def test_the_drive_shape_is_free_driving_written_by_simulate_and_read_with_its_columns(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The `drive` corpus (issue 25) is what `wbpower simulate --drive free --realism field`
    writes: field-realism logs read back with a speed and a rate of turn at 20 Hz, two surfaces,
    and its parameters stamped (a small one here: 2 runs a surface of 60 s)."""
    small = corpora.Shape("drive_free", 0.05, 2, 0, 1406, "free driving", duration_s=60.0)
    monkeypatch.setitem(corpora.SHAPES, "drive", small)
    folder = corpora.build("drive", tmp_path)
    logs = corpora.log_files(folder)
    assert [p.name for p in logs] == [
        "free_001_asphalt.csv", "free_002_grass.csv", "free_003_asphalt.csv", "free_004_grass.csv"
    ]  # fmt: skip
    run = read_log(logs[1])
    assert run.speed_mps is not None and run.yaw_rate_radps is not None
    assert run.meta.extra["surface"] == "grass"
    assert run.sample_period_s == pytest.approx(0.05)
    assert corpora.is_built("drive", tmp_path)
    sub = corpora.quick_subset(folder, tmp_path / "quick")  # no `_r1` names: the first eighth
    assert [p.name for p in corpora.log_files(sub)] == ["free_001_asphalt.csv"]


def test_the_grid_shapes_parameters_did_not_change_with_the_drive_shape() -> None:
    """A grid corpus built before the drive shape existed is not written again: its
    parameters (what `.corpus-params.json` holds) have no `duration_s`."""
    for name, shape in corpora.SHAPES.items():
        params = corpora._params(shape)["shape"]
        assert ("duration_s" in params) == shape.free_driving, name
