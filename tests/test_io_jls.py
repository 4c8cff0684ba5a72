"""Joulescope recordings (log-format.md section 3), written here by pyjls's own writer."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pyjls = pytest.importorskip("pyjls", reason="the 'jls' extra (pip install 'wbpower[jls]')")

import jlswriter  # noqa: E402

from wifibot_power.errors import LogError  # noqa: E402
from wifibot_power.io import ReadOptions, find_logs, read_log  # noqa: E402
from wifibot_power.io.formats import jls  # noqa: E402
from wifibot_power.segment import segment_run  # noqa: E402

RATE_HZ = jlswriter.RATE_HZ  # blocks of 10 samples: 10 kHz


def levels(n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Current [A] and voltage [V] (float32, as the instrument writes them): 0.2 A idle,
    0.9 A from 30% to 70% of the recording, with noise."""
    rng = np.random.default_rng(seed)
    current = np.full(n, 0.2)
    current[int(0.3 * n) : int(0.7 * n)] = 0.9
    current += rng.normal(0, 0.01, n)
    voltage = 5.0 - 0.1 * current + rng.normal(0, 0.002, n)
    return current.astype(np.float32), voltage.astype(np.float32)


#: written by pyjls in a child process, retried if it hangs (tests/jlswriter.py: a deadlock)
write_jls = jlswriter.write


N = 200_007  # 2 s, and 7 samples that fill no block of 10


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> tuple[Path, np.ndarray, np.ndarray]:
    current, voltage = levels(N)
    path = write_jls(tmp_path_factory.mktemp("jls") / "bench.jls", current, voltage)
    return path, current, voltage


def test_energy_is_the_full_rate_sum(recording):
    path, current, voltage = recording
    run = read_log(path)
    assert run.format == "jls"
    assert jls.block_of(RATE_HZ, N) == 10
    assert run.samples == N // 10 and run.sample_period_s == pytest.approx(1e-4)
    # the instrument's power signal (float32 current x voltage), summed at full rate
    power = (current * voltage).astype(np.float64)
    full_J = float(np.sum(power[: N // 10 * 10])) / RATE_HZ
    assert run.energy_J == pytest.approx(full_J, rel=1e-12)
    # the 7 samples that fill no block are reported, with their energy
    (tail,) = [p for p in run.problems if p.kind == "tail"]
    assert "last 7 sample(s)" in tail.message
    assert f"{float(np.sum(power[-7:])) / RATE_HZ:.4g} J" in tail.message


def test_chunks_do_not_change_anything(recording, monkeypatch):
    """Memory flat in the length: read in chunks; a chunk size that is no multiple of
    anything in the file gives the same samples as one chunk."""
    path, _, _ = recording
    whole = read_log(path)
    monkeypatch.setattr(jls, "CHUNK_SAMPLES", 1237)
    chunked = read_log(path)
    np.testing.assert_array_equal(chunked.power_W, whole.power_W)


def test_current_times_voltage_without_a_power_signal(tmp_path, recording):
    _, current, voltage = recording
    path = write_jls(tmp_path / "iv.jls", current, voltage, power=False)
    run = read_log(path)
    product = current.astype(np.float64) * voltage.astype(np.float64)
    expected = product[: N // 10 * 10].reshape(-1, 10).mean(axis=1)
    np.testing.assert_allclose(run.power_W, expected, rtol=1e-12)
    # a current alone needs a voltage
    only = write_jls(tmp_path / "i.jls", current, voltage, power=False, names=("current", "x", ""))
    with pytest.raises(LogError, match="no voltage signal.*--supply-voltage"):
        read_log(only, ReadOptions(current_column="current"))
    supplied = read_log(only, ReadOptions(current_column="current", supply_voltage_V=5.0))
    assert supplied.mean_power_W == pytest.approx(5.0 * float(np.mean(current[: N // 10 * 10])))


def test_levels_are_segmented_where_they_change(recording):
    path, _, _ = recording
    run = read_log(path)
    phases = segment_run(run).phases
    edges = [p.t_start_s for p in phases[1:]]
    assert len(phases) == 3
    assert edges == pytest.approx([0.3 * N / RATE_HZ, 0.7 * N / RATE_HZ], abs=2e-3)


def test_dropped_samples(tmp_path):
    current, voltage = levels(N)
    short = write_jls(tmp_path / "short.jls", current, voltage, skip=(50_003, 1000))  # 10 ms
    run = read_log(short)
    (gap,) = [p for p in run.problems if p.kind == "gap"]
    assert "1 gap(s)" in gap.message and "0.01 s" in gap.message
    assert gap.t_start_s == pytest.approx(50_003 / RATE_HZ)
    # each block's mean is over the samples it has: no block reads the gap as 0 W
    assert run.power_W.min() > 0.9
    long = write_jls(tmp_path / "long.jls", current, voltage, skip=(50_003, 10_000))  # 100 ms
    with pytest.raises(LogError, match="gap.*longest 0.1 s"):
        read_log(long)


def test_gap_across_chunks(tmp_path, monkeypatch):
    current, voltage = levels(N)
    path = write_jls(tmp_path / "gap.jls", current, voltage, skip=(1200, 2000))
    monkeypatch.setattr(jls, "CHUNK_SAMPLES", 1000)  # the gap spans three chunks
    (gap,) = [p for p in read_log(path).problems if p.kind == "gap"]
    assert gap.t_start_s == pytest.approx(1200 / RATE_HZ)
    assert gap.duration_s == pytest.approx(2000 / RATE_HZ)


def test_inspect_and_discovery(recording, wbpower):
    path, _, _ = recording
    (source,), _ = find_logs([path.parent])
    assert source.path == path
    result = wbpower("inspect", path, "--json")
    assert result.exit_code == 0, result.stderr
    (row,) = json.loads(result.stdout)["logs"]
    assert row["format"] == "jls" and row["meta"]["instrument"] == "Jetperch JS220 000415"


def test_missing_library_names_the_extra(recording, monkeypatch):
    import importlib

    real = importlib.import_module

    def without_pyjls(name, *args):
        if name == "pyjls":
            raise ImportError("No module named 'pyjls'")
        return real(name, *args)

    monkeypatch.setattr(importlib, "import_module", without_pyjls)
    with pytest.raises(LogError) as caught:
        read_log(recording[0])
    assert "pip install 'wbpower[jls]'" in caught.value.one_line()


def test_the_writers_hang_is_retried_and_never_hangs_the_run(tmp_path, monkeypatch):
    """tests/jlswriter.py: a child that hangs (pyjls's writer deadlock) is killed by its
    timeout and the write tried again; after `ATTEMPTS` hangs it fails, it does not wait."""
    import subprocess

    calls = []

    def hangs_then_writes(command, check, timeout):
        calls.append(timeout)
        if len(calls) == 1:
            raise subprocess.TimeoutExpired(command, timeout)
        return real_run(command, check=check, timeout=timeout)

    real_run = subprocess.run
    monkeypatch.setattr(jlswriter.subprocess, "run", hangs_then_writes)
    current, voltage = levels(2_000)
    path = write_jls(tmp_path / "retried.jls", current, voltage)
    assert len(calls) == 2 and calls[0] == jlswriter.CHILD_TIMEOUT_S
    assert read_log(path).samples == 2_000 // 10

    def always_hangs(command, check, timeout):
        raise subprocess.TimeoutExpired(command, timeout)

    monkeypatch.setattr(jlswriter.subprocess, "run", always_hangs)
    with pytest.raises(RuntimeError, match="hung 5 times"):
        write_jls(tmp_path / "never.jls", current, voltage)
