"""A log that says its power twice (a power column and voltage x current) must agree with
itself (issue 29): the power column is not trusted when its own voltage and current say
otherwise. Tolerance: `validate.POWER_TWICE_TOLERANCE` (5% of the energy)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wifibot_power.errors import LogError
from wifibot_power.io import read_log
from wifibot_power.io.validate import POWER_TWICE_TOLERANCE

N = 500


def _canonical(tmp_path: Path, power_W, voltage_V, current_A, header=None) -> Path:
    header = header or "time_s,voltage_V,current_A,power_W"
    path = tmp_path / "twice.csv"
    lines = [
        f"{k * 0.01:.2f},{v:.5f},{i:.5f},{p:.5f}"
        for k, (v, i, p) in enumerate(zip(voltage_V, current_A, power_W, strict=True))
    ]
    path.write_text(f"{header}\n" + "\n".join(lines) + "\n")
    return path


def _const(value: float) -> np.ndarray:
    return np.full(N, value)


@pytest.mark.parametrize(
    ("power_W", "volts", "amps", "ratio"),
    [
        (36.0, 12.0, 2.0, "1.5x"),  # a 1.5x mismatch
        (240.0, 12.0, 2.0, "10x"),  # 10x: within the unit-mistake check's 30x, caught here
        (24.0, 12.0, -2.0, "-1x"),  # the current's sign against the power's
    ],
)
def test_a_power_column_that_disagrees_with_voltage_x_current_is_refused(
    tmp_path, wbpower, power_W, volts, amps, ratio
):
    path = _canonical(tmp_path, _const(power_W), _const(volts), _const(amps))
    with pytest.raises(LogError) as error:
        read_log(path)
    message = error.value.one_line()
    for needle in ("'power_W'", "'voltage_V'", "'current_A'", ratio, str(path)):
        assert needle in message, (needle, message)
    result = wbpower("inspect", path)
    assert result.exit_code == 2
    assert len(result.stderr.strip().splitlines()) == 1


def test_a_unit_mistake_is_named_as_such_before_the_disagreement(tmp_path, wbpower):
    # the repro, mW in a W column (1000x): the reader's unit-mistake check
    # (`validate.check_power_scale`, 30x off V x I) speaks first, with its own message
    path = _canonical(tmp_path, _const(900.0), _const(5.0), _const(0.18))
    with pytest.raises(LogError) as error:
        read_log(path)
    message = error.value.one_line()
    assert "power column 'power_W' is 1e+03 times the voltage x current" in message, message
    assert "disagrees" not in message
    result = wbpower("inspect", path)
    assert result.exit_code == 2
    assert len(result.stderr.strip().splitlines()) == 1
    # a unit slip after the first lines the unit check looks at is still caught, whole column
    power_W = np.r_[np.full(100, 10.0), np.full(N - 100, 10_000.0)]
    with pytest.raises(LogError, match="'power_W' disagrees with 'voltage_V' x 'current_A'"):
        read_log(_canonical(tmp_path, power_W, _const(5.0), _const(2.0)))


def test_agreeing_columns_are_read_within_the_stated_tolerance(tmp_path):
    rng = np.random.default_rng(0)
    volts = 12.0 + 0.2 * rng.standard_normal(N)
    amps = 2.0 + 0.5 * rng.standard_normal(N)
    # 1% noise per sample and 3% less overall (an instrument's mean of V x I): read
    power_W = 0.97 * volts * amps * (1 + 0.01 * rng.standard_normal(N))
    run = read_log(_canonical(tmp_path, power_W, volts, amps))
    np.testing.assert_allclose(run.power_W, np.round(power_W, 5))  # the power column itself
    # just past the tolerance: refused
    over = (1 + 1.2 * POWER_TWICE_TOLERANCE) * volts * amps
    with pytest.raises(LogError, match="disagrees"):
        read_log(_canonical(tmp_path, over, volts, amps))


def test_naming_the_power_column_is_the_way_out(tmp_path, wbpower):
    path = _canonical(tmp_path, _const(0.9), _const(5.0), _const(0.18 * 1000))
    assert wbpower("inspect", path).exit_code == 2
    # the user says which one is right: read as named
    result = wbpower("inspect", "--json", "--power-column", "power_W", path)
    assert result.exit_code == 0, result.stderr
    result = wbpower(
        "inspect", "--json", "--current-column", "current_A", "--voltage-column", "voltage_V", path
    )
    assert result.exit_code == 0, result.stderr


def test_channels_and_the_analyser_export_are_checked_too(tmp_path):
    header = "time_s,power_left_W,voltage_left_V,current_left_A"
    path = tmp_path / "channels.csv"
    path.write_text(header + "\n" + "".join(f"{k * 0.01:.2f},1.35,5,0.18\n" for k in range(N)))
    with pytest.raises(LogError, match="'power_left_W' disagrees with 'voltage_left_V'"):
        read_log(path)
    n6705 = tmp_path / "n6705.csv"
    n6705.write_text(
        'N6705C exported datalog\n\n"Sample interval: 0.001"\n\n'
        'Sample,"Curr avg 1","Volt avg 1","Power avg 1"\n'
        + "".join(f"{k},0.18,5,1.35\n" for k in range(N))
    )
    with pytest.raises(LogError, match="'Power avg 1' disagrees with 'Volt avg 1'"):
        read_log(n6705)


def _written(path: Path, volts: str, amps: str, power: str) -> Path:
    """A log of N rows of the same values, written as given."""
    rows = "".join(f"{k * 0.01:.2f},{volts},{amps},{power}\n" for k in range(N))
    path.write_text("time_s,voltage_V,current_A,power_W\n" + rows)
    return path


@pytest.mark.parametrize(
    ("volts", "amps", "read", "refused"),
    [
        # 12 V written to the volt, 0.06 A to the centiamp, 0.62 W to 0.1 mW: V x I as written
        # is 0.72 W, 0.10 W a sample over the power column; the tolerance allows 5% of 0.72 W,
        # 0.036 W, and the rounding up to 0.5 (12 x 0.01 + 0.06 x 1 + 0.0001) = 0.09005 W
        # more: read. (Without the rounding, or without its 12 V x 0.01 A term, refused.)
        # At 0.55 W, 0.17 W a sample apart, beyond both: refused.
        ("12", "0.06", "0.62", "0.55"),
        # 0.12 V written to the centivolt, 6.001 A to the milliamp, 0.66 W to the centiwatt:
        # V x I as written is 0.72012 W, 0.06012 W a sample over the power column; the
        # tolerance allows 0.036 W, the rounding 0.5 (0.12 x 0.001 + 6.001 x 0.01 + 0.01 +
        # 0.01 x 0.001) = 0.03507 W more: read. (Without its 6.001 A x 0.01 V term: refused.)
        # At 0.60 W, 0.12 W a sample apart: refused.
        ("0.12", "6.001", "0.66", "0.60"),
    ],
)
def test_the_rounding_of_the_numbers_as_written_is_allowed_for(
    tmp_path, volts, amps, read, refused
):
    path = tmp_path / "coarse.csv"
    assert read_log(_written(path, volts, amps, read)).power_W[0] == float(read)
    with pytest.raises(LogError, match="disagrees"):
        read_log(_written(path, volts, amps, refused))


@settings(max_examples=150, deadline=None)
@given(
    samples=st.integers(1, 3000),
    seed=st.integers(0, 2**32 - 1),
    holes=st.sampled_from([0.0, 0.0, 0.01, 0.3]),
)
def test_the_checks_sums_are_over_the_samples_all_three_give(samples, seed, holes):
    """`_twice_sums`: the sums over the samples where power, current and voltage are all
    finite, by plain sums when every sample is (the fast way) and masked otherwise, equal
    to the same sums over those samples picked out by hand."""
    from wifibot_power.io.validate import _twice_sums

    rng = np.random.default_rng(seed)
    voltage = 12 + rng.normal(0, 0.5, samples)
    current = rng.normal(1, 2, samples)  # negative currents too
    power = voltage * current * (1 + rng.normal(0, 0.01, samples))
    for column, bad in ((power, np.nan), (current, np.inf), (voltage, np.nan)):
        column[rng.random(samples) < holes] = bad
    kept = np.isfinite(power) & np.isfinite(current * voltage)
    p, i, v = power[kept], current[kept], voltage[kept]
    expected = (
        p.sum(),
        (i * v).sum(),
        max(np.abs(p).sum(), np.abs(i * v).sum()),
        np.abs(v).sum(),
        np.abs(i).sum(),
    )
    for masked in (False, True):
        *sums, count = _twice_sums(power, current, voltage, masked=masked)
        assert count == kept.sum()
        np.testing.assert_allclose(sums, expected, rtol=1e-12, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(samples=st.integers(1, 5000), seed=st.integers(0, 2**32 - 1))
def test_the_checks_plain_sums_are_numpys_own_and_leave_the_columns_as_read(samples, seed):
    """The plain sums (every sample finite) through one temporary are numpy's sums of each
    quantity to the bit (the same arrays summed: no other order of summation), and the
    columns are left as read (the temporary is the check's own)."""
    from wifibot_power.io.validate import _twice_sums

    rng = np.random.default_rng(seed)
    voltage = 12 + rng.normal(0, 0.5, samples)
    current = rng.normal(1, 2, samples)
    power = -voltage * current * (1 + rng.normal(0, 0.01, samples))  # negative powers too
    before = [column.copy() for column in (power, current, voltage)]
    sums = _twice_sums(power, current, voltage)
    assert sums == (
        float(np.sum(power)),
        float(np.sum(current * voltage)),
        max(float(np.sum(np.abs(power))), float(np.sum(np.abs(current * voltage)))),
        float(np.sum(np.abs(voltage))),
        float(np.sum(np.abs(current))),
        samples,
    )
    for column, read in zip((power, current, voltage), before, strict=True):
        assert np.array_equal(column, read)
