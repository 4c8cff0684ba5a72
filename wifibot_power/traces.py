"""Per-run statistics of the power trace that `diagnose` needs, computed at sample level
while the run is in memory (so diagnosis holds only these small summaries, not traces).

- Start and end windows of each step (where a start transient or a stopping phase puts
  its energy), as sufficient statistics that are linear in the model's coefficients.
- The spectrum of the cruise power (where a wheel-eccentricity ripple shows), with a test
  of its strongest line against the local spectrum, and the cruise trace in 10 ms blocks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wifibot_power.changepoint import block_means
from wifibot_power.phases import Segmentation
from wifibot_power.run import Run
from wifibot_power.runtable import WindowEnergy
from wifibot_power.sinusoid import detrended, refined_hz, sinusoid_fit

#: Length of the window after each acceleration start where a start transient sits [s].
START_WINDOW_S = 0.25
#: Length of the window after each cruise end where a stopping phase sits [s].
END_WINDOW_S = 1.0
#: Block length for spectra and trace comparisons [s]; ripple is at most a few Hz.
BLOCK_S = 0.01
#: Shortest cruise phase whose spectrum is analysed [s].
MIN_CRUISE_S = 3.0
#: Frequencies searched for a ripple peak [Hz].
RIPPLE_BAND_HZ = (0.1, 20.0)
#: Periodogram bins on each side of a candidate line that estimate the spectrum under it
#: (`line_p_values`): 8 a side gives F(2, 32), within ±0.9 Hz of the line in a 10 s cruise
LINE_NEIGHBOURS = 8


@dataclass(frozen=True, eq=False)
class TraceStats:
    """Window sums (J, s) over all steps of a run, and the cruise spectrum's peak."""

    steps: int
    start_measured_J: float
    start_accel_s: float
    start_ramp_s: float  # sum over accel samples in the window of u = (t - t_a0) / t_acc, times dt
    start_ramp2_s: float  # the same sum of u², times dt
    start_cruise_s: float
    end_measured_J: float
    end_s: float
    ripple_hz: float
    ripple_amplitude_W: float
    ripple_p_value: float
    cruise_blocks_W: np.ndarray  # detrended 10 ms block means of the longest cruise
    block_s: float

    def as_row(self) -> dict[str, float]:
        return {
            "start_measured_J": self.start_measured_J,
            "start_accel_s": self.start_accel_s,
            "start_ramp_s": self.start_ramp_s,
            "start_ramp2_s": self.start_ramp2_s,
            "start_cruise_s": self.start_cruise_s,
            "end_measured_J": self.end_measured_J,
            "end_s": self.end_s,
            "ripple_hz": self.ripple_hz,
            "ripple_amplitude_W": self.ripple_amplitude_W,
            "ripple_p_value": self.ripple_p_value,
            # how long the analysed cruise is: how many cycles of a line it can show
            "ripple_cruise_s": self.cruise_blocks_W.size * self.block_s
            if self.cruise_blocks_W.size
            else np.nan,
        }


EMPTY = TraceStats(
    0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, np.nan, np.nan, np.nan, np.zeros(0), BLOCK_S
)


def trace_stats(
    run: Run, segmentation: Segmentation, energy: WindowEnergy | None = None
) -> TraceStats:
    """Window sums and cruise spectrum of a motion run (EMPTY for other runs); `energy`: the
    run's `runtable.WindowEnergy` when the caller has it already."""
    if run.meta.mode != "motion" or not segmentation.phases:
        return EMPTY
    dt = run.sample_period_s
    energy = energy or WindowEnergy(run)
    by_step: dict[int, dict[str, list]] = {}
    for phase in segmentation.phases:
        if phase.phase in ("accel", "cruise", "decel") and phase.step >= 1:
            by_step.setdefault(phase.step, {}).setdefault(phase.phase, []).append(phase)
    steps = sorted(s for s, kinds in by_step.items() if "accel" in kinds and "cruise" in kinds)
    # each step's stop window ends where the next step's motion starts, whether or not that
    # step has a cruise (a speed column can give steps that speed up and stop), the last
    # one's at the end of the run
    motion_starts = sorted(
        min(p.i_start for ps in kinds.values() for p in ps) for kinds in by_step.values()
    )
    starts_next = [
        next(
            (i for i in motion_starts if i > min(p.i_start for p in by_step[s]["accel"])),
            run.samples,
        )
        for s in steps
    ]
    sums = np.zeros(7)
    windows: list[tuple[int, int]] = []  # each step's start and end windows, in turn
    w_start = max(1, round(START_WINDOW_S / dt))
    w_end = max(1, round(END_WINDOW_S / dt))
    for step, next_start in zip(steps, starts_next, strict=True):
        accel = by_step[step]["accel"]
        ia0, ia1 = min(p.i_start for p in accel), max(p.i_end for p in accel)
        ic1 = max(p.i_end for p in by_step[step]["cruise"])
        i_stop = min(ia0 + w_start, ic1)
        n_acc = min(i_stop, ia1) - ia0
        # u at the middle of each accel sample in the window (an arithmetic series)
        n_ramp = ia1 - ia0
        sum_u = (n_acc * n_acc / 2.0) / n_ramp
        # sum of ((j + 0.5) / n)² for j < m: (m³/3 - m/12) / n²
        sum_u2 = (n_acc**3 / 3.0 - n_acc / 12.0) / n_ramp**2
        j_stop = min(ic1 + w_end, next_start)
        windows += [(ia0, i_stop), (ic1, j_stop)]
        # the two windows' energies (0 and 5) are added below, in one pass over the samples
        sums += [
            0.0,
            n_acc * dt,
            sum_u * dt,
            sum_u2 * dt,
            max(i_stop - ia1, 0) * dt,
            0.0,
            (j_stop - ic1) * dt,
        ]
    if windows:
        window_J = energy.between(*np.array(windows).T)
        sums[0], sums[5] = window_J[0::2].sum(), window_J[1::2].sum()
    hz, amplitude_W, p_value, blocks, block_s = _cruise_spectrum(run, segmentation)
    return TraceStats(len(steps), *map(float, sums), hz, amplitude_W, p_value, blocks, block_s)


def _cruise_spectrum(run: Run, segmentation: Segmentation):
    dt = run.sample_period_s
    cruises = [p for p in segmentation.phases if p.phase == "cruise"]
    if not cruises:
        return np.nan, np.nan, np.nan, np.zeros(0), BLOCK_S
    longest = max(cruises, key=lambda p: p.i_end - p.i_start)
    per_block = max(1, round(BLOCK_S / dt))
    block_s = per_block * dt
    n_blocks = (longest.i_end - longest.i_start) // per_block
    if n_blocks * block_s < MIN_CRUISE_S:
        return np.nan, np.nan, np.nan, np.zeros(0), block_s
    x = block_means(
        run.power_W[longest.i_start : longest.i_start + n_blocks * per_block], per_block
    )
    x = detrended(x, block_s)  # drift within a cruise is not ripple
    hz, amplitude_W, p_value = ripple_peak(x, block_s)
    return hz, amplitude_W, p_value, x, block_s


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
