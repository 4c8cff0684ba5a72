"""The ripple's spectral-line test (`traces.line_p_values`, `traces.ripple_peak`): it holds
its level under white and red noise, finds a line of three cycles or more, and does not
test what it cannot tell from red noise (benchmarks/line_test_noise.py prints the table
docs/diagnose.md quotes)."""

from __future__ import annotations

import numpy as np
import pytest

from wifibot_power.traces import line_p_values, ripple_peak

BLOCK_S, BLOCKS = 0.01, 1000  # a 10 s cruise in 10 ms blocks
T = np.arange(BLOCKS) * BLOCK_S


def _coloured(rng: np.random.Generator, rms_W: float, exponent: float) -> np.ndarray:
    """1/f^exponent noise from a 60 s stretch (power below the cruise's resolution too)."""
    spectrum = np.fft.rfft(rng.standard_normal(6 * BLOCKS))
    f = np.arange(spectrum.size, dtype=np.float64)
    f[0] = 1.0
    spectrum /= f ** (exponent / 2)
    spectrum[0] = 0.0
    x = np.fft.irfft(spectrum, 6 * BLOCKS)[:BLOCKS]
    return x * rms_W / x.std()


def _cruise(
    rng: np.random.Generator,
    coloured_W: float,
    exponent: float,
    line_W: float = 0.0,
    hz: float = 0.0,
) -> np.ndarray:
    x = rng.normal(0.0, 0.08, BLOCKS) + _coloured(rng, coloured_W, exponent)
    x = x + line_W * np.sin(2 * np.pi * hz * T + rng.uniform(0, 2 * np.pi))
    return x - np.polyval(np.polyfit(T, x, 1), T)  # as traces._cruise_spectrum detrends


@pytest.mark.parametrize(
    ("coloured_W", "exponent"), [(0.0, 1.0), (0.05, 1.0), (0.5, 1.0), (0.2, 2.0)]
)
def test_noise_is_called_a_line_at_about_the_level_asked(coloured_W, exponent) -> None:
    """200 cruises of noise: at 1%, at most 7 called periodic (the binomial 99.9% bound for
    1% of 200). Measured on 400 (benchmarks/line_test_noise.py): 0.5-1.5% for these
    noises; Fisher's g-test, which assumes white noise, 79-100% with the red ones."""
    rng = np.random.default_rng(7)
    called = sum(
        ripple_peak(_cruise(rng, coloured_W, exponent), BLOCK_S)[2] < 0.01 for _ in range(200)
    )
    assert called <= 7


@pytest.mark.parametrize(
    ("hz", "coloured_W", "p_below"), [(0.5, 0.05, 1e-6), (2.45, 0.05, 1e-6), (7.3, 0.5, 1e-10)]
)
def test_a_line_of_three_cycles_or_more_is_found_in_red_noise(hz, coloured_W, p_below) -> None:
    """0.5 W at 0.5-7.3 Hz (5-73 cycles in 10 s) over 1/f noise: found at its frequency and
    amplitude. Measured on 50 cruises each: p at most 2.2e-7, 8.4e-8 and 3.9e-14, the
    frequency within 0.6%, the amplitude within 6% (11% under 0.5 W of 1/f). An off-grid
    line leaks into its neighbours (sidelobes falling as 1/d²), so p has a floor near 1e-8
    however strong the line: far below the runs' 1% (`cruise_ripple.RUN_ALPHA`)."""
    rng = np.random.default_rng(8)
    for _ in range(10):
        found_hz, amplitude_W, p_value = ripple_peak(
            _cruise(rng, coloured_W, 1.0, 0.5, hz), BLOCK_S
        )
        assert p_value < p_below
        assert found_hz == pytest.approx(hz, rel=0.01)
        assert amplitude_W == pytest.approx(0.5, rel=0.15)


def test_a_line_of_under_three_cycles_is_not_tested() -> None:
    """Two cycles in the series (bin 2): no neighbour below it but the one next to it, so it
    cannot be told from red noise and gets p = 1, however strong; so do the two bins at
    either end of the periodogram."""
    x = 2.0 * np.sin(2 * np.pi * 0.2 * T) + np.random.default_rng(9).normal(0, 0.08, BLOCKS)
    ordinates = (np.abs(np.fft.rfft(x)) ** 2)[1:-1]  # bin k is ordinates[k - 1]
    p_values = line_p_values(ordinates)
    assert p_values[1] == 1.0  # bin 2, the line
    assert p_values[0] == 1.0 and (p_values[-2:] == 1.0).all()
    assert p_values[2] < 1.0  # bin 3: one neighbour on each side beyond the next ones
    assert ripple_peak(x, BLOCK_S)[2] == 1.0


def test_the_line_p_value_is_the_f_tail_against_its_neighbours() -> None:
    """A flat spectrum of ones with one ordinate 10: its 16 neighbours (2-9 bins away) average
    1, so p = P(F(2, 32) > 10) = (1 + 10/16)^-16; a neighbour raised to 9 lifts the mean to
    1.5 and p to (1 + 10/1.5/16)^-16; the bins next to the line are not its neighbours."""
    ordinates = np.ones(100)
    ordinates[50] = 10.0
    assert line_p_values(ordinates)[50] == pytest.approx((1 + 10 / 16) ** -16, rel=1e-12)
    ordinates[49] = 1e6  # next to the line: leakage, not background
    assert line_p_values(ordinates)[50] == pytest.approx((1 + 10 / 16) ** -16, rel=1e-12)
    ordinates[45] = 9.0
    assert line_p_values(ordinates)[50] == pytest.approx((1 + 10 / 1.5 / 16) ** -16, rel=1e-12)
