"""The parse allocates through jemalloc where pyarrow has it (`transport._arrow_pool`): with
mimalloc, pyarrow's default, one process over the bench's 89 logs kept ~60 MB more than over
2 of them. A user's ARROW_DEFAULT_MEMORY_POOL still chooses."""

from __future__ import annotations

import gzip
import os
import subprocess
import sys

import numpy as np
import pyarrow as pa
import pytest

from wifibot_power.io import read_log, transport

#: the counting proxy pool, kept for the life of the process
_COUNTED: dict[str, pa.MemoryPool] = {}


def _has_jemalloc() -> bool:
    try:
        pa.jemalloc_memory_pool()
    except NotImplementedError:
        return False
    return True


@pytest.mark.skipif(not _has_jemalloc(), reason="this pyarrow has no jemalloc")
@pytest.mark.parametrize("suffix", [".csv", ".csv.gz"])  # read whole / in pieces
def test_the_parse_allocates_through_jemalloc(tmp_path, monkeypatch, suffix):
    assert transport._POOL.backend_name == "jemalloc"
    # a proxy of it, whose statistics count what went through it; one for the whole process,
    # never freed (pyarrow may still hold buffers it gave after the test: a proxy freed
    # under them crashed the worker)
    counted = _COUNTED.setdefault("pool", pa.proxy_memory_pool(transport._POOL))
    monkeypatch.setattr(transport, "_POOL", counted)
    before = counted.total_bytes_allocated()
    n = 200_000
    lines = "\n".join(f"{k * 0.001:.3f},{23.0 + (k % 7) * 0.1:.1f}" for k in range(n))
    text = ("# mode: idle\ntime_s,power_W\n" + lines + "\n").encode()
    log = tmp_path / f"idle{suffix}"
    log.write_bytes(gzip.compress(text) if suffix.endswith(".gz") else text)
    run = read_log(log)
    assert run.power_W.size == n
    np.testing.assert_allclose(run.power_W[:7], 23.0 + np.arange(7) * 0.1)
    # the parse's buffers (2 columns of 200 k float64 at least) went through the pool
    assert counted.total_bytes_allocated() - before >= 2 * 8 * n


def test_a_pool_chosen_in_the_environment_is_kept():
    env = {**os.environ, "ARROW_DEFAULT_MEMORY_POOL": "system"}
    code = "from wifibot_power.io import transport; print(transport._POOL.backend_name)"
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "system"
