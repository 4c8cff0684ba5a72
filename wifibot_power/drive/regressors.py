"""A window's speed regressors from its run's bins (windows.py): the speed at the window's
edges and the inertial terms from them, the noise they carry and its correction, and |v| and
|yaw rate| with the noise around a true 0 taken out.

- The inertial terms need a v, and a differentiated quantized speed is mostly noise. The
  window mean of a v is exactly the change of v^2/2 over the window divided by its duration
  (d(v^2/2)/dt = a v), so only the speed at the window's two edges is needed
  (`edge_speeds`: Richardson's extrapolation of box means, exact for a cubic speed), with the
  attenuation its noise brings corrected for (`calibrated`). Its sign splits speeding up
  (a v > 0) from braking (a v < 0), reversing included (v^2 does not care about the
  direction).
- |mean| rather than mean |.| for |v| and |yaw rate|: the noise left around a true 0 is taken
  out of the square (`_denoised_abs`).
"""

from __future__ import annotations

import numpy as np

from wifibot_power.drive.stats import DriveStats

#: The speed at a window's edge (`edge_speeds`): Richardson's combination of the means over
#: `EDGE_SAMPLES` samples (at least one bin) on each side and over twice as many,
#: (4 A(w) - A(2w)) / 3, which cancels the box mean's curvature error (A(w) = v + v'' w^2 / 24
#: + ...; the interface value of Colella & Woodward's piecewise parabolic method, J. Comput.
#: Phys. 54, 1984, Eq. 1.6, at 20 Hz: (7 (s_-1 + s_+1) - (s_-2 + s_+2)) / 12). A plain mean over
#: 2 bins a side (200 ms at 20 Hz) smeared the speed profile's corners into the neighbouring
#: windows, where the power has no inertial share: a regressor smoother than its response, the
#: effective mass 0.29 kg (1.6 standard errors) high on the simulator with exact speeds, 0.04
#: with this. The edges' noise is then corrected for (`calibrated`), not smoothed away.
EDGE_SAMPLES = 1.0
#: The speed noise estimate (`speed_noise_per_sample`) leaves out second differences beyond this
#: many of its own deviations (corners of the speed profile, reversing), iterated `CLIP_ROUNDS`
#: times: white noise loses 0.006% of its samples and 0.1% of its variance so.
CLIP_DEVIATIONS = 4.0
CLIP_ROUNDS = 4


def inertial_regressors(
    stats: DriveStats, n: int, count: int, mean_speed: np.ndarray, sample_noise_mps: float
) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
    """Each of a run's `count` windows of `n` bins: its mean of (a v)+ and (a v)- [m^2/s^3]
    (a current proxy: of (a sign v)+ and (a sign v)- [m/s^2]) from the speed at its edges
    (`edge_speeds`, `_speeding_and_braking`), corrected for the edges' noise (`calibrated`),
    and the two columns' reliabilities (`reliability`: the share of each column's sum of
    squares that is not noise; the lag search takes the rest out: gram.py `noise_share`)."""
    speed = stats.speed_mps
    half = edge_half_bins(stats.samples_per_bin)
    edges = np.arange(count + 1) * n
    edge_speed = edge_speeds(speed, edges, half)
    weights, centres = edge_kernel(half)
    edge_noise_mps = sample_noise_mps * np.sqrt(
        sample_gain(weights, centres, stats.samples_per_bin)
    )
    # the phases' trapezoid of a step run (stats.speed_from_phases) is exact by construction;
    # a measured speed whose noise reads 0 (quantized: some of BorealTC's, EUC_core's) is not
    exact = stats.speed_from_phases
    if exact:
        edge_speed = within_neighbours(edge_speed, speed, edges, half)
    # power: d(v^2/2)/dt = a v; a current proxy's force form: d|v|/dt = a sign(v) (terms.py)
    kinetic = np.abs if stats.current_proxy else _half_square
    # whether a window speeds up or brakes, from its neighbours' mean speeds over the bins
    # its own edge speeds do not use: the same samples on both sides would correlate the
    # choice with the edges' noise (a cruise's window whose start edge reads high is called
    # braking and gets a negative change: braking 1.2 standard errors low on the simulator,
    # 0.8 with this; the effective mass 1.2 high, 1.0)
    trim = min(2 * half, n - 1)
    blocks = speed[: count * n].reshape(count, n)
    neighbours = (
        np.square(row_means(blocks[:, trim:])),  # a window without its first bins: "after"
        np.square(row_means(blocks[:, : n - trim])),  # without its last bins: "before"
    )
    window_s = n * stats.bin_s
    noise_up, noise_down = inertial_noise_var(
        edge_speed, edge_noise_mps, window_s, power_form=not stats.current_proxy
    )
    av_up, av_down = _speeding_and_braking(
        edge_speed, mean_speed, window_s, kinetic, neighbours, own_sign=exact
    )
    return calibrated(av_up, av_down, noise_up, noise_down)


