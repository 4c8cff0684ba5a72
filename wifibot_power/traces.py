"""Cause-neutral tools the causes' per-run statistics are made with (`causes.base.RunView`):
the windows of each step of a segmented run, and the test of a spectral line in a series
(a cruise's power in blocks) against its local spectrum. Names no cause.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.sinusoid import refined_hz, sinusoid_fit

if TYPE_CHECKING:
    from wifibot_power.phases import Segmentation

#: Frequencies searched for a ripple peak [Hz].
RIPPLE_BAND_HZ = (0.1, 20.0)
#: Periodogram bins on each side of a candidate line that estimate the spectrum under it
#: (`line_p_values`): 8 a side gives F(2, 32), within ±0.9 Hz of the line in a 10 s cruise
LINE_NEIGHBOURS = 8


@dataclass(frozen=True, eq=False)
class StepWindows:
    """Sample indices of each step that has an acceleration and a cruise, in step order:
    where its acceleration starts and ends, where its cruise ends, and where the next step's
    motion starts (the run's end after the last). Causes take their windows from these
    (`causes.base.RunView.steps`)."""

    accel_start: list[int]
    accel_end: list[int]
    cruise_end: list[int]
    next_start: list[int]

    def __len__(self) -> int:
        return len(self.accel_start)


def windows_after(
    starts: list[int], length_s: float, limits: list[int], period_s: float
) -> tuple[list[int], list[int]]:
    """Windows of `length_s` (at least a sample) from each of `starts`, each cut at its
    matching `limits` (sample indices): (starts, ends)."""
    n = max(1, round(length_s / period_s))
    return starts, [min(i + n, limit) for i, limit in zip(starts, limits, strict=True)]


def step_windows(segmentation: Segmentation, samples: int) -> StepWindows:
    """The steps of a segmented run that have an acceleration and a cruise (`StepWindows`).
    Each step's stop window ends where the next step's motion starts, whether or not that
    step has a cruise (a speed column can give steps that speed up and stop), the last
    one's at the end of the run (`samples`)."""
    by_step: dict[int, dict[str, list]] = {}
    for phase in segmentation.phases:
        if phase.phase in ("accel", "cruise", "decel") and phase.step >= 1:
            by_step.setdefault(phase.step, {}).setdefault(phase.phase, []).append(phase)
    steps = sorted(s for s, kinds in by_step.items() if "accel" in kinds and "cruise" in kinds)
    motion_starts = sorted(
        min(p.i_start for ps in kinds.values() for p in ps) for kinds in by_step.values()
    )
    accel_start = [min(p.i_start for p in by_step[s]["accel"]) for s in steps]
    return StepWindows(
        accel_start,
        [max(p.i_end for p in by_step[s]["accel"]) for s in steps],
        [max(p.i_end for p in by_step[s]["cruise"]) for s in steps],
        [next((i for i in motion_starts if i > ia0), samples) for ia0 in accel_start],
    )


def ripple_peak(x: np.ndarray, block_s: float) -> tuple[float, float, float]:
    """The spectral line of a zero-mean series in RIPPLE_BAND_HZ that stands out most from
    its neighbourhood: frequency [Hz], amplitude of the best-fitting sinusoid [W], and the
    p-value of that line against the local spectrum (`line_p_values`; the neighbours taken
    from the series without the fitted sinusoid), times the band's bins for the search over
    them (Bonferroni)."""
    n = x.size
    spectrum = np.abs(np.fft.rfft(x)) ** 2
    freqs = np.fft.rfftfreq(n, block_s)
    band = (freqs >= RIPPLE_BAND_HZ[0]) & (freqs <= min(RIPPLE_BAND_HZ[1], 0.5 / block_s))
    band[0] = band[-1] = False  # the mean and the Nyquist bin are not lines
    if band.sum() < 3:
        return np.nan, np.nan, np.nan
    # which line: the one that stands out most in the Hann-tapered spectrum, against its
    # neighbours beyond the taper's main lobe (±2 bins). Untapered, an off-grid line's
    # leakage caps how far it stands out, so a weaker line on the grid (a 2nd harmonic of
    # 0.3 of the fundamental, fieldgen's ripple at 0.7 m/s) was taken for it
    tapered = np.abs(np.fft.rfft(x * np.hanning(n))) ** 2
    in_band = np.flatnonzero(band[1:-1])
    chosen = line_p_values(tapered[1:-1], gap=2)
    k = 1 + int(in_band[np.argmin(chosen[in_band])])
    # refine the frequency between the neighbouring bins (the periodogram's grid is 1/T),
    # then fit the sinusoid there: least squares in frequency, amplitude and phase
    best = refined_hz(x, block_s, float(freqs[k]))
    coef, fitted = sinusoid_fit(x, block_s, best)  # the sinusoid and its line
    amplitude_W = float(np.hypot(coef[0], coef[1]))
    # the chosen line against its neighbours in the series without it: an off-grid line
    # leaks into the bins around it (sidelobes falling as 1/d²), and against its own
    # leakage a line of 3.5-5.5 cycles never reached 1% however strong it was. Its ordinate:
    # the bin nearest the refined frequency's (the taper may have chosen the next one)
    residual = (np.abs(np.fft.rfft(x - fitted)) ** 2)[1:-1]
    k = int(np.clip(round(best / (freqs[1] - freqs[0])), 1, residual.size))
    residual[k - 1] = spectrum[k]
    p_value = float(min(1.0, in_band.size * line_p_values(residual)[k - 1]))
    return float(best), float(amplitude_W), p_value


def line_p_values(ordinates: np.ndarray, side: int = LINE_NEIGHBOURS, gap: int = 1) -> np.ndarray:
    """P-value of each periodogram ordinate as a spectral line against its neighbours.

    Each ordinate of a stationary series' periodogram is ``S(f)·χ²₂/2``, independent of
    the others (Brockwell & Davis, Time Series: Theory and Methods, §10.3), whatever the
    shape of the spectrum S. Where S is smooth, the mean of the ``r`` ordinates on either
    side of bin k (gap + 1 to gap + r bins away: a line off the bin grid leaks into the
    bins next to it) estimates S there, and ``I_k / mean`` is F(2, 4r): P(F > x) =
    (1 + x/2r)^(-2r). Fisher's g-test (Fisher 1929), used until the fifth session, divides
    by the whole spectrum's sum, i.e. assumes white noise: under 1/f noise of 0.05 W rms it
    called 79% of 10 s cruises periodic at 1%, against 0.2% here (docs/diagnose.md). The
    neighbours are taken as many on each side, so a sloping spectrum (red noise) is not
    read against its lower side alone; a bin with no neighbour on a side (within gap + 1
    of either end) gets p = 1: a "line" of under three cycles in the series cannot be told
    from red noise."""
    m = ordinates.size
    cumulative = np.concatenate(([0.0], np.cumsum(ordinates)))
    k = np.arange(m)
    reach = np.clip(np.minimum(side, np.minimum(k - gap, m - 1 - gap - k)), 0, None)
    window = (
        cumulative[np.clip(k + gap + 1 + reach, 0, m)] - cumulative[np.clip(k - gap - reach, 0, m)]
    )
    near = cumulative[np.clip(k + gap + 1, 0, m)] - cumulative[np.clip(k - gap, 0, m)]
    count = 2 * reach
    p_values = np.ones(m)
    tested = count > 0
    background = (window[tested] - near[tested]) / count[tested]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(background > 0, ordinates[tested] / background, np.inf)
    p_values[tested] = (1.0 + ratio / count[tested]) ** (-count[tested].astype(np.float64))
    return p_values


def ripple_trace_rmse_W(x: np.ndarray, block_s: float, hz: float, amplitude_W: float) -> float:
    """RMS of a cruise trace after removing a sinusoid of given frequency and amplitude;
    only the phase is fitted to the trace (the run's own start time is arbitrary)."""
    t = np.arange(x.size) * block_s
    basis = np.column_stack([np.sin(2 * np.pi * hz * t), np.cos(2 * np.pi * hz * t)])
    coef, *_ = np.linalg.lstsq(basis, x, rcond=None)
    norm = np.hypot(*coef)
    predicted = basis @ (coef / norm * amplitude_W) if norm > 0 else np.zeros_like(x)
    return float(np.sqrt(np.mean((x - predicted) ** 2)))
