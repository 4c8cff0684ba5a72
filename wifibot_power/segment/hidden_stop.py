"""Stops a ripple may have hidden (docs/segmentation.md, "A stop hidden by the ripple"):
a doubt of a motion run segmented from power alone, judged on its 10 ms means."""

from __future__ import annotations

import numpy as np

from wifibot_power.changepoint import block_means
from wifibot_power.segment.common import Span, _Means10, _phase_name, _wavy_means
from wifibot_power.segment.params import MotionParams

#: the fewest cycles of the ripple the fitted part must hold (`_ripple_continuation`), and
#: the most means it is fitted on (`_hidden_stop_doubts` averages longer cruises to these)
_RIPPLE_CYCLES = 2.0
_RIPPLE_POINTS = 256


def _hidden_stop_doubts(
    means: _Means10,
    spans: list[Span],
    idle_median_W: dict[int, float],
    params: MotionParams,
    wavy_steps: set[int] | None = None,
    ends_moving: bool = False,
) -> list[str]:
    """Stops a ripple may have hidden, on the 10 ms means of the phases `spans` (the idles'
    medians `idle_median_W`, by span), in span order: `_ripple_stop_doubts` (a wavy cruise
    whose end strays off its own carried-on ripple; `wavy_steps`: the steps whose search
    found the motion after the acceleration wavy, any stop in it included) and
    `_idle_stop_doubts` (an idle after a step that stands above its level from its start).
    When the run `ends_moving` (doubted as such already), its last idle is not looked at:
    the motion in it is not a stop."""
    # a boundary within 50 ms is right (issue 12): the ends of each phase are left out
    dt_ms = 1000.0 * (means.when(1) - means.when(0))
    guard = max(1, round(50.0 / dt_ms))
    doubts = _ripple_stop_doubts(means, spans, params, wavy_steps, guard, dt_ms)
    doubts |= _idle_stop_doubts(means, spans, idle_median_W, params, ends_moving, guard, dt_ms)
    return [doubts[k] for k in sorted(doubts)]


