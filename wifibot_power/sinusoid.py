"""The least-squares sinusoid of a series near a periodogram peak: one implementation for
the ripple line of a cruise (`traces.ripple_peak`) and for the wheel ripple fitted out of a
cruise's creep (`causes.thermal_drift`).

A series x of n evenly spaced values (step Δ), from which a level and a line in time were
removed, is fitted by ``a sin 2πft + b cos 2πft`` jointly with the line ``c + d t``: the
frequency f whose fit leaves the least residual is the one whose sinusoid explains the most
of x (least squares in frequency, amplitude and phase; Quinn & Hannan, The Estimation and
Tracking of Frequency, 2001, §2.3). The periodogram's grid is 1/(nΔ), so its highest
bin is only within half a bin of f, and a sinusoid half a bin off leaves a third of its
amplitude unexplained in a series of a few periods: f is refined within one bin either side.
"""

from __future__ import annotations

import numpy as np

#: frequencies tried within one periodogram bin either side of a peak (then a parabola
#: through the best three): a grid of a twentieth of a bin
CANDIDATES = 41


def centred_times_s(n: int, step_s: float) -> np.ndarray:
    """Sample times centred on the series' middle [s]: sums of odd functions vanish."""
    return (np.arange(n) - (n - 1) / 2.0) * step_s


def detrended(x: np.ndarray, step_s: float) -> np.ndarray:
    """`x` less its least-squares level and line in time [same unit]: over centred t the two
    are apart, the mean and Σtx / Σt² (what numpy.polyfit's line gives, to rounding)."""
    t = centred_times_s(x.size, step_s)
    centred = np.asarray(x, dtype=np.float64) - np.add.reduce(x) / x.size
    return centred - t * (float(t @ centred) / float(t @ t))


def explained_W2(x: np.ndarray, step_s: float, candidates_hz: np.ndarray) -> np.ndarray:
    """Sum of squares [W²] the least-squares sinusoid at each candidate frequency explains
    in `x`, fitted jointly with a level and a line in time.

    `x` must be orthogonal to a level and a line (detrended), so its products with the
    parts of the sine and cosine that a level and a line explain vanish (Frisch-Waugh-
    Lovell): with S, C the sine and cosine made orthogonal to [1, t], the explained sum is
    ``(Sx)²/S·S + (Cx)²/C·C``. Over centred, evenly spaced t (step Δ, n values) S·C = 0 and
    the sums are closed forms of the Dirichlet kernel D(ω) = Σ cos ωt = sin(nωΔ/2) /
    sin(ωΔ/2): Σ sin ωt = Σ t cos ωt = 0, Σ t sin ωt = -D'(ω), Σ cos² ωt = (n + D(2ω)) / 2,
    Σ sin² ωt = (n - D(2ω)) / 2; f must lie in (0, 1/(2Δ)). Only Σ x e^{iωt} is summed:
    the candidates must be evenly spaced, so each one's wave is the one before times a
    fixed turn (a complex product a value, no sines; one wave held at a time, so memory
    is the series', and faster than all the waves made at once as a matrix: measured).
    """
    x = np.asarray(x, dtype=np.float64)
    candidates_hz = np.asarray(candidates_hz, dtype=np.float64)
    n = x.size
    t = centred_times_s(n, step_s)
    xc = np.empty(candidates_hz.size, dtype=np.complex128)  # Σ x e^{iωt}
    turn = np.exp(2j * np.pi * (candidates_hz[1] - candidates_hz[0]) * t)
    wave = np.exp(2j * np.pi * candidates_hz[0] * t)
    x_complex = x.astype(np.complex128)
    for j in range(candidates_hz.size):  # a candidate an iteration, vectorised over t
        if j:
            np.multiply(wave, turn, out=wave)
        xc[j] = wave @ x_complex
    half = np.pi * candidates_hz * step_s  # ωΔ/2
    sin_half, cos_half = np.sin(half), np.cos(half)
    sin_n, cos_n = np.sin(n * half), np.cos(n * half)
    dirichlet = sin_n / sin_half
    t_sin = -0.5 * step_s * (n * cos_n * sin_half - sin_n * cos_half) / sin_half**2
    cos2 = np.sin(2.0 * n * half) / np.sin(2.0 * half)  # D(2ω)
    ss = 0.5 * (n - cos2) - t_sin**2 / float(t @ t)
    cc = 0.5 * (n + cos2) - dirichlet**2 / n
    with np.errstate(divide="ignore"):
        return xc.imag**2 / np.where(ss > 0, ss, np.inf) + xc.real**2 / np.where(cc > 0, cc, np.inf)


def refined_hz(x: np.ndarray, step_s: float, peak_hz: float) -> float:
    """The frequency [Hz] within one periodogram bin of `peak_hz` whose sinusoid, fitted
    with a level and a line, explains the most of `x` (`explained_W2`, on `x` detrended
    here): the best of `CANDIDATES` evenly spaced, then the vertex of the parabola through
    it and its two neighbours. Kept to one cycle in the series or more and under the
    Nyquist frequency."""
    x = detrended(x, step_s)  # as `explained_W2` needs (a no-op, to rounding, if it was)
    bin_hz = 1.0 / (x.size * step_s)
    # at least one cycle in the series: under one, a sinusoid beside a line is a bend, and
    # takes up the curvature of a slow creep (a warming motor's) rather than a ripple; and
    # below the Nyquist frequency, where the sine vanishes at every sample
    low_hz = max(peak_hz - bin_hz, bin_hz)
    high_hz = min(peak_hz + bin_hz, 0.5 / step_s - bin_hz / 4)
    if x.size < 4 or high_hz <= low_hz:
        return float(peak_hz)  # no room to refine (a series of a few values)
    candidates_hz = np.linspace(low_hz, high_hz, CANDIDATES)
    explained = explained_W2(x, step_s, candidates_hz)
    j = int(np.argmax(explained))
    if 0 < j < candidates_hz.size - 1:
        left, mid, right = explained[j - 1], explained[j], explained[j + 1]
        curvature = left - 2.0 * mid + right
        if curvature < 0:  # a maximum: the vertex lies within half a grid step
            shift = 0.5 * (left - right) / curvature
            return float(candidates_hz[j] + shift * (candidates_hz[1] - candidates_hz[0]))
    return float(candidates_hz[j])


def sinusoid_fit(x: np.ndarray, step_s: float, hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares ``a sin 2πft + b cos 2πft + c + d t`` of `x` at `hz`, t centred
    (`centred_times_s`): the coefficients (a, b, c, d) and the fitted values. By the normal
    equations (four columns: a level, a centred line and a sine and cosine are well
    conditioned)."""
    t = centred_times_s(x.size, step_s)
    basis = np.column_stack(
        [np.sin(2 * np.pi * hz * t), np.cos(2 * np.pi * hz * t), np.ones(x.size), t]
    )
    coef = np.linalg.solve(basis.T @ basis, basis.T @ x)
    return coef, basis @ coef
