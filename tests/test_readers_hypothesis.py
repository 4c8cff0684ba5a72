"""Property-based tests of the readers (hypothesis, bounded so the file runs in seconds).

- any bytes: a `Run` or a `LogError`, never another exception;
- a valid log written by `format_log` reads back exactly, within the written rounding;
- a log cut anywhere reads as its complete rows, or is a clear `LogError`.
"""

from __future__ import annotations

import os
import string
import tempfile
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pyarrow as pa
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from wifibot_power.errors import LogError
from wifibot_power.io import read_log
from wifibot_power.io.metadata import KNOWN_KEYS
from wifibot_power.io.validate import UNJUDGED_POWER_W
from wifibot_power.io.writer import format_log
from wifibot_power.run import MODES, Run, RunMeta

#: bounded: the whole file stays well under 60 s on one core (about 10 s at 150 examples);
#: WBPOWER_HYPOTHESIS_EXAMPLES=5000 hunts deeper, off CI
FAST = settings(
    max_examples=int(os.environ.get("WBPOWER_HYPOTHESIS_EXAMPLES", "150")),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)


def _read(data: bytes) -> Run | LogError:
    try:
        return read_log("fuzz.csv", data=data)
    except LogError as exc:
        assert "\n" not in exc.one_line() and "fuzz.csv" in exc.one_line()
        return exc


def _sane(run: Run, power_only: bool = False) -> None:
    """What a successful read promises: finite power, strictly increasing time, and, for a
    log of a power column alone, a peak over the small robots' size (`UNJUDGED_POWER_W`; no
    fixed ceiling since issue 26) read only with the problem saying it could not be judged."""
    assert run.samples >= 1
    assert np.isfinite(run.power_W).all() and np.isfinite(run.time_s).all()
    assert (run.power_W >= -1.0).all()
    if power_only and run.power_W.max() > UNJUDGED_POWER_W:
        assert "unjudged_power" in {p.kind for p in run.problems}, run.problems
    assert (np.diff(run.time_s) > 0).all()
    assert run.sample_period_s > 0


@FAST
@given(st.binary(max_size=3000))
def test_arbitrary_bytes_give_a_run_or_a_log_error(data):
    result = _read(data)
    if isinstance(result, Run):
        _sane(result)


CSV_ALPHABET = '0123456789.,;-+eE\t\r\n#: "naifNAIF' + "power_Wtime_svoltage_Vcurrent_A"


@FAST
@given(
    st.sampled_from(["", "# mode: idle\n", 'N6705C exported datalog\n"Sample interval: 0.001"\n']),
    st.sampled_from(
        [
            "time_s,power_W\n",
            "power_W\n",
            "time_s;power_W\n",
            'Sample,"Power avg 1"\n',
            "voltage_V,current_A\n",
        ]
    ),
    st.text(alphabet=CSV_ALPHABET, max_size=400),
)
@example("", "power_W\n", "1001\r")  # over the small robots' size: read, said unjudged
def test_csv_like_text_gives_a_run_or_a_log_error(preamble, header, body):
    # text close to a log reaches the parsing and validation paths that random bytes miss
    result = _read((preamble + header + body).encode())
    if isinstance(result, Run):
        _sane(result, power_only="voltage_V" not in header)


PERIODS_S = [0.1024e-3, 1e-3, 1.00352e-3, 0.01]
SAFE_TEXT = st.text(alphabet=string.ascii_letters + string.digits + "_.-", min_size=1, max_size=20)
EXTRA_KEYS = st.text(alphabet=string.ascii_lowercase + "_", min_size=1, max_size=10).filter(
    lambda k: k not in KNOWN_KEYS and k != "wbpower"
)


@st.composite
def metas(draw) -> RunMeta:
    mode = draw(st.sampled_from(MODES))
    motion = mode == "motion"
    # values with few digits: the writer prints metadata with %g (6 significant digits)
    speed = draw(st.integers(1, 2000)) / 1000 if motion else None
    return RunMeta(
        run_id=draw(SAFE_TEXT),
        mode=mode,
        speed_mps=speed,
        distance_m=draw(st.integers(1, 500)) / 10 if motion else None,
        steps=draw(st.integers(1, 20)) if motion else 1,
        payload_kg=draw(st.integers(0, 50)) / 10,
        started_at=draw(
            st.none()
            | st.datetimes(
                min_value=datetime(2000, 1, 1),
                max_value=datetime(2099, 1, 1),
                timezones=st.just(UTC),
            )
        ),
        sample_period_s=draw(st.sampled_from(PERIODS_S)),
        extra=draw(st.dictionaries(EXTRA_KEYS, SAFE_TEXT, max_size=3)),
    )


# power in 0.1 mW steps from 0 to 200 W, all different: no flat top that would read as clipping
POWERS_W = hnp.arrays(
    np.int64, st.integers(1, 300), elements=st.integers(0, 2_000_000), unique=True
).map(lambda a: a / 1e4)


