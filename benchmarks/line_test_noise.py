"""How often the ripple's spectral-line test calls noise a line, and how often it finds a
real one: the table docs/diagnose.md quotes ("The ripple's spectral test").

Series like the cruises `traces.ripple_peak` reads: 1000 blocks of 10 ms (a 10 s cruise),
detrended by a line as `traces._cruise_spectrum` does, with white noise of 0.08 W (the field
realism's 0.8 W per 0.1 ms sample in 10 ms means) plus coloured noise taken from a 60 s
stretch (so it has power below the cruise's own resolution, as a run's drift does). Each
row: the share of 400 series (seed 2) whose p-value is under 0.01, for Fisher's g-test
(what wbpower used until the fifth session, written out here) and the test of a line
against its neighbours (`traces.line_p_values`, what it uses now).

    python benchmarks/line_test_noise.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from wifibot_power.traces import RIPPLE_BAND_HZ, ripple_peak  # noqa: E402

BLOCK_S, BLOCKS, TRIALS, LEVEL = 0.01, 1000, 400, 0.01


def coloured(rng: np.random.Generator, n: int, rms_W: float, exponent: float) -> np.ndarray:
    """Noise whose power falls as 1/f^exponent, scaled to `rms_W`."""
    spectrum = np.fft.rfft(rng.standard_normal(n))
    f = np.arange(spectrum.size, dtype=np.float64)
    f[0] = 1.0
    spectrum /= f ** (exponent / 2)
    spectrum[0] = 0.0
    x = np.fft.irfft(spectrum, n)
    return x * rms_W / x.std()


def fisher_p(x: np.ndarray) -> float:
    """Fisher's g-test of the highest periodogram ordinate in the band (Fisher 1929)."""
    spectrum = np.abs(np.fft.rfft(x)) ** 2
    freqs = np.fft.rfftfreq(x.size, BLOCK_S)
    band = (freqs >= RIPPLE_BAND_HZ[0]) & (freqs <= RIPPLE_BAND_HZ[1])
    ordinates = spectrum[1:-1] if x.size % 2 == 0 else spectrum[1:]
    g = spectrum[band].max() / ordinates.sum()
    return float(min(1.0, ordinates.size * (1.0 - g) ** (ordinates.size - 1)))


def main() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(BLOCKS) * BLOCK_S

    def cycles(count: float) -> np.ndarray:
        """1/f noise of 0.05 W with a 0.5 W line of `count` cycles in the cruise."""
        phase = rng.uniform(0, 2 * np.pi)
        line = 0.5 * np.sin(2 * np.pi * count / (BLOCKS * BLOCK_S) * t + phase)
        return coloured(rng, 6000, 0.05, 1.0)[:BLOCKS] + line

    rows = {
        "white 0.08 W": lambda: 0.0,
        "+ 1/f 0.05 W (fieldgen's)": lambda: coloured(rng, 6000, 0.05, 1.0)[:BLOCKS],
        "+ 1/f 0.5 W": lambda: coloured(rng, 6000, 0.5, 1.0)[:BLOCKS],
        "+ 1/f^1.5 0.2 W": lambda: coloured(rng, 6000, 0.2, 1.5)[:BLOCKS],
        "+ 1/f^2 0.2 W": lambda: coloured(rng, 6000, 0.2, 2.0)[:BLOCKS],
        "+ 1/f 0.05 W, line 0.5 W at 0.3-6 Hz": lambda: (
            coloured(rng, 6000, 0.05, 1.0)[:BLOCKS]
            + 0.5 * np.sin(2 * np.pi * rng.uniform(0.3, 6.0) * t + rng.uniform(0, 2 * np.pi))
        ),
        "+ 1/f 0.5 W, line 0.2 W at 0.3-6 Hz": lambda: (
            coloured(rng, 6000, 0.5, 1.0)[:BLOCKS]
            + 0.2 * np.sin(2 * np.pi * rng.uniform(0.3, 6.0) * t + rng.uniform(0, 2 * np.pi))
        ),
        "+ 1/f 0.05 W, line 0.5 W at 0.21 Hz (2.1 cycles)": lambda: cycles(2.1),
        "+ 1/f 0.05 W, line 0.5 W at 0.33 Hz (3.3 cycles)": lambda: cycles(3.3),
        "+ 1/f 0.05 W, line 0.5 W at 0.36 Hz (3.6 cycles)": lambda: cycles(3.6),
        "+ 1/f 0.05 W, line 0.5 W at 0.42 Hz (4.2 cycles)": lambda: cycles(4.2),
        "+ 1/f 0.05 W, line 0.5 W at 0.445 Hz (4.45 cycles)": lambda: cycles(4.45),
        "+ 1/f 0.05 W, line 0.5 W at 0.55 Hz (5.5 cycles)": lambda: cycles(5.5),
    }
    head = f"| series ({TRIALS} each, seed 2) | Fisher's g p < {LEVEL} |"
    print(f"{head} line vs neighbours p < {LEVEL} |")
    print("| --- | --- | --- |")
    for name, extra in rows.items():
        fisher = line = 0
        for _ in range(TRIALS):
            x = rng.normal(0.0, 0.08, BLOCKS) + extra()
            x = x - np.polyval(np.polyfit(t, x, 1), t)
            fisher += fisher_p(x) < LEVEL
            line += ripple_peak(x, BLOCK_S)[2] < LEVEL
        print(f"| {name} | {fisher / TRIALS:.1%} | {line / TRIALS:.1%} |")


if __name__ == "__main__":
    main()