def within_neighbours(
    edge_speed: np.ndarray, speed_mps: np.ndarray, edges: np.ndarray, half: int
) -> np.ndarray:
    """Each edge speed [m/s] kept between the means of the `half` bins on its two sides
    (unchanged where a side is missing: a run's ends, a drop-out). PPM's monotonicity
    constraint: an interface value lies between its neighbouring cell means (Colella &
    Woodward, J. Comput. Phys. 54, 1984, Sec. 1, the limited slopes of Eq. 1.8; Colella &
    Sekora, J. Comput. Phys. 227, 2008, Sec. 2). `edge_speeds`' extrapolation, exact for a
    smooth speed, overshoots at a step: a step run without a stopping phase (the paper's ideal
    robot, `speed_from_phases`) drops from its cruise speed to 0 inside a bin, and the edge
    next to it read up to 0.35 m/s beyond both sides at 0.9 m/s, a speeding-up share in a
    cruise window. For an exact speed only (the trapezoid): with noise, the clip would change
    the edges' noise, which `calibrated` takes as a linear combination's."""
    sums = running_sums(speed_mps)
    before = _span_means(speed_mps, edges - half, edges, sums)
    after = _span_means(speed_mps, edges, edges + half, sums)
    low, high = np.minimum(before, after), np.maximum(before, after)
    return np.where(np.isfinite(low + high), np.clip(edge_speed, low, high), edge_speed)


def _window_abs(bins: np.ndarray, mean: np.ndarray, noise: float, bin_noise: float) -> np.ndarray:
    """A window's mean |x| from its bins (a row each): |mean| denoised (`_denoised_abs`, the
    window mean's noise `noise`), except in a window where x changes sign (reversing, a spin
    turned the other way: its bins reach beyond 3 deviations of a bin's noise, `bin_noise`,
    on both sides of 0), where |mean| would cancel the two directions: there the mean of the
    bins' own denoised |x|. (With the window's noise taken for a bin's, sqrt(10) too small
    at 20 Hz, two thirds of the straight windows were read as turning both ways and their
    |yaw rate| as the mean of their bins' |noise|: 0.0021 rad/s for a true 0, times 25-60
    N m of turning in every straight window, which the drivers' step paid: drive_on_W -0.90
    standard errors on the simulator at field realism, 200 seeds, inside its 95% interval in
    90%.)"""
    reach = 3.0 * max(bin_noise, 1e-12)
    high, low = _row_extremes(bins)
    flips = (high > reach) & (low < -reach)
    out = _denoised_abs(mean, noise)
    if flips.any():
        out[flips] = _denoised_abs(bins[flips], bin_noise).mean(axis=1)
    return out