@FAST
@given(metas(), POWERS_W, st.booleans(), st.booleans())
def test_valid_log_round_trips_within_the_written_rounding(meta, power_W, time_column, with_vi):
    voltage_V = np.full(power_W.size, 12.6) if with_vi else None
    data = format_log(meta, power_W, voltage_V=voltage_V, time_column=time_column)
    run = read_log("rt.csv", data=data)
    assert run.power_W.tolist() == np.round(power_W, 4).tolist()  # exact: 4 decimals written
    expected_time_s = np.round(np.arange(power_W.size) * meta.sample_period_s, 10)
    if not time_column:
        expected_time_s = np.arange(power_W.size) * meta.sample_period_s
    assert run.time_s.tolist() == expected_time_s.tolist()
    got = run.meta
    if time_column and power_W.size == 1:
        # one time stamp holds no spacing (and the writer then writes no sample_period_s):
        # the paper's analyser period is assumed, as documented
        assert got.sample_period_s == 0.1024e-3
    else:
        assert got.sample_period_s == meta.sample_period_s
    assert (got.run_id, got.mode, got.speed_mps, got.distance_m, got.steps, got.payload_kg) == (
        meta.run_id,
        meta.mode,
        meta.speed_mps,
        meta.distance_m,
        meta.steps,
        meta.payload_kg,
    )
    assert got.started_at == meta.started_at
    assert {k: v for k, v in got.extra.items() if k != "wbpower-log"} == meta.extra
    # the assumed period is said (issue 26), and only where it was assumed
    assumed = time_column and power_W.size == 1
    assert [p.kind for p in run.problems] == (["assumed_period"] if assumed else [])


@FAST
@given(metas(), POWERS_W, st.booleans(), st.data())
def test_cut_log_reads_its_complete_rows_or_errors(meta, power_W, time_column, data):
    full = format_log(meta, power_W, time_column=time_column)
    whole = read_log("full.csv", data=full).power_W
    cut_at = data.draw(st.integers(0, len(full)), label="cut_at")
    cut = full[:cut_at]
    result = _read(cut)
    lines = full.split(b"\n")
    header = next(k for k, line in enumerate(lines) if not line.startswith(b"#"))
    header_end = sum(len(line) + 1 for line in lines[: header + 1])
    if cut_at > header_end and not cut.endswith(b"\n"):
        # a data line without its line end may hold a cut number: always an error
        assert isinstance(result, LogError)
        assert "the last line has no line end" in str(result)
        return
    if isinstance(result, LogError):
        return  # e.g. cut inside the metadata or the header
    # cut at a line end: every complete data line is read, and nothing else
    n = result.samples
    assert n == cut[header_end:].count(b"\n")
    assert result.power_W.tolist() == whole[:n].tolist()
    # one time stamp left holds no spacing: the period is assumed and said (as in the round
    # trip above), whatever the metadata's sample_period_s (the stamps are the clock)
    assumed = time_column and n == 1
    assert [p.kind for p in result.problems] == (["assumed_period"] if assumed else [])


@FAST
@given(POWERS_W, st.data())
def test_one_corrupted_byte_gives_a_run_or_a_log_error(power_W, data):
    full = bytearray(format_log(RunMeta(run_id="c", mode="idle"), power_W))
    position = data.draw(st.integers(0, len(full) - 1), label="position")
    full[position] = data.draw(st.integers(0, 255), label="byte")
    result = _read(bytes(full))
    if isinstance(result, Run):
        _sane(result, power_only=True)


@FAST
@given(st.sampled_from([".csv.gz", ".csv.zst"]), st.binary(max_size=500), st.integers(0, 400))
def test_broken_compressed_files_give_a_run_or_a_log_error(suffix, noise, cut_at):
    # a compressed valid log cut short, or followed by noise: decompression errors are LogErrors
    full = format_log(RunMeta(run_id="z", mode="idle"), np.arange(50) / 10 + 20.0)
    sink = pa.BufferOutputStream()
    with pa.CompressedOutputStream(sink, "gzip" if suffix == ".csv.gz" else "zstd") as out:
        out.write(full)
    packed = sink.getvalue().to_pybytes()
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"log{suffix}"
        path.write_bytes(packed[:cut_at] + noise)
        try:
            run = read_log(path)
        except LogError as exc:
            assert str(path) in exc.one_line() and "\n" not in exc.one_line()
        else:
            _sane(run)


def test_a_log_cut_to_its_first_row_says_its_period_is_assumed():
    """Found by hypothesis (fourteenth session), pinned here: a log with a time column cut
    after its first data row reads that row, and its one stamp holds no spacing, so the
    period is assumed and said, even where the metadata gave one (the stamps are the clock);
    the fuzz test expected no problem and failed on ~1 run in a few, off CI."""
    full = format_log(
        RunMeta(run_id="a", mode="idle", sample_period_s=0.01),
        np.array([20.0, 21.0, 22.0]),
        time_column=True,
    )
    first_row_end = full.index(b"\n", full.index(b"time_s")) + 1
    first_row_end = full.index(b"\n", first_row_end) + 1
    run = read_log("cut.csv", data=full[:first_row_end])
    assert run.samples == 1
    assert [p.kind for p in run.problems] == ["assumed_period"]