def _ripple_stop_doubts(
    means: _Means10,
    spans: list[Span],
    params: MotionParams,
    wavy_steps: set[int] | None,
    guard: int,
    dt_ms: float,
) -> dict[int, str]:
    """A wavy cruise (of `wavy_steps`; by default its 10 ms means tested as `_wavy` does)
    that runs straight into idle (no stop found): its ripple (a line and the sinusoid that
    fits it best, `_ripple_continuations`) is fitted on the cruise but its last
    `max_decel_wavy_s` (or third), over up to `hidden_stop_fit_s`, and carried on over that
    tail. Where the cruise really held on to the end, the tail scatters about the
    carried-on ripple as the fitted part does about its fit; a stop inside it (power drops,
    then falls towards idle, while the ripple fades with the speed) does not. Doubted when
    the tail's rms off the ripple exceeds `hidden_stop_ratio` times the fitted part's (and
    noise's). The doubts by span; `guard` means at each end of a phase are left out."""
    y10, sigma10 = means.values_W, means.sigma_W
    # the cruises' means (of `group` 10 ms means, at most `_RIPPLE_POINTS`: the cost),
    # fitted part and tail, fitted all at once
    cruises: list[tuple[int, np.ndarray, int, float, float]] = []
    for k, (a, b, name, step) in enumerate(spans):
        following = spans[k + 1][2] if k + 1 < len(spans) else None
        if name != "cruise" or following != "idle" or b - a - 2 * guard < 30:
            continue
        values = y10[a + guard : b - guard]
        # wavy as the step's search first found it (the cruise with any stop it hides),
        # else by the same test here
        wavy = step in wavy_steps if wavy_steps is not None else _wavy_means(values, sigma10)
        if not wavy:
            continue
        n = values.size
        tail = min(max(1, round(params.max_decel_wavy_s * 1000.0 / dt_ms)), n // 3)
        fit = min(n - tail, max(1, round(params.hidden_stop_fit_s * 1000.0 / dt_ms)))
        group = -(-(fit + tail) // _RIPPLE_POINTS)
        fit_g, tail_g = fit // group, tail // group  # (fit + tail) // group <= 256
        if fit_g < 8 or tail_g < 1:
            continue
        grouped = block_means(values[n - (fit_g + tail_g) * group :], group)
        cruises.append((k, grouped, fit_g, sigma10 / np.sqrt(group), tail * dt_ms / 1000.0))
    fits = _ripple_continuations(
        [(means_g, fit_g, noise) for _, means_g, fit_g, noise, _ in cruises]
    )
    doubts: dict[int, str] = {}
    for (k, grouped, fit_g, noise_W, tail_s), fitted in zip(cruises, fits, strict=True):
        if fitted is None:
            continue  # no ripple to carry on, or under two cycles of it: no telling
        carried, fit_rms_W = fitted
        off = grouped[fit_g:] - carried
        tail_rms_W = float(np.sqrt(np.einsum("i,i->", off, off) / off.size))
        if tail_rms_W > params.hidden_stop_ratio * max(fit_rms_W, noise_W):
            doubts[k] = (
                f"{_phase_name('cruise', spans[k][3])} ends off its own ripple: over its last "
                f"{tail_s:.2f} s power is {tail_rms_W:.3g} W rms off the ripple fitted "
                f"before ({fit_rms_W:.3g} W there): a stop the ripple hid?"
            )
    return doubts


def _idle_stop_doubts(
    means: _Means10,
    spans: list[Span],
    idle_median_W: dict[int, float],
    params: MotionParams,
    ends_moving: bool,
    guard: int,
    dt_ms: float,
) -> dict[int, str]:
    """An idle after a step whose power stands above the idle's own median from its start
    (the drive still on: a stop labelled idle) by more than `hidden_stop_z` noise sd of the
    stretch's mean from `guard` means past its start to `guard` before its end (the
    tolerance of a boundary at either end, as for a cruise), and by `min_excess_W` at
    least: the running mean above the median, in sd of that mean, all idles in one pass.
    The doubts by span."""
    y10, sigma10 = means.values_W, means.sigma_W
    idles = [
        (k, a, b)
        for k, (a, b, name, step) in enumerate(spans)
        if name == "idle"
        and step >= 1
        and b - a >= 4 * guard
        and not (ends_moving and k == len(spans) - 1)
    ]
    # a running mean stands `min_excess_W` above the level only where some mean does:
    # where none does (noise of a few sd under 0.25 W, as a rule), nothing to test
    windows = [(a + guard, b - guard) for _, a, b in idles]
    levels_W = [idle_median_W[k] for k, _, _ in idles]
    # (a bound only for a bar of 0 sd or more: under it, an idle at its level is doubted)
    if not idles or (
        params.hidden_stop_z >= 0 and not _stands_above(y10, windows, levels_W, params.min_excess_W)
    ):
        return {}
    lengths = np.array([b - a - 2 * guard for _, a, b in idles])
    starts = np.concatenate(([0], np.cumsum(lengths)[:-1]))
    excess = np.concatenate([y10[a + guard : b - guard] for _, a, b in idles])
    excess -= np.repeat(np.array(levels_W), lengths)
    running = np.cumsum(excess)
    before = np.concatenate(([0.0], running[starts[1:] - 1]))
    running -= np.repeat(before, lengths)
    count = np.arange(1, running.size + 1, dtype=np.float64)
    count -= np.repeat(starts.astype(np.float64), lengths)
    z = running / (sigma10 * np.sqrt(count) + 1e-12)
    # and by at least `min_excess_W` (what the segmenter calls the drive on, "motion"):
    # the sd of a long mean is sigma10 / sqrt(n) under white noise only, and fieldgen's
    # 1/f noise of 0.05 W stood idles 0.075-0.13 W above their median at z > 6 (5 of 24
    # null batches unexplained through the runs it left out; found by validation)
    z = np.where(running >= params.min_excess_W * count, z, 0.0)
    doubts: dict[int, str] = {}
    for j in np.flatnonzero(np.maximum.reduceat(z, starts) > params.hidden_stop_z):
        k, a, _ = idles[j]
        i = int(starts[j]) + int(np.argmax(z[starts[j] : starts[j] + lengths[j]]))
        doubts[k] = (
            f"{_phase_name('idle', spans[k][3])} stands {running[i] / count[i]:.3g} W above "
            f"its own level from {means.when(a):.3f} s for "
            f"{(count[i] + guard) * dt_ms / 1000.0:.2f} s: the drive still on, a stop "
            "labelled idle?"
        )
    return doubts


def _stands_above(
    y10: np.ndarray, windows: list[tuple[int, int]], levels_W: list[float], excess_W: float
) -> bool:
    """Whether any value of `y10` in the windows [a, b) (in order, apart, not empty)
    stands `excess_W` or more above its window's level, less 1e-6 W (a margin far above
    the rounding of the running sums this stands in for): each window's maximum by one
    `reduceat` over the windows' edges."""
    edges = [edge for window in windows for edge in window]
    if edges[-1] >= y10.size:
        edges.pop()
    tops = np.maximum.reduceat(y10, edges)[::2].tolist()
    return max(top - level for top, level in zip(tops, levels_W, strict=True)) >= excess_W - 1e-6


def _ripple_continuation(
    values: np.ndarray, fit_n: int, noise_W: float
) -> tuple[np.ndarray, float] | None:
    """`_ripple_continuations` of one window."""
    return _ripple_continuations([(values, fit_n, noise_W)])[0]


def _ripple_continuations(
    windows: list[tuple[np.ndarray, int, float]],
) -> list[tuple[np.ndarray, float] | None]:
    """For each window (values, fit_n, noise_W): a line plus the ripple's sinusoid fitted
    (least squares) to `values[:fit_n]`, carried on over `values[fit_n:]` (returned), and
    the rms of the fit's residual. None when the
    fitted part holds under `_RIPPLE_CYCLES` cycles of it (a fraction of a cycle fits, but
    does not carry on: on the default grid's 1 m steps at 0.7 m/s, 0.75 of a cycle carried
    on 0.3 s was 4 times its fit's rms off with no stop), over a quarter of a cycle per
    value (a sinusoid near the values' Nyquist frequency is noise's), or when the
    sinusoid's rms is not above max(3 `noise_W`, 0.1 W), `_wavy`'s bar: no ripple to carry
    on (a noisy cruise at 0.9 m/s, 1.5 W, had an alternating "ripple" fitted to its noise
    whose continuation stood 2.4 noise sd off).

    The frequency w0: the strongest peak of the periodogram of the detrended values
    (zero-padded to 4x or more, a power of two: `_fft_length`; the peak interpolated by
    a parabola). The fit is linear in the
    columns 1, u, sin w0 u, cos w0 u, u sin w0 u, u cos w0 u (u: the time centred and
    scaled to [-1/2, 1/2) over the fitted part): the last two are the first-order terms
    of a frequency a little off w0, a sin((w0 + d) u) + b cos((w0 + d) u) ~ ... +
    d u (a cos w0 u - b sin w0 u), so d is read off their coefficients c = -b d, e = a d
    (least squares) and the line and the sinusoid at w0 + d are carried on, its amplitude
    held (the first-order terms themselves grow with u). One 6 x 6 solve per window;
    normal equations by `einsum`: no BLAS threads (see changepoint.block_means).

    The windows are the rows of padded arrays (each padded past its window with zeros,
    which the periodogram and the normal equations ignore; the periodogram zero-padded to
    a power of two, 4x the longest window or more). A step's cost is numpy's per call, not
    its few hundred means: ten windows of 256 means cost 0.2-0.4 ms at once against
    0.5-0.8 ms one by one; one window costs 125-150 us as a row (a one-window copy of this
    function, 50-70 us, was dropped in review: the same fit written twice, kept equal by a
    test; it runs only for a wavy cruise with no stop found).
    """
    if not windows:
        return []
    rows = len(windows)
    fit_n = np.array([w[1] for w in windows])
    tail_n = np.array([w[0].size - w[1] for w in windows])
    width, tail_width = int(fit_n.max()), max(1, int(tail_n.max()))
    fit = np.zeros((rows, width))
    for i, (values, n, _) in enumerate(windows):
        fit[i, :n] = values[:n]
    columns = np.arange(width, dtype=np.float64)
    inside = columns[None, :] < fit_n[:, None]
    centre = (fit_n[:, None] - 1) / 2.0
    x = np.where(inside, columns[None, :] - centre, 0.0)  # centred, 0 past each window
    mean_W = fit.sum(axis=1) / fit_n
    s_xx = fit_n * (fit_n * fit_n - 1) / 12.0
    slope = np.einsum("ij,ij->i", x, fit) / s_xx
    detrended = np.where(inside, fit - mean_W[:, None] - slope[:, None] * x, 0.0)
    noise_W = np.array([w[2] for w in windows])
    bar_W = np.maximum(3.0 * noise_W, 0.1)
    scattered = np.einsum("ij,ij->i", detrended, detrended) / fit_n > bar_W * bar_W
    if not scattered.any():  # no ripple in any (as `_ripple_continuation`)
        return [None] * rows
    cycles = _ripple_cycles(detrended, fit_n, width)  # in each fitted part
    valid = scattered & (cycles >= _RIPPLE_CYCLES) & (cycles <= fit_n / 4.0)
    u = x / fit_n[:, None]
    omega = 2.0 * np.pi * cycles
    coef, rms_W = _fit_ripples(fit, inside, u, omega, valid)
    a_W, b_W, c_W, e_W = coef[:, 2], coef[:, 3], coef[:, 4], coef[:, 5]
    amplitude2 = a_W * a_W + b_W * b_W
    valid &= np.sqrt(amplitude2 / 2.0) > bar_W
    omega += (a_W * e_W - b_W * c_W) / np.where(valid, amplitude2, 1.0)
    u_tail = (np.arange(tail_width, dtype=np.float64)[None, :] + fit_n[:, None] - centre) / fit_n[
        :, None
    ]
    angle = omega[:, None] * u_tail
    carried = (
        coef[:, 0:1]
        + coef[:, 1:2] * u_tail
        + a_W[:, None] * np.sin(angle)
        + b_W[:, None] * np.cos(angle)
    )
    return [(carried[i, : tail_n[i]], float(rms_W[i])) if valid[i] else None for i in range(rows)]


def _fft_length(n: int) -> int:
    """The power of two at or above `n`: the periodogram's zero-padded length. A few
    lengths, each planned once by numpy's FFT (its plans are cached; a new length per
    cruise was planned per call, which cost more than the transform)."""
    return 1 << max(0, n - 1).bit_length()


def _ripple_cycles(detrended: np.ndarray, fit_n: np.ndarray, width: int) -> np.ndarray:
    """The ripple's cycles in each row's fitted part: the strongest peak of the periodogram
    of the detrended rows (zero-padded to 4x the widest or more, a power of two:
    `_fft_length`), interpolated by a parabola through it and its neighbours."""
    rows = detrended.shape[0]
    pad = _fft_length(4 * width)
    spectrum = np.abs(np.fft.rfft(detrended, pad, axis=1))
    spectrum[:, 0] = 0.0
    peak = spectrum.argmax(axis=1)
    at = np.arange(rows)
    inner = (peak >= 1) & (peak < spectrum.shape[1] - 1)
    left = spectrum[at, np.maximum(peak - 1, 0)]
    mid = spectrum[at, peak]
    right = spectrum[at, np.minimum(peak + 1, spectrum.shape[1] - 1)]
    curve = left - 2.0 * mid + right
    shift = np.where(
        inner & (curve < 0), 0.5 * (left - right) / np.where(curve < 0, curve, -1.0), 0.0
    )
    return (peak + shift) * fit_n / pad


def _fit_ripples(
    fit: np.ndarray, inside: np.ndarray, u: np.ndarray, omega: np.ndarray, valid: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares coefficients of the columns 1, u, sin w0 u, cos w0 u, u sin w0 u,
    u cos w0 u on each row of `fit` (its values where `inside`; `omega`: w0 per row), and
    the rms of each fit's residual [W]. Rows not `valid` are not solved for; a row whose
    solve fails is marked not valid (in place)."""
    rows, width = fit.shape
    design = np.empty((rows, 6, width))
    design[:, 0] = inside
    design[:, 1] = u
    angle = omega[:, None] * u
    np.sin(angle, out=design[:, 2])
    np.cos(angle, out=design[:, 3])
    design[:, 2:4] *= inside[:, None, :]
    np.multiply(u[:, None, :], design[:, 2:4], out=design[:, 4:6])
    gram = np.einsum("sij,skj->sik", design, design)
    gram[~valid] = np.eye(6)  # not solved for: no ripple there
    rhs = np.einsum("sij,sj->si", design, fit)
    try:
        coef = np.linalg.solve(gram, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:  # a degenerate window: each solved alone, it left out
        coef = np.full((rows, 6), np.nan)
        for i in range(rows):
            try:
                coef[i] = np.linalg.solve(gram[i], rhs[i])
            except np.linalg.LinAlgError:
                valid[i] = False
    resid = fit - np.einsum("si,sij->sj", coef, design)
    fit_n = inside.sum(axis=1)
    return coef, np.sqrt(np.einsum("ij,ij->i", resid, resid) / fit_n)