def _row_extremes(bins: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each row's largest and smallest value (NaN where it holds one), as `max(axis=1)` and
    `min(axis=1)` give them, a column at a time: numpy's reduction over a short last axis
    (a window's 10 bins) is ~2x slower than these few passes over the rows."""
    high, low = bins[:, 0].copy(), bins[:, 0].copy()
    for k in range(1, bins.shape[1]):
        np.maximum(high, bins[:, k], out=high)
        np.minimum(low, bins[:, k], out=low)
    return high, low


def row_means(bins: np.ndarray) -> np.ndarray:
    """Each row's mean, bit for bit `bins.mean(axis=1)` of float64 rows (a window's bins) of
    any layout, a
    few passes over the columns instead of a call of numpy's sum per row (~3x slower for
    rows of 10). numpy sums a row of 8 to 128 values pairwise with 8 accumulators (value j
    in accumulator j mod 8, those added as ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7)),
    then the values past the last whole 8 in turn; fewer than 8 in turn), onto 0, then
    divides by the count: the same additions here, in the same order
    (tests/test_drive_fast_paths.py holds the two equal). Other rows: numpy's mean."""
    n = bins.shape[1] if bins.ndim == 2 else 0
    # numpy sums a row pairwise only where its values are adjacent in memory (a row-major
    # array's rows); other layouts (F-ordered, transposed) it sums in sequence: its own mean
    if not 1 <= n <= 128 or bins.dtype != np.float64 or bins.strides[1] != bins.itemsize:
        return bins.mean(axis=1)
    column = [bins[:, k] for k in range(n)]
    if n < 8:
        total = np.add(0.0, column[0])  # (numpy's: 0 + the first, then the rest in turn)
        for k in range(1, n):
            total += column[k]
    else:
        whole = n - n % 8
        acc = column[:8]
        for start in range(8, whole, 8):
            acc = [acc[j] + column[start + j] for j in range(8)]
        total = acc[0] + acc[1]
        total += acc[2] + acc[3]
        right = acc[4] + acc[5]
        right += acc[6] + acc[7]
        total += right
        for k in range(whole, n):
            total += column[k]
        np.add(0.0, total, out=total)  # (onto numpy's initial 0: -0.0 sums to +0.0)
    total /= n
    return total


def row_shares(flags: np.ndarray) -> np.ndarray:
    """Each row's share of True, bit for bit `flags.mean(axis=1)` of a bool array (its sum
    of 0.0 and 1.0 is a whole number whatever the order: the count over the row's length),
    counted a column at a time (~4x faster for rows of 10)."""
    n = flags.shape[1]
    if not 1 <= n <= 255:
        return flags.mean(axis=1)
    as_bytes = flags.view(np.uint8)
    count = as_bytes[:, 0].copy()
    for k in range(1, n):
        count += as_bytes[:, k]
    return count / n


def _denoised_abs(mean: np.ndarray, noise: float) -> np.ndarray:
    """|x| of a window mean x whose noise has standard deviation `noise` s: sqrt(max(x^2 - s^2,
    0)) - sqrt(2) `ZERO_READING` s exp(-x^2 / 2 s^2). The square root is a moment correction
    (E[x^2] = |true|^2 + s^2), which leaves a true |x| >> s as it is but reads a true 0 as
    0.342 s on average (`max` keeps only the noise's large draws). The second part takes that
    out where x is within a few s of 0 (E[exp(-z^2/2)] = 1/sqrt(2) for a standard normal z,
    so a true 0 reads 0 on average) and vanishes beyond (3 s: 0.04 s): a window that does not
    turn (most of a robot's: driving straight) has |yaw rate| 0 on average, a window driving
    has its |v|. Read as 0.342 s, the straight windows' |yaw rate| (0.0006 rad/s on the
    simulator at field realism) times 25-60 N m was turning power in every straight window,
    which the drivers' step paid: drive_on_W 0.16 W low, inside its 95% interval in 172 of
    200 seeds (180 with this; a constant shift, 0.342 s everywhere, took 0.342 s off every
    moving window's |v| too and pushed the 6.5 Hz row's drive_on_W as far the other way). A
    window whose true |x| is 0 may read below 0: an estimate unbiased at 0 of a quantity
    >= 0 is."""
    root = np.sqrt(np.maximum(np.square(mean) - noise * noise, 0.0))
    if noise <= 0:
        return root
    return root - np.sqrt(2.0) * ZERO_READING * noise * np.exp(-np.square(mean / noise) / 2.0)


#: E[sqrt(max(z^2 - 1, 0))] for a standard normal z (`_denoised_abs`): 0.3422 by 4 million
#: draws (tests/test_drive_edges.py checks it to 3 digits)
ZERO_READING = 0.342


def _half_square(speed_mps: np.ndarray) -> np.ndarray:
    """v^2 / 2 [m^2/s^2]: its rate of change is a v."""
    return np.square(speed_mps) / 2.0


def _speeding_and_braking(
    edge_speed: np.ndarray,
    mean_speed: np.ndarray,
    window_s: float,
    kinetic=_half_square,
    neighbours: tuple[np.ndarray, np.ndarray] | None = None,
    own_sign: bool = False,
) -> tuple[np.ndarray, ...]:
    """Each window's mean of (a v)+ and (a v)- [m^2/s^3]. Its size is the change of v^2/2
    between the speeds at its edges over its duration (d(v^2/2)/dt = a v, exact whatever
    happens inside), all speeding up or all braking when the speed keeps its sign; a window
    where the speed changes sign (reversing through 0) brakes from v_start^2/2 to 0 and
    speeds up from 0 to v_end^2/2. Whether a window speeds up or brakes is read from its
    neighbours' mean speeds (v^2 after against before), not from the sign of its own noisy
    change: split by its own sign, the edges' noise in a cruise would be rectified into both
    columns, biasing both coefficients (seen on the simulator at 6.5 Hz: braking 10% low).
    `neighbours`: the squared mean speeds of each window without its first and without its
    last edge bins, so that the call shares no sample with the edges (run_windows).
    `own_sign`: the speed is exact (the phases' trapezoid of a step run), so each window
    goes by the sign of its own change, which no noise makes. The neighbours' rule
    fails where the speed turns within a window's length: in the paper's 1 m steps at 0.9 m/s
    (0.9 s up, 0.5 s cruise, a stop) a window ending its ramp was called braking, its next
    window holding the stop, and its speeding up went into the braking column with the wrong
    sign (the drive model's v^2 term 0.49 W/(m/s)^2 for the simulator's 0 on sample_logs,
    its cruise 0.14 W high at 0.9 m/s; docs/drive-model.md, "The paper's step runs"). A
    measured speed keeps the neighbours' rule: a window's own sign beyond 3 standard
    deviations of its noise moved the real logs' held-out errors both ways (F1/10 2.3 ->
    4.1%, EUC_core mten4's median 21.9 -> 31.3%, Storvild 87 -> 79%), no clear gain.
    `kinetic` is the quantity differentiated: v^2/2 (power, a v), or |v| (a current proxy's
    force form, a sign(v) [m/s^2]: windows.run_windows)."""
    start, end = edge_speed[:-1], edge_speed[1:]
    half_change = kinetic(end) - kinetic(start)
    crosses = start * end < 0
    square = np.square(mean_speed)
    after_sq, before_sq = neighbours if neighbours is not None else (square, square)
    after = np.concatenate((after_sq[1:], square[-1:]))
    before = np.concatenate((square[:1], before_sq[:-1]))
    rising = np.where(np.isfinite(after - before), after - before, half_change) > 0
    if own_sign:
        rising = half_change > 0
    up = np.where(crosses, kinetic(end), np.where(rising, half_change, 0.0))
    down = np.where(crosses, -kinetic(start), np.where(rising, 0.0, half_change))
    return up / window_s, down / window_s


def _edge_means(
    speed: np.ndarray,
    edges: np.ndarray,
    half: int,
    sums: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """The mean of the `half` bins on either side of each edge (fewer at a run's ends); NaN
    when one of them is a drop-out (`sums`: as `_span_means`')."""
    return _span_means(speed, edges - half, edges + half, sums)


def running_sums(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The running count of undefined (non-finite) values and the running sum of the values
    (0 for the undefined), each from a leading 0: the count and the sum of values[i:j] are
    their differences at j and i."""
    total = np.empty(values.size + 1)
    total[0] = 0.0
    finite = np.isfinite(values)
    if finite.all():
        np.cumsum(values, out=total[1:])
        return np.zeros(values.size + 1, dtype=np.intp), total
    bad = np.empty(values.size + 1, dtype=np.intp)
    bad[0] = 0
    undefined = np.logical_not(finite, out=finite)
    # (into intp: numpy's default cast of the bools, to a fresh array, is ~8x slower)
    np.cumsum(undefined, out=bad[1:])
    # np.nan_to_num(values) of the few undefined values only (its passes over every value,
    # one per kind of non-finite, cost more than the cumulative sum)
    clean = values.copy()
    clean[undefined] = np.nan_to_num(values[undefined])
    np.cumsum(clean, out=total[1:])
    return bad, total


def _span_means(
    speed: np.ndarray,
    start: np.ndarray,
    stop: np.ndarray,
    sums: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """The mean of the bins from each `start` to its `stop` (clipped to the run); NaN when
    one of them is a drop-out or none is left. `sums`: the speed's `running_sums` when the
    caller has them (made once for several spans of one speed)."""
    bad, total = running_sums(speed) if sums is None else sums
    low = np.clip(start, 0, speed.size)
    high = np.clip(stop, 0, speed.size)
    mean = (total[high] - total[low]) / np.maximum(high - low, 1)
    return np.where((bad[high] - bad[low] == 0) & (high > low), mean, np.nan)


def edge_half_bins(samples_per_bin: float) -> int:
    """The bins on each side of an edge in the inner mean of `edge_speeds`: `EDGE_SAMPLES`
    samples, at least one bin (20 Hz: 1, 6.5 Hz: 4)."""
    return max(1, int(np.ceil(EDGE_SAMPLES / samples_per_bin - 1e-9)))


def edge_speeds(speed_mps: np.ndarray, edges: np.ndarray, half: int) -> np.ndarray:
    """The speed at each edge [m/s] from the bins' means: (4 A(2 half) - A(4 half)) / 3, A(w)
    the mean of the w bins centred on the edge (`EDGE_SAMPLES`: Richardson's extrapolation of
    the box mean to zero width, exact for a cubic speed; Colella & Woodward 1984, Eq. 1.6).
    Its weights: 7 / (12 half) on the inner 2 half bins, -1 / (12 half) on the outer ones
    (`edge_kernel`). NaN where a drop-out is among them."""
    sums = running_sums(speed_mps)  # (once for both means)
    inner = _edge_means(speed_mps, edges, half, sums)
    outer = _edge_means(speed_mps, edges, 2 * half, sums)
    return (4.0 * inner - outer) / 3.0


def edge_kernel(half: int) -> tuple[np.ndarray, np.ndarray]:
    """`edge_speeds`' weights and the centres of the bins they fall on [bins from the edge]."""
    centres = np.arange(-2 * half, 2 * half) + 0.5
    weights = np.where(np.abs(centres) < half, 7.0, -1.0) / (12.0 * half)
    return weights, centres


def sample_gain(weights: np.ndarray, centres: np.ndarray, samples_per_bin: float) -> float:
    """The variance of sum_k w_k bin_k over that of one sample's white noise: the sum of the
    squared weights the combination puts on the samples. A bin of a fast logger is the mean of
    its `samples_per_bin` samples: sum w^2 / samples_per_bin. A slow logger's bins interpolate
    linearly between samples (stats.py `_held`): each weight spreads over the two samples
    around its bin by the hat function, averaged over 16 phases of the samples against the
    bins."""
    if samples_per_bin >= 1.0:
        return float(np.sum(np.square(weights)) / samples_per_bin)
    period = 1.0 / samples_per_bin  # [bins]
    phases = np.arange(16)[:, None, None] * period / 16.0
    first = np.floor((centres.min() - period) / period)
    middles = (first + np.arange(int(np.ptp(centres) / period) + 4))[None, :, None] * period
    hat = np.clip(1.0 - np.abs(centres[None, None, :] - middles - phases) / period, 0.0, None)
    on_samples = hat @ weights  # (phase, sample)
    return float(np.mean(np.sum(np.square(on_samples), axis=1)))


def window_gain(n: int, samples_per_bin: float) -> float:
    """The variance of a window's mean of `n` bins over that of one sample's white noise
    (`sample_gain` of the weights 1/n): 1 / (n samples_per_bin) for a fast logger's bins;
    for a slow logger's, whose bins interpolate between samples, the window's hat weights
    spread over more samples than its span holds: 6.5 Hz, 10 bins of 50 ms, 0.265 (0.2655 by
    200,000 white samples interpolated so) against 1 / 3.25 = 0.308."""
    return sample_gain(np.full(n, 1.0 / n), np.arange(n) + 0.5, samples_per_bin)


def speed_noise_per_sample(speed_mps: np.ndarray, samples_per_bin: float) -> float:
    """The white noise of one speed sample [m/s] from the bins: the mean square of their
    second differences (over one sample period at least: a straight ramp cancels) over its
    `sample_gain`, leaving out those beyond `CLIP_DEVIATIONS` of the estimate (a corner of the
    speed profile, a reversal), `CLIP_ROUNDS` times. A mean of squares, not a median: an
    encoder's quantized speed (2 cm/s steps over 1 cm/s noise) has successive differences of
    0 or one step, whose median is a step whatever the noise (stats.py's estimate, 0.021 m/s
    for the simulator's 0.0115); quantization adds its step^2 / 12 to the variance, which a
    mean of squares keeps (Widrow & Kollar, "Quantization Noise", 2008, Ch. 4)."""
    lag = 1 if samples_per_bin >= 1.0 else max(1, int(round(1.0 / samples_per_bin)))
    if speed_mps.size <= 2 * lag:
        return 0.0
    # (v[i + 2 lag] - 2 v[i + lag]) + v[i], the operations of the expression, in one array
    second = np.multiply(speed_mps[lag:-lag], 2.0)
    np.subtract(speed_mps[2 * lag :], second, out=second)
    np.add(second, speed_mps[: -2 * lag], out=second)
    finite = np.isfinite(second)
    square = np.square(second, out=second) if finite.all() else np.square(second[finite])
    if not square.size:
        return 0.0
    gain = sample_gain(np.array([1.0, -2.0, 1.0]), np.array([0.0, lag, 2.0 * lag]), samples_per_bin)
    mean_square = float(np.mean(square))
    kept = square.size  # the values the mean is over (all, then those inside)
    for _ in range(CLIP_ROUNDS):
        inside = square <= CLIP_DEVIATIONS**2 * mean_square
        count = int(np.count_nonzero(inside))
        if count == kept:
            # the same values as the last mean (a lower mean keeps fewer: those inside only
            # shrink), so the same mean, and every round after: done
            break
        kept = count
        mean_square = float(np.mean(square[inside])) if count else 0.0
    return float(np.sqrt(mean_square / gain))


def calibrated(
    av_up: np.ndarray,
    av_down: np.ndarray,
    noise_var_up: np.ndarray,
    noise_var_down: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
    """The speeding-up and braking regressors of one run times their reliability ratio,
    lambda = 1 - sum(noise variance) / sum(regressor^2) over the windows where each acts,
    clipped to [0, 1]: regression calibration, E[x | x_observed] ~ lambda x_observed, whose
    least squares is consistent where the noisy regressor's is biased towards 0 (errors in
    variables: Carroll, Ruppert, Stefanski & Crainiceanu, "Measurement Error in Nonlinear
    Models", 2nd ed., 2006, Sec. 2.2 and Ch. 4; Fuller, "Measurement Error Models", 1987,
    Sec. 1.1). The noise is the edges' (`inertial_noise_var`); without it the effective mass
    came out 0.31 kg (1.6 standard errors) low on the simulator at field realism, braking
    0.26 kg (1.7; 100 seeds). Returns the two columns and their ratios (`reliability`)."""
    reliable = (reliability(av_up, noise_var_up), reliability(av_down, noise_var_down))
    return av_up * reliable[0], av_down * reliable[1], reliable


def reliability(values: np.ndarray, noise_var: np.ndarray) -> float:
    """A noisy column's reliability ratio (`calibrated`): 1 - sum(noise variance) / sum(value^2)
    over the windows where it acts (non-zero), clipped to [0, 1]; 1 where it never acts. The
    share of the column's sum of squares that is signal: its expected sum of squares is the
    true column's plus the noise's (Fuller 1987, Sec. 1.1: the reliability ratio kappa_xx)."""
    acting = np.isfinite(values) & (values != 0)
    total = float(np.sum(np.square(values[acting])))
    noise = float(np.sum(noise_var[acting]))
    return min(max(1.0 - noise / total, 0.0), 1.0) if total > 0 else 1.0


def inertial_noise_var(
    edge_speed: np.ndarray, edge_noise_mps: float, window_s: float, power_form: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """The noise variance each window's speeding-up and braking regressor takes from the
    noise (standard deviation `edge_noise_mps`, s) of its edge speeds (`_speeding_and_
    braking`): v^2/2 at an edge read as (v + e)^2/2 is off by v e + e^2/2, so a window's change
    over `window_s` T has variance (s^2 (v_start^2 + v_end^2) + s^4) / T^2, with v^2 = the
    read v^2 - s^2; a current proxy's |v| (`power_form` False) is off by about e: 2 s^2 / T^2.
    A window through 0 (reversing) has one edge in each column. Returns the variances where
    the window is (up, down) as if it were all in each column: `calibrated` takes those of
    the windows where each column acts."""
    s2 = edge_noise_mps**2
    if power_form:
        edge_var = np.maximum(s2 * np.square(edge_speed) - s2 * s2 / 2.0, 0.0)
    else:
        edge_var = np.full(edge_speed.shape, s2)
    start, end = edge_var[:-1], edge_var[1:]
    crosses = edge_speed[:-1] * edge_speed[1:] < 0
    both = start + end
    t2 = window_s**2
    return np.where(crosses, end, both) / t2, np.where(crosses, start, both) / t2


def gradient(values: np.ndarray, spacing: float) -> np.ndarray:
    """`np.gradient(values, spacing)` of 2 or more values on an even grid: central differences
    inside, (v[i + 1] - v[i - 1]) / (2 spacing), one-sided at the two ends, the same
    operations in the same order (numpy's own function spends more on checking its
    arguments than on the run's few thousand windows)."""
    out = np.empty_like(values, dtype=np.float64)
    np.subtract(values[2:], values[:-2], out=out[1:-1])
    out[1:-1] /= 2.0 * spacing
    out[0] = (values[1] - values[0]) / spacing
    out[-1] = (values[-1] - values[-2]) / spacing
    return out
