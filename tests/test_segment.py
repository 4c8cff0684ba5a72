"""Segmentation: the generic change-point layer on hand-made signals, motion phases scored
against the simulator's truth, and the `wbpower segment` command.

Accuracy targets (issue 3): boundary error <= 20 ms median and <= 50 ms worst over the
default speed grid, at the default and at a noisier analyser, with each effect of causes.md.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from wifibot_power.changepoint import (
    LevelParams,
    _centred_power_sum,
    _solve,
    best_split,
    best_splits,
    block_means,
    detect_levels,
    jump_sd_factor,
    jump_statistic_W,
    median,
    peaks,
    percentile,
    robust_sigma_W,
    sliding_max,
)
from wifibot_power.changepoint import splits as changepoint_splits
from wifibot_power.changepoint import stacked as changepoint_stacked
from wifibot_power.cli import app
from wifibot_power.errors import LogError
from wifibot_power.io.writer import format_log, write_log
from wifibot_power.phases import Phase, Spike
from wifibot_power.run import Run, RunMeta
from wifibot_power.segment import (
    MotionParams,
    _above_off_edges,
    _line,
    _locate_steps,
    _longest_runs,
    _may_hold_two_levels,
    _mean,
    _most_within,
    _phases,
    _search_steps,
    _stands_above,
    _start_spikes,
    _std,
    _Step,
    _time_at,
    _Trace,
    segment_run,
)
from wifibot_power.simulate import EFFECTS, SimConfig, simulate_runs

# -- generic layer -------------------------------------------------------------------------


def test_block_means_by_hand() -> None:
    # (1+2+3)/3 = 2, (4+5+6)/3 = 5; the partial block [7] is dropped
    assert_allclose(block_means(np.array([1.0, 2, 3, 4, 5, 6, 7]), 3), [2.0, 5.0])


def test_robust_sigma_ignores_jumps() -> None:
    rng = np.random.default_rng(1)
    y = rng.normal(0.0, 0.7, 20_000)
    y[[2000, 7000, 12000, 15000, 18000]] += 50.0  # five big jumps (and back)
    # the MAD of 20k differences estimates sigma to ~1% (efficiency 37%): 3% is > 3 sd
    assert_allclose(robust_sigma_W(y), 0.7, rtol=0.03)


def test_jump_statistic_is_the_step_and_ignores_trends_and_curvature() -> None:
    i = np.arange(100, dtype=np.float64)
    step = np.where(i >= 50, 2.5, 0.0)
    # a step of 2.5 at block 50: both lines are flat, J[50] = 2.5 exactly
    assert_allclose(jump_statistic_W(step, 10)[50], 2.5, atol=1e-12)
    # a straight trend is fitted exactly on both sides: no jump anywhere
    assert_allclose(jump_statistic_W(0.3 * i + step, 10)[50], 2.5, atol=1e-9)
    assert np.nanmax(np.abs(jump_statistic_W(0.3 * i, 10))) < 1e-9
    # x^2 about any boundary is an even part (same bias on both sides) plus a line: J = 0
    assert np.nanmax(np.abs(jump_statistic_W(0.01 * i**2, 10))) < 1e-9


def test_jump_statistic_is_its_definition_at_every_boundary() -> None:
    # the prefix-sum form (each line's value at the boundary from its centre, +-w/2) against
    # two numpy polyfits per boundary, on random walks, every boundary (agree to ~1e-12 W
    # on values of ~10 W; NaN where a line does not fit)
    rng = np.random.default_rng(18)
    for trial in range(6):
        n, w = int(rng.integers(20, 120)), int(rng.integers(2, 9))
        y = 10.0 + rng.normal(0.0, 1.0, n).cumsum()
        jump = jump_statistic_W(y, w)
        for k in range(n + 1):
            if k < w or k > n - w:
                assert np.isnan(jump[k]), (trial, k)
                continue
            before = np.polyval(np.polyfit(np.arange(k - w, k), y[k - w : k], 1), k - 0.5)
            after = np.polyval(np.polyfit(np.arange(k, k + w), y[k : k + w], 1), k - 0.5)
            assert_allclose(jump[k], after - before, atol=1e-9), (trial, k)


def _jump_two_sides(y: np.ndarray, w: int) -> np.ndarray:
    """`jump_statistic_W` as it was written before the two sides shared their lines
    (fcbcdd0): the lines before and after each boundary fitted apart, by slices of the
    prefix sums."""
    n = y.size
    out = np.full(n + 1, np.nan)
    if w < 2 or n < 2 * w:
        return out
    yc = y - np.add.reduce(y) / n
    j = np.arange(n, dtype=np.float64)
    s0 = np.concatenate(([0.0], yc.cumsum()))
    s1 = np.concatenate(([0.0], (j * yc).cumsum()))
    count = n - 2 * w + 1
    s_xx = w * (w * w - 1) / 12.0

    def line_at_boundary(first: int) -> np.ndarray:
        stop = first + count
        sum_y = s0[first + w : stop + w] - s0[first:stop]
        sum_jy = s1[first + w : stop + w] - s1[first:stop]
        centre = first + (w - 1) / 2.0
        mean_j = np.arange(centre, centre + count)
        slope = (sum_jy - mean_j * sum_y) / s_xx
        return sum_y / w + slope * ((w / 2.0) if first == 0 else (-w / 2.0))

    out[w : n - w + 1] = line_at_boundary(w) - line_at_boundary(0)
    return out


def test_jump_statistic_sharing_its_lines_is_the_two_sides_bit_for_bit() -> None:
    # each line fitted once (the one before boundary k is the one after boundary k - w):
    # the same doubles as fitting the two sides apart, at every boundary, on random walks,
    # rounded (ties), constant and offset traces, the shortest windows and series
    rng = np.random.default_rng(19)
    finite = 0
    for trial in range(500):
        n, w = int(rng.integers(0, 400)), int(rng.integers(0, 40))
        y = 23.0 + rng.normal(0.0, 1.0, n).cumsum() * rng.uniform(0.0, 2.0)
        if trial % 5 == 0:
            y = np.round(y, 1)
        if trial % 7 == 0:
            y = np.full(n, 12.5)
        if trial % 11 == 0:
            y = y + 1e4
        if trial % 13 == 0:
            n, w = 2 * w, w  # a single boundary
            y = y[:n] if y.size >= n else 23.0 + rng.normal(0.0, 1.0, n)
        got, want = jump_statistic_W(y, w), _jump_two_sides(y, w)
        assert np.array_equal(got, want, equal_nan=True), (trial, n, w)
        finite += int(np.isfinite(want).sum())
    assert finite > 10_000


def _passes_two_levels(y10: np.ndarray, a: int, b: int, sigma10: float, bar_W: float) -> bool:
    """`_motion_doubts`'s two-levels test on the cruise [a, b) as it is written: its best
    split into flat pieces of a quarter or more, the difference of their means above max(6
    sd, twice the scatter left, `bar_W`)."""
    split = best_split(y10, a, b, 0, 0, (b - a) // 4)
    index = split.index - a
    sd = sigma10 * np.sqrt(1.0 / index + 1.0 / (b - a - index))
    scatter_W = np.sqrt(split.sse / (b - a))
    return abs(split.jump_W) > max(6.0 * sd, 2.0 * scatter_W, bar_W)


def test_two_level_splits_are_skipped_only_where_the_test_cannot_pass() -> None:
    """`_may_hold_two_levels` (no split made where it says False) against the test made in
    full on random cruises: flat, rippled, with a second level anywhere (inside the
    quarters or not), each bar dominating in turn (noise's 6 sd, the scatter, the swing's
    fraction), and cruises whose step sits a hair (1e-12) either side of the bar. Wherever
    the test passes the split is made; on most cruises that hold one level it is not."""
    rng = np.random.default_rng(21)
    passed = skipped = edge = 0
    for trial in range(400):
        spans, values = [], [rng.normal(23.0, 0.05, int(rng.integers(0, 30)))]
        at = values[0].size
        for _ in range(int(rng.integers(1, 6))):
            n = int(rng.integers(20, 900))
            i = np.arange(n)
            sigma = float(rng.choice([0.01, 0.05, 0.3]))
            cruise = 26.0 + rng.normal(0.0, sigma, n)
            if rng.uniform() < 0.4:  # a ripple of 0.1-2 cycles per 100 means
                cruise += rng.uniform(0.0, 1.0) * np.sin(i * rng.uniform(0.001, 0.12))
            if rng.uniform() < 0.5:  # a second level, from anywhere in the cruise
                cruise[int(rng.integers(1, n)) :] += rng.normal(0.0, 10.0 * sigma)
            spans.append((at, at + n))
            values += [cruise, rng.normal(23.0, 0.05, int(rng.integers(0, 30)))]
            at += n + values[-1].size
        y10 = np.concatenate(values)
        sigma10 = float(rng.choice([0.005, 0.05, 0.3]))
        fraction_W = float(rng.choice([0.0, 0.1, 0.5, 2.0]))
        if trial % 4 == 0:  # the swing's fraction a hair below or above the step
            a, b = spans[0]
            jump = abs(best_split(y10, a, b, 0, 0, (b - a) // 4).jump_W)
            fraction_W = jump * (1.0 - 1e-12 if trial % 8 == 0 else 1.0 + 1e-12)
            sigma10 = 0.0 if trial % 3 else sigma10
        may = _may_hold_two_levels(y10, spans, sigma10, fraction_W)
        assert len(may) == len(spans)
        for k, (a, b) in enumerate(spans):
            passes = _passes_two_levels(y10, a, b, sigma10, fraction_W)
            assert may[k] or not passes, (trial, k)
            passed += passes
            skipped += not may[k]
            edge += trial % 8 == 0 and k == 0 and passes
    # the test passed often (so a bound that skipped them would fail here), the split was
    # skipped often (so the fast path is taken), and the hair-above cases were kept
    assert passed > 100 and skipped > 300 and edge > 5, (passed, skipped, edge)


def test_two_level_bound_holds_at_high_power() -> None:
    """The bound's squares are taken about each cruise's exact mean: about the rounded
    mean they exceed the true SST by (sum of the centred values)² / n, which at 1e7 W (an
    ulp of 2e-9 W) beat the 1e-9 margins and skipped a split the test passes (the review's
    case: nine means at 1e7 W, thirty an ulp above, no noise, a bar of 1e-9 W)."""
    y10 = np.array([1e7] * 9 + [np.nextafter(1e7, np.inf)] * 30)
    assert _passes_two_levels(y10, 0, 39, 0.0, 1e-9)
    assert _may_hold_two_levels(y10, [(0, 39)], 0.0, 1e-9) == [True]
    rng = np.random.default_rng(8)
    for offset_W in (1e6, 1e7, 1e9):  # steps of a few ulps at large powers, either side
        for _ in range(40):
            n = int(rng.integers(20, 200))
            y10 = offset_W + np.spacing(offset_W) * rng.integers(0, 4, n).astype(np.float64)
            y10[int(rng.integers(1, n)) :] += np.spacing(offset_W) * rng.integers(0, 3)
            fraction_W = float(rng.choice([1e-9, 1e-6])) * offset_W / 1e7
            may = _may_hold_two_levels(y10, [(0, n)], 0.0, fraction_W)[0]
            assert may or not _passes_two_levels(y10, 0, n, 0.0, fraction_W)


def _start_spikes_in_full(
    run: Run, y: np.ndarray, block: int, sigma_b: float, steps: list[_Step]
) -> list[Spike]:
    """`_start_spikes` as written before it left out the tail's median where the first
    block stands below every bar (fcbcdd0): every step's bar made in full."""
    spikes = []
    dt = run.sample_period_s
    for step in steps:
        seg = y[step.t0 : step.t1]
        if seg.size < 20:
            continue
        tail = seg[seg.size // 2 :]
        x = np.arange(seg.size, dtype=np.float64)
        slope, tail_intercept = _line(tail)
        intercept = tail_intercept - slope * (seg.size // 2)
        excess = seg - (intercept + slope * x)
        tail_scatter_W = 1.4826 * float(np.median(np.abs(excess[seg.size // 2 :])))
        out = excess > 6.0 * max(sigma_b, tail_scatter_W) + 0.5
        if not out[0]:
            continue
        n_out = int(np.argmin(out)) if not out.all() else out.size
        i0, i1 = step.t0 * block, (step.t0 + n_out) * block
        above_J = float(np.sum(excess[:n_out]) * block * dt)
        if above_J < 0.01 * float(np.sum(seg)) * block * dt:
            continue
        spikes.append(
            Spike(
                t_start_s=_time_at(run, i0),
                duration_s=(i1 - i0) * dt,
                peak_W=float(run.power_W[i0:i1].max()),
                energy_above_level_J=above_J,
            )
        )
    return spikes


def test_start_spikes_without_the_tails_median_below_every_bar_are_in_full() -> None:
    """Steps whose first block stands below 6 sd + 0.5 W of the ramp's line skip the
    tail's median (the bar is at least that): the spikes are those of the bar made in full,
    on random ramps with and without a start spike, rippled tails whose scatter raises the
    bar past a spike, short accelerations, and spikes whose first block stands a hair
    (1e-9 W) either side of 6 sd + 0.5 W above the line (found in full when above)."""
    rng = np.random.default_rng(23)
    found = hair = above = 0
    for trial in range(300):
        block, period = int(rng.choice([1, 10])), 1e-4
        sigma_b = float(rng.choice([0.0, 0.02, 0.3]))
        # at the hair, the tail's scatter stays under sigma_b: the bar is 6 sd + 0.5 W
        noise_W = sigma_b / 4.0 if trial % 3 == 0 else sigma_b
        y = 23.0 + rng.normal(0.0, noise_W, 4000)
        steps = []
        for t0 in range(100, 3600, int(rng.integers(300, 900))):
            t1 = t0 + int(rng.integers(5, 250))
            i = np.arange(t1 - t0)
            y[t0:t1] += 0.5 + 0.02 * i
            if rng.uniform() < 0.3 and not (trial % 3 == 0 and t0 == 100):
                y[t0:t1] += rng.uniform(0.0, 3.0) * np.sin(i * 0.3)  # the tail's scatter
            if rng.uniform() < 0.5 or (trial % 3 == 0 and t0 == 100):
                y[t0 : t0 + int(rng.integers(2, 10))] += rng.uniform(2.0, 20.0)
            steps.append(_Step(t0=t0, t1=t1, t2=t1, t3=t1))
        first = steps[0]
        if trial % 3 == 0 and first.t1 - first.t0 >= 20:  # the first block at the hair
            seg = y[first.t0 : first.t1]
            slope, intercept = _line(seg[seg.size // 2 :])
            intercept -= slope * (seg.size // 2)
            y[first.t0] = intercept + 6.0 * sigma_b + 0.5 + (1e-9 if trial % 2 else -1e-9)
            hair += 1
        power = np.repeat(y, block)
        meta = RunMeta(run_id=f"r{trial}", mode="motion", sample_period_s=period)
        run = Run("r.csv", "wbpower-csv", meta, None, power)
        got = _start_spikes(run, y, block, sigma_b, steps)
        want = _start_spikes_in_full(run, y, block, sigma_b, steps)
        assert got == want, trial
        found += len(got)
        starts = [spike.t_start_s for spike in want]
        above += trial % 6 == 3 and _time_at(run, first.t0 * block) in starts
    # many spikes, and spikes found with their first block a hair above the least bar
    assert found > 100 and hair > 80 and above > 20, (found, hair, above)


def _peaks_by_definition(score: np.ndarray, threshold: float, separation: int) -> list[int]:
    """Local maxima over the centred window of 2 separation + 1 (NaN and beyond the ends
    -inf) above the threshold, then greedy from the largest, at least `separation` apart:
    every index tested with a sliding maximum, as `peaks` did before it gathered windows."""
    s = np.nan_to_num(score, nan=-np.inf)
    local = np.flatnonzero((s == sliding_max(s, 2 * separation + 1)) & (s > threshold))
    kept: list[int] = []
    for idx in local[np.argsort(-s[local], kind="stable")]:
        if all(abs(int(idx) - k) >= separation for k in kept):
            kept.append(int(idx))
    return sorted(kept)


def test_peaks_is_its_definition_with_few_or_many_above_the_threshold() -> None:
    rng = np.random.default_rng(4)
    for trial in range(400):
        n = int(rng.integers(1, 300))
        score = rng.normal(size=n)
        if trial % 3 == 0:
            score = np.round(score, 1)  # plateaus: equal neighbours
        if trial % 4 == 0:
            score[rng.integers(0, n, n // 5 + 1)] = np.nan
        # thresholds from below every score (the sliding path) to above most (the gather)
        threshold = float(rng.uniform(-3.0, 2.5))
        separation = int(rng.integers(1, 25))
        found = peaks(score, threshold, separation).tolist()
        assert found == _peaks_by_definition(score, threshold, separation), trial


def test_mean_sd_and_median_helpers_give_numpys_numbers() -> None:
    rng = np.random.default_rng(5)
    for n in (1, 2, 7, 8, 9, 127, 128, 129, 1000, 4097):
        x = rng.normal(23.0, 3.0, n)
        # bit for bit: the segmentation must not move when these replace numpy.mean / std
        assert _mean(x) == float(np.mean(x))
        assert _std(x) == float(np.std(x))
        assert median(x) == float(np.median(x))
    assert np.isnan(median(np.array([])))


def test_percentile_is_numpys_bit_for_bit() -> None:
    rng = np.random.default_rng(7)
    for trial in range(400):
        x = rng.normal(23.0, 3.0, int(rng.integers(1, 40 if trial % 2 else 5000)))
        if trial % 3 == 0:
            x = np.round(x, 1)  # ties
        for q in (0, 1, 50, 95, 99, 99.9, 100):
            assert percentile(x, q) == float(np.percentile(x, q)), (trial, q)
        # detect_levels takes the 1st and 99th together, numpy took them as a pair
        pair = np.percentile(x, [1, 99])
        assert (percentile(x, 1), percentile(x, 99)) == (float(pair[0]), float(pair[1]))


def test_longest_runs_cut_to_spans_are_each_spans_own() -> None:
    """The longest run of True in each span (and where it starts in it, the first of equal
    ones), from the runs of the whole mask cut to the spans: as if found in each span's
    own mask, by brute force."""
    rng = np.random.default_rng(8)
    longer = skipped = 0
    for trial in range(200):
        mask = rng.uniform(size=int(rng.integers(1, 300))) < rng.uniform(0.1, 0.9)
        spans = sorted(
            (int(a), int(a + rng.integers(0, 60)))
            for a in rng.integers(0, mask.size, int(rng.integers(0, 6)))
        )
        spans = [(a, min(b, mask.size)) for a, b in spans]
        # with `longer_than` (the doubts' 50 ms): a span that cannot hold a longer run
        # (no more Trues in all) may give (0, 0), any other its longest run
        longer_than = int(rng.integers(1, 12)) if trial % 2 else 0
        found = _longest_runs(mask, spans, longer_than=longer_than)
        for (a, b), (longest, at) in zip(spans, found, strict=True):
            best = (0, 0)
            for i in range(a, b):
                j = i
                while j < b and mask[j]:
                    j += 1
                if j - i > best[0] and (i == a or not mask[i - 1]):
                    best = (j - i, i - a)
            if best[0] > longer_than:
                assert (longest, at) == best, (trial, a, b)
                longer += longer_than > 0
            else:
                assert (longest, at) in ((0, 0), best), (trial, a, b)
                skipped += (longest, at) != best
    assert longer > 50 and skipped > 50, (longer, skipped)


def test_most_steps_within_a_duration_as_the_doubts_test_it() -> None:
    # the idle-in-motion doubt fires for k means when k * dt10 > 0.05: the stretches it
    # skips are those of at most `_most_within(0.05, dt10)` means, in doubles
    rng = np.random.default_rng(26)
    for step_s in [
        0.01,
        0.0102,
        0.001024,
        0.05,
        0.025,
        0.0125,
        0.06,
        1 / 3,
        *rng.uniform(1e-4, 0.07, 300),
    ]:
        k = _most_within(0.05, step_s)
        assert k * step_s <= 0.05 < (k + 1) * step_s, step_s
    assert _most_within(0.05, 0.01) == 5  # 5 x 0.01 is 0.05 in doubles: not over 50 ms


def test_above_off_edges_misses_no_score_the_doubts_would_keep() -> None:
    """The doubts look for peaks of the jump statistic only where `_above_off_edges`
    says one may stand more than the tolerance from every edge: wherever a score above the
    threshold stands that far (|edge - k| > tolerance in doubles, as the doubts test it),
    it says so; edges at fractional places, tolerances of 1.5 to 12 means, NaN scores,
    scores above the threshold right at the tolerance's reach."""
    rng = np.random.default_rng(27)
    kept = skipped = 0
    for trial in range(500):
        m = int(rng.integers(12, 400))
        score = np.abs(rng.normal(0.0, 1.0, m + 1))
        score[: int(rng.integers(0, 6))] = np.nan
        edges = sorted(rng.uniform(0, m, int(rng.integers(0, 8))) // 0.1 * 0.1)
        tolerance = float(rng.choice([1.5, 6.0, 0.06 / 0.0102, 12.0]))
        threshold = 2.0
        score[score > threshold] = 0.0
        # a score above the threshold near (or right at) some edge's reach
        if edges and trial % 2:
            edge = edges[int(rng.integers(len(edges)))]
            k = int(round(edge + rng.choice([-1.0, 1.0]) * (tolerance + rng.uniform(-1.0, 1.0))))
            if 0 <= k <= m:
                score[k] = 3.0
        k = np.arange(m + 1)
        nearest = (
            np.min(np.abs(np.array(edges)[None, :] - k[:, None]), axis=1)
            if edges
            else np.full(m + 1, np.inf)
        )
        wanted = bool(np.any((score > threshold) & (nearest > tolerance)))
        found = _above_off_edges(score, threshold, edges, tolerance)
        assert found or not wanted, trial
        kept += wanted
        skipped += not found
    assert kept > 50 and skipped > 100, (kept, skipped)


def test_phases_made_together_are_each_phases_own_numbers() -> None:
    """`_phases` (the run's period, samples and stamps looked up once) against each phase
    made on its own as before (fcbcdd0's `_phase`: numpy's mean and sum, `Run.time_at`,
    the run's end for its last sample's index), bit for bit: runs with and without time
    stamps, phases at the start, at the end and one sample long."""
    rng = np.random.default_rng(28)
    for trial in range(60):
        samples = int(rng.integers(2, 5000))
        period = float(rng.choice([1e-4, 1.024e-4, 0.001, 1 / 18]))
        power = rng.normal(23.0, 2.0, samples)
        stamps = None if trial % 2 else np.cumsum(rng.uniform(0.5, 1.5, samples)) * period
        meta = RunMeta(run_id="r", mode="motion", sample_period_s=period)
        run = Run("r.csv", "wbpower-csv", meta, stamps, power)
        cuts = sorted({0, samples, *rng.integers(0, samples, int(rng.integers(0, 12))).tolist()})
        if trial % 3 == 0 and samples > 2:
            cuts = sorted({*cuts, samples - 1})  # a last phase one sample long
        pieces = [
            (k, "cruise", a, b, float(rng.uniform()) if k % 2 else None)
            for k, (a, b) in enumerate(zip(cuts[:-1], cuts[1:], strict=True))
        ]

        want = [
            Phase(
                step=k,
                phase=name,
                i_start=a,
                i_end=b,
                t_start_s=_time_at(run, a),
                t_end_s=_time_at(run, b),
                mean_power_W=float(np.mean(power[a:b])),
                energy_J=float(np.sum(power[a:b]) * period),
                speed_mps=speed,
            )
            for k, name, a, b, speed in pieces
        ]
        assert _phases(run, pieces) == want, trial


def test_stands_above_is_any_window_maximum_over_its_level() -> None:
    """`_stands_above` (each window's maximum by one reduceat over the windows' edges)
    against each window's own maximum, windows reaching the end of the series or one
    value long, maxima a hair (1e-12 W) either side of the bar (less its 1e-6 W margin)."""
    rng = np.random.default_rng(24)
    outcomes = set()
    for trial in range(400):
        y10 = 23.0 + rng.normal(0.0, 0.05, int(rng.integers(5, 400)))
        cuts = np.sort(rng.choice(y10.size + 1, 2 * int(rng.integers(1, 5)), replace=False))
        windows = [(int(a), int(b)) for a, b in zip(cuts[::2], cuts[1::2], strict=True)]
        levels = rng.normal(23.0, 0.1, len(windows)).tolist()
        excess_W = 0.25
        if trial % 3 == 0:  # one window's maximum at the bar, a hair either side
            k = int(rng.integers(len(windows)))
            a, b = windows[k]
            y10[a:b] = np.minimum(y10[a:b], levels[k])
            side = 1e-12 if trial % 2 else -1e-12
            y10[int(rng.integers(a, b))] = levels[k] + excess_W - 1e-6 + side
        want = any(
            float(y10[a:b].max()) - level >= excess_W - 1e-6
            for (a, b), level in zip(windows, levels, strict=True)
        )
        assert _stands_above(y10, windows, levels, excess_W) == want, trial
        outcomes.add(want)
    assert outcomes == {True, False}


def test_idles_below_the_excess_everywhere_hold_no_stop_labelled_idle() -> None:
    """What `_hidden_stop_doubts` skips when no idle mean stands `min_excess_W` above its
    level (`_stands_above` False): the test in full (the running mean from the idle's
    start above its level by 6 sd of that mean and by `min_excess_W`) never passes there,
    on idles of noise, of a slow rise, and of a step up at any place, sd small or large."""
    rng = np.random.default_rng(25)
    params = MotionParams()
    fired = skipped = 0
    for trial in range(600):
        n = int(rng.integers(1, 300))
        sigma10 = float(rng.choice([1e-4, 0.01, 0.05]))
        window = rng.normal(0.0, sigma10, n)
        if trial % 3 == 1:
            window += np.linspace(0.0, rng.uniform(0.0, 1.0), n)
        if trial % 3 == 2:
            window[int(rng.integers(n)) :] += rng.uniform(0.0, 1.0)
        level = float(rng.normal(23.0, 1.0))
        y10 = level + window
        running = np.cumsum(y10 - level)
        count = np.arange(1, n + 1)
        z = running / (sigma10 * np.sqrt(count) + 1e-12)
        passes = bool(np.any((running >= params.min_excess_W * count) & (z > params.hidden_stop_z)))
        stands = _stands_above(y10, [(0, n)], [level], params.min_excess_W)
        assert stands or not passes, trial
        fired += passes
        skipped += not stands
    assert fired > 50 and skipped > 200, (fired, skipped)


def test_the_stop_labelled_idle_gate_holds_only_for_a_bar_of_0_sd_or_more(monkeypatch):
    """`_stands_above` stands in for the stop-labelled-idle test only when its bar is 0 sd or
    more (`MotionParams.hidden_stop_z`): under it an idle at its own level passes, so the
    gate is not used. A run segmented with a bar of -1 sd gets the doubts it gets with the
    gate taken out (every idle after a step, on a quiet simulated run)."""
    import wifibot_power.segment as segment

    config = SimConfig(repeats=1, modes=(), sample_period_s=1.024e-3, seed=5, speeds_mps=(0.5,))
    run = next(s.run for s in simulate_runs(config) if s.run.meta.steps > 1)
    params = MotionParams(hidden_stop_z=-1.0)
    gated = segment._segment_motion(run, params).doubts
    monkeypatch.setattr(segment, "_stands_above", lambda *a: True)
    assert gated == segment._segment_motion(run, params).doubts
    assert any("a stop labelled idle?" in d for d in gated)


def test_long_medians_narrowed_first_are_numpys() -> None:
    # past 4,096 values the median partitions only a band read off a sample: the same
    # number whatever the order and the ties (sorted, rounded, half of them one value)
    rng = np.random.default_rng(6)
    for trial in range(90):
        x = rng.normal(0.0, 1.0, int(rng.integers(4_000, 150_000 if trial < 60 else 9_000)))
        if trial % 3 == 0:
            x = np.round(x, 2)
        if trial % 4 == 0:
            x = np.sort(x)[:: 1 if trial % 8 else -1].copy()
        if trial % 5 == 0:
            x[: x.size // 2] = 0.7
        assert median(x) == float(np.median(x)), trial
        d = np.diff(x)
        mad = float(np.median(np.abs(d - np.median(d))))
        assert robust_sigma_W(x) == float(1.4826 * mad / np.sqrt(2.0)), trial


def test_long_medians_narrowed_twice_or_missed_are_numpys() -> None:
    # a band still longer than 4,096 values is narrowed again, with the wanted ranks off
    # its middle (a skewed array: most of the band on one side); a sample that misses the
    # middle (every 7th value the same: the sample is all zeros) falls back to a partition
    # of what is left. Each the same number as numpy's, odd and even sizes.
    rng = np.random.default_rng(16)
    for size in (4_097, 4_098, 60_001, 60_002, 300_000, 300_001):
        skewed = rng.exponential(1.0, size) ** 3
        assert median(skewed) == float(np.median(skewed)), size
        periodic = np.tile(np.arange(7.0), -(-size // 7))[:size]
        periodic[:: (size // 2048)] = 0.0
        assert median(periodic) == float(np.median(periodic)), size
        ties = np.round(rng.normal(0.0, 1.0, size), 1)
        assert median(ties) == float(np.median(ties)), size


def test_a_zero_median_is_plus_zero() -> None:
    # review (sixth session): with -0.0 and +0.0 both at the middle, which one the
    # partition leaves there depends on the order; a 0 W idle level read "-0". Short and
    # long (narrowed) arrays, odd and even sizes, quantised readings around 0 W
    rng = np.random.default_rng(18)
    for size in (5, 6, 4_097, 50_000, 50_001):
        for _ in range(10):
            x = np.round(rng.normal(0.0, 0.004, size), 2)
            x[rng.random(size) < 0.5] *= -1.0  # both zeros, shuffled
            found = median(x)
            assert found == float(np.median(x))
            if found == 0.0:
                assert np.copysign(1.0, found) == 1.0, size


def test_solve_written_out_for_low_degrees_is_the_loop_bit_for_bit() -> None:
    # `_solve` writes degrees 0 and 1 out (most splits): each coefficient and the explained
    # sum the very doubles of the general loop (here), on random rows of G⁻¹ and b
    rng = np.random.default_rng(17)

    def loop(rhs, inverse):
        coef = []
        for p in range(len(rhs)):
            c_p = inverse[p, p % 2] * rhs[p % 2]
            for q in range(p % 2 + 2, len(rhs), 2):
                c_p = c_p + inverse[p, q] * rhs[q]
            coef.append(c_p)
        explained = coef[0] * rhs[0]
        for p in range(1, len(rhs)):
            explained = explained + coef[p] * rhs[p]
        return coef, explained

    for m in (1, 2, 3, 4):
        for _ in range(20):
            size = int(rng.integers(1, 300))
            rhs = [rng.normal(0.0, 10.0 ** rng.integers(-3, 4), size) for _ in range(m)]
            inverse = {
                (p, q): rng.normal(0.0, 1.0, size)
                for p in range(m)
                for q in range(m)
                if (p + q) % 2 == 0
            }
            coef, explained = _solve(rhs, inverse)
            want_coef, want_explained = loop(rhs, inverse)
            assert all(np.array_equal(a, b) for a, b in zip(coef, want_coef, strict=True))
            assert np.array_equal(explained, want_explained)


def test_jump_statistic_noise_matches_its_sd_factor() -> None:
    rng = np.random.default_rng(2)
    jump = jump_statistic_W(rng.normal(0.0, 1.0, 200_000), 10)
    # sd of J over 200k (correlated) values: within 3% of the closed form
    assert_allclose(np.nanstd(jump), jump_sd_factor(10), rtol=0.03)


def _brute_best_split(y: np.ndarray, deg_left: int, deg_right: int, min_len: int) -> float:
    """Smallest SSE over every split, each piece by numpy's own polyfit."""

    def sse(part: np.ndarray, deg: int) -> float:
        x = np.arange(part.size, dtype=np.float64)
        residual = part - np.polyval(np.polyfit(x, part, deg), x)
        return float(residual @ residual)

    return min(
        sse(y[:k], deg_left) + sse(y[k:], deg_right) for k in range(min_len, y.size - min_len + 1)
    )


@settings(max_examples=60, deadline=None)
@given(
    values=st.lists(st.floats(-50, 50, allow_nan=False), min_size=16, max_size=40),
    deg_left=st.integers(0, 3),
    deg_right=st.integers(0, 3),
)
def test_best_split_is_the_least_squares_split(
    values: list[float], deg_left: int, deg_right: int
) -> None:
    y = np.array(values) + 25.0  # power-like offset: the prefix sums must not lose it
    split = best_split(y, 0, y.size, deg_left, deg_right, min_len=5)
    assert split is not None
    brute = _brute_best_split(y, deg_left, deg_right, 5)
    # same optimum up to float error on sums of ~40 squares of values up to ~75
    assert split.sse == pytest.approx(brute, rel=1e-6, abs=1e-6)


def test_best_split_same_whether_its_window_shapes_are_kept_or_not(monkeypatch) -> None:
    """`best_split` keeps what depends on a window's shape alone (`_piece_shape`,
    `_window_positions`) for later calls: each split is the same, bit for bit, made with
    nothing kept, with everything kept, and with a store so small it is emptied every few
    calls (the same shape under another degree, side or range must not be taken for it,
    nor a kept array changed by a call), the least-squares split (brute force), and the
    store stays within its bound."""
    rng = np.random.default_rng(11)
    cases = [
        (25.0 + rng.normal(0, 1, size), deg_left, deg_right, min_len, sign)
        for size in (16, 17, 23, 40)
        for deg_left in range(4)
        for deg_right in range(4)
        for min_len, sign in ((5, 0), (6, 1), (5, -1))
    ]

    def splits(clear_each: bool) -> list:
        found = []
        for y, deg_left, deg_right, min_len, sign in cases:
            if clear_each:
                changepoint_splits._SHAPES.clear()
                changepoint_splits._SHAPES_SIZE[0] = 0
                changepoint_splits._POSITIONS.clear()
            found.append(best_split(y, 0, y.size, deg_left, deg_right, min_len, jump_sign=sign))
            assert changepoint_splits._SHAPES_SIZE[0] <= changepoint_splits._SHAPES_MAX_SIZE
        return found

    cold = splits(clear_each=True)
    assert splits(clear_each=False) == cold
    assert splits(clear_each=False) == cold  # every shape kept by now
    monkeypatch.setattr(changepoint_splits, "_SHAPES_MAX_SIZE", 4000)  # emptied every dozen shapes
    changepoint_splits._SHAPES.clear()
    changepoint_splits._SHAPES_SIZE[0] = 0
    assert splits(clear_each=False) == cold
    assert 0 < len(changepoint_splits._SHAPES) < 40  # some were kept, and some let go
    for (y, deg_left, deg_right, min_len, sign), split in zip(cases, cold, strict=True):
        if sign == 0:
            brute = _brute_best_split(y, deg_left, deg_right, max(min_len, 5))
            assert split.sse == pytest.approx(brute, rel=1e-6, abs=1e-6)


def test_centred_power_sums_by_hand() -> None:
    # L = 3: positions -1, 0, 1: every even power sums to 2, odd ones to 0
    assert_allclose(
        [_centred_power_sum(r, np.array([3.0]))[0] for r in range(7)], [3, 0, 2, 0, 2, 0, 2]
    )
    # L = 4: positions +-0.5, +-1.5: r = 2: 2 (0.25 + 2.25) = 5; r = 4: 2 (0.0625 + 5.0625)
    # = 10.25; r = 6: 2 (0.015625 + 11.390625) = 22.8125
    assert_allclose(
        [_centred_power_sum(r, np.array([4.0]))[0] for r in (2, 4, 6)], [5.0, 10.25, 22.8125]
    )


def test_best_split_long_window_exact_pieces() -> None:
    # 2000 blocks, noise-free: a cubic (a wavy cruise) over [0, 1234), then flat idle 23.3 W.
    # The least-squares split is exact (SSE 0 there, > 0 elsewhere), and both pieces are
    # recovered at the boundary k = 1233.5 in a window long enough to stress conditioning.
    k = np.arange(2000, dtype=np.float64)

    def cubic(x):
        return 25.0 + 3e-3 * x - 2e-6 * x**2 + 1e-9 * x**3

    y = np.where(k < 1234, cubic(k), 23.3)
    split = best_split(y, 0, y.size, 3, 0, 5)
    assert split is not None and split.index == 1234
    # cubic(1233.5) = 25 + 3.7005 - 3.04304 + 1.87680 = 27.53425 W (by hand); the pieces
    # are exact, so only float error on sums of ~2000 terms is left: 1e-6 W
    assert split.left_end_W == pytest.approx(cubic(1233.5), abs=1e-6)
    assert split.right_start_W == pytest.approx(23.3, abs=1e-6)
    assert split.sse == pytest.approx(0.0, abs=1e-6)


def test_best_split_sign_constraint() -> None:
    # flat 10 W, then from block 30 a line starting at 9 W rising 0.5 W per block: the
    # free split is at 30 with a jump of -1 W; asked for upward jumps only, it must move
    y = np.concatenate([np.full(30, 10.0), 9.0 + 0.5 * np.arange(30)])
    free = best_split(y, 0, y.size, 0, 1, 5)
    assert free is not None and free.index == 30
    assert free.jump_W == pytest.approx(-1.0 - 0.25, abs=1e-9)  # at the boundary x = 29.5
    up = best_split(y, 0, y.size, 0, 1, 5, jump_sign=1)
    assert up is not None and up.index != 30 and up.jump_W >= 0


def test_best_splits_are_best_split_bit_for_bit() -> None:
    """Windows stacked as rows of one padded array (short ones) or split one by one (long
    ones), with minimum lengths of their own, some too short for two pieces: every `Split`
    is `best_split`'s, bit for bit (dataclass equality compares the floats exactly)."""
    rng = np.random.default_rng(12)
    compared = stacked = 0
    for trial in range(40):
        n = int(rng.integers(60, 3000))
        y = 23.0 + np.cumsum(rng.normal(0, 0.05, n)) + rng.normal(0, 0.2, n)
        deg_left, deg_right = int(rng.integers(0, 4)), int(rng.integers(0, 4))
        sign, min_len = int(rng.integers(-1, 2)), int(rng.integers(1, 12))
        windows = []
        for _ in range(int(rng.integers(2, 9))):
            lo = int(rng.integers(-5, n - 10))
            hi = lo + int(rng.integers(4, 900 if trial % 4 else 2500))
            windows.append((lo, hi, int(rng.integers(1, 30))) if trial % 3 == 0 else (lo, hi))
        found = best_splits(y, windows, deg_left, deg_right, min_len, sign)
        for window, split in zip(windows, found, strict=True):
            own = window[2] if len(window) > 2 else min_len
            assert split == best_split(y, window[0], window[1], deg_left, deg_right, own, sign)
            compared += 1
            stacked += min(window[1], n) - max(window[0], 0) <= changepoint_stacked._STACKED_MAX
    assert compared > 150 and stacked > 100  # both ways taken, many times


def test_steps_searched_side_by_side_are_those_searched_one_by_one() -> None:
    """`_locate_steps` searches every step at once with an assumed end of the step before,
    then searches again a step whose idle window the found end changes: its steps are those
    of a search step after step, whatever was assumed. Steps 0.15 s apart (closer than the
    0.5 s idle window), whose coarse ends are 60 ms early, make the assumption matter."""
    rng = np.random.default_rng(13)
    block_dt, params = 1e-3, MotionParams()
    y, coarse, cursor = [np.full(800, 23.0)], [], 800
    for k in range(6):
        gap = 150 if k % 2 else 900
        ramp = 23.0 + 6.0 + np.linspace(0, 4.0, 200)
        motion = np.concatenate([ramp, np.full(1200, 30.0 + k % 3)])
        y += [motion, np.full(gap, 23.0)]
        coarse.append((cursor + 20, cursor + motion.size - 60))
        cursor += motion.size + gap
    y = np.concatenate(y) + rng.normal(0.0, 0.05, cursor)
    sigma_b = robust_sigma_W(y)

    def one_by_one(ends_before) -> list:
        steps: list = []
        for i, (a, b) in enumerate(coarse):
            prev_end = ends_before(i, steps)
            next_start = coarse[i + 1][0] if i + 1 < len(coarse) else y.size
            trace = _Trace(y, block_dt, sigma_b, params)
            steps += _search_steps(trace, [(a, b, prev_end, next_start)])
        return steps

    truth = one_by_one(lambda i, steps: steps[-1].t3 if steps else 0)
    # each step searched from a wrong end of the step before (0: its idle window reaches
    # into that step's motion) gives other steps: the assumption must be corrected
    wrong = one_by_one(lambda i, steps: 0)
    assert wrong != truth
    for assumed in (None, [0] * (len(coarse) - 1), [b + 400 for _, b in coarse[:-1]]):
        assert _locate_steps(y, block_dt, sigma_b, coarse, params, assumed) == truth


def _staircase(period_s: float = 1e-3, noise_W: float = 0.01, seed: int = 3):
    """Levels 1, 3, 2, 5 W for 0.5 s each; every step up overshoots by the step's size and
    settles with a 20 ms time constant (an inrush spike)."""
    levels_W = [1.0, 3.0, 2.0, 5.0]
    n_level = round(0.5 / period_s)
    power = np.repeat(levels_W, n_level)
    t_local = np.arange(n_level) * period_s
    for k in range(1, 4):
        step = levels_W[k] - levels_W[k - 1]
        if step > 0:
            power[k * n_level : (k + 1) * n_level] += step * np.exp(-t_local / 0.02)
    rng = np.random.default_rng(seed)
    return power + rng.normal(0.0, noise_W, power.size), n_level, levels_W


def test_detect_levels_on_a_staircase_with_inrush_spikes() -> None:
    power, n_level, levels_W = _staircase()
    found = detect_levels(power, 1e-3)
    # 4 levels: the spikes (100% overshoot, 20 ms decay) must not make levels of their own
    assert len(found.levels_W) == 4
    # changes at samples 500, 1000, 1500: within 2 samples (2 ms)
    assert_allclose(found.bounds[1:-1], [n_level, 2 * n_level, 3 * n_level], atol=2)
    # level medians: within 0.02 W (noise 0.01 W; the settled tail of a spike is in the median)
    assert_allclose(found.levels_W, levels_W, atol=0.02)
    # a spike is reported at each of the two steps up, not at the step down
    assert [s.i_start for s in found.spikes] == pytest.approx([n_level, 3 * n_level], abs=2)
    # energy above the level of a spike: step * tau = 2 W * 0.02 s = 0.04 J (1 -> 3 W), cut
    # where it falls under the report threshold: at least 80% of it
    assert 0.8 * 0.04 <= found.spikes[0].energy_above_level_J <= 0.04 * 1.05


def test_detect_levels_steady_trace_is_one_level() -> None:
    rng = np.random.default_rng(4)
    found = detect_levels(23.3 + rng.normal(0, 0.3, 50_000), 0.1024e-3)
    assert len(found.levels_W) == 1 and not found.spikes


def test_detect_levels_min_step_merges_small_changes() -> None:
    power, _, _ = _staircase()
    # changes of 2, 1 and 3 W: asking for 1.2 W merges the 3 -> 2 W change only (the merged
    # level's median, ~2.5 W, is still 1.5 W from 1 W and 2.5 W from 5 W)
    found = detect_levels(power, 1e-3, LevelParams(min_step_W=1.2))
    assert len(found.levels_W) == 3
    assert found.bounds[1:-1] == pytest.approx([500, 1500], abs=2)


# -- motion runs against the simulator's truth ---------------------------------------------

#: the default speed grid at a 1.024 ms analyser period (10x the paper's: the segmenter works
#: on ~1 ms blocks anyway, and the simulator averages its noise to that period), to stay fast
FAST = SimConfig(repeats=1, modes=(), sample_period_s=1.024e-3, seed=11)


def _boundaries(phases: list[dict]) -> dict[tuple[int, str], float]:
    """{(step, kind): t_s} for accel start, cruise start and end, decel end."""
    out: dict[tuple[int, str], float] = {}
    for p in phases:
        step, name = int(p["step"]), p["phase"]
        if name == "accel":
            out[(step, "accel_start")] = p["t_start_s"]
        elif name == "cruise":
            out[(step, "cruise_start")] = p["t_start_s"]
            out[(step, "cruise_end")] = p["t_end_s"]
        elif name == "decel":
            out[(step, "decel_end")] = p["t_end_s"]
    return out


def _score_by_kind(config: SimConfig) -> dict[str, np.ndarray]:
    """Signed boundary errors [s] (found - true) by kind of boundary over every run of
    `config`; asserts the phase structure, and that a clean simulated run has no doubt."""
    errors: dict[str, list[float]] = {}
    for sim in simulate_runs(config):
        seg = segment_run(sim.run)
        truth = _boundaries(sim.truth["phases"])
        found = _boundaries([p.as_dict() for p in seg.phases])
        run_id = sim.truth["run_id"]
        # the same phases: every step, a decel only where the truth has one
        assert set(found) == set(truth), f"{run_id}: {sorted(set(found) ^ set(truth))[:4]}"
        for key in truth:
            errors.setdefault(key[1], []).append(found[key] - truth[key])
        _check_cover(sim.run, seg)
        # no false doubt on a run the segmenter gets right (issue 12)
        assert seg.doubts == (), f"{run_id}: {seg.doubts}"
    return {kind: np.array(e) for kind, e in errors.items()}


def _score(config: SimConfig) -> np.ndarray:
    """Absolute boundary errors [s] over every run of `config` (see `_score_by_kind`)."""
    return np.abs(np.concatenate(list(_score_by_kind(config).values())))


#: Boundary accuracy pinned per kind of boundary, as measured (signed errors over the
#: default grid at 1.024 ms, seeds 5, 6 and 11, each effect alone; docs/segmentation.md):
#: at 0.3 W every kind is found on the true sample in >= 90% of boundaries (p90 |e| 0.0
#: ms), worst 1 sample (1.0 ms); at 1.5 W the median |e| is 0 for cruise start and end
#: (p90 <= 1 sample) and 1 sample for accel start (p90 5.1 ms) and decel end (p90 5.8
#: ms), worst 46 ms. Pinned with slack below one
#: sample where the measurement is 0, so a refinement one sample off, or every boundary
#: of a kind shifted by 8 ms, fails.
HALF_SAMPLE_S = 0.6e-3
ACCURACY = {
    # noise: (p90 |e| bound per kind, median |e| bound per kind, worst)
    0.3: ({"*": HALF_SAMPLE_S}, {"*": HALF_SAMPLE_S}, 1.1e-3),
    1.5: (
        {"accel_start": 6e-3, "decel_end": 7e-3, "*": 2.1e-3},
        {"accel_start": 1.1e-3, "decel_end": 1.1e-3, "*": HALF_SAMPLE_S},
        0.050,
    ),
}


def check_accuracy(errors: dict[str, np.ndarray], noise_W: float) -> None:
    p90_bound, median_bound, worst = ACCURACY[noise_W]
    for kind, signed in errors.items():
        e = np.abs(signed)
        p90 = p90_bound.get(kind, p90_bound["*"])
        med = median_bound.get(kind, median_bound["*"])
        assert np.percentile(e, 90) <= p90, f"{kind}: p90 {np.percentile(e, 90) * 1e3:.2f} ms"
        assert np.median(e) <= med, f"{kind}: median {np.median(e) * 1e3:.2f} ms"
        assert e.max() <= worst, f"{kind}: worst {e.max() * 1e3:.1f} ms"
        # no kind is late or early on average by more than a third of a sample at 0.3 W
        if noise_W == 0.3:
            assert abs(np.mean(signed)) <= 0.35e-3, f"{kind}: bias {np.mean(signed) * 1e3:.2f} ms"


def _check_cover(run: Run, seg) -> None:
    starts = np.array([p.i_start for p in seg.phases])
    ends = np.array([p.i_end for p in seg.phases])
    assert starts[0] == 0 and ends[-1] == run.samples
    assert np.all(starts[1:] == ends[:-1]) and np.all(ends > starts)
    # energy is additive over phases (rectangle rule on the same samples)
    assert sum(p.energy_J for p in seg.phases) == pytest.approx(run.energy_J, rel=1e-12)


CASES = [("none", {})] + [(name, {name: EFFECTS[name][1]}) for name in EFFECTS]


@pytest.mark.parametrize("noise_W", [0.3, 1.5], ids=["default-noise", "noisier"])
@pytest.mark.parametrize("effect", CASES, ids=[c[0] for c in CASES])
def test_boundaries_against_truth_over_the_default_grid(
    effect: tuple[str, dict[str, float]], noise_W: float
) -> None:
    _, effects = effect
    by_kind = _score_by_kind(replace(FAST, noise_W=noise_W, effects=effects))
    errors_s = np.abs(np.concatenate(list(by_kind.values())))
    # issue 3: median <= 20 ms, worst <= 50 ms
    assert np.median(errors_s) <= 0.020
    assert errors_s.max() <= 0.050, f"worst {errors_s.max() * 1e3:.1f} ms"
    # issue 12: as tight as measured
    check_accuracy(by_kind, noise_W)


@pytest.mark.parametrize("noise_W", [0.3, 1.5])
@pytest.mark.parametrize(
    "kind, shift_s", [("cruise_start", 1.024e-3), ("cruise_start", 0.008), ("cruise_end", 1.024e-3)]
)
def test_accuracy_check_fails_a_boundary_one_sample_or_8_ms_off(
    kind: str, shift_s: float, noise_W: float
) -> None:
    """The pinned accuracy is tight enough: every boundary of one kind moved by one sample
    (1.024 ms) or by 8 ms fails it (measured errors of the grid, shifted)."""
    config = replace(FAST, noise_W=noise_W, speeds_mps=(0.2, 0.5, 0.8))
    by_kind = _score_by_kind(config)
    check_accuracy(by_kind, noise_W)  # as found: passes
    shifted = {**by_kind, kind: by_kind[kind] + shift_s}
    with pytest.raises(AssertionError):
        check_accuracy(shifted, noise_W)


@pytest.mark.parametrize("noise_W", [0.3, 1.5])
def test_boundaries_at_the_paper_sample_rate(noise_W: float) -> None:
    config = SimConfig(
        speeds_mps=(0.1, 0.5, 0.9),
        trips=((2.0, 1), (10.0, 10)),
        repeats=1,
        modes=(),
        noise_W=noise_W,
        seed=12,
    )
    errors_s = _score(config)
    assert np.median(errors_s) <= 0.020 and errors_s.max() <= 0.050


def test_stop_phase_found_only_when_simulated() -> None:
    config = replace(FAST, speeds_mps=(0.3, 0.8), trips=((2.0, 1),))
    plain = [segment_run(s.run) for s in simulate_runs(config)]
    assert all(not seg.of("decel") for seg in plain)
    stopping = [
        segment_run(s.run) for s in simulate_runs(replace(config, effects={"decel_phase": 0.5}))
    ]
    # t_dec = 0.5 s: within 2 ms at the default noise
    for seg in stopping:
        (decel,) = seg.of("decel")
        assert decel.duration_s == pytest.approx(0.5, abs=0.002)


def test_start_transient_is_reported_as_a_spike_inside_accel() -> None:
    config = replace(FAST, speeds_mps=(0.5,), trips=((2.0, 1),), effects={"start_transient": 6.0})
    (sim,) = simulate_runs(config)
    seg = segment_run(sim.run)
    (accel,) = seg.of("accel")
    (spike,) = seg.spikes
    assert accel.t_start_s <= spike.t_start_s < accel.t_end_s
    # a 6 J pulse (tau 0.05 s): most of it stands out above the ramp
    assert 3.0 < spike.energy_above_level_J < 6.5


def test_wrong_step_count_shows_as_steps_found() -> None:
    # 10 steps with 2 s of idle between them, but the metadata says 1: the 2 s gaps are idle
    # (longer than a ripple dip), so 10 steps are found and `fit` can flag the mismatch
    (sim,) = simulate_runs(replace(FAST, speeds_mps=(0.5,), trips=((10.0, 10),)))
    run = replace(sim.run, meta=replace(sim.run.meta, steps=1))
    seg = segment_run(run)
    assert len(seg.of("accel")) == 10 and len(seg.of("cruise")) == 10


def test_mode_log_gives_levels() -> None:
    config = replace(FAST, speeds_mps=(), trips=(), modes=("network",), mode_repeats=1)
    (sim,) = simulate_runs(config)
    seg = segment_run(sim.run)
    assert [p.phase for p in seg.phases] == ["level"]
    assert seg.phases[0].mean_power_W == pytest.approx(23.3 + 4.4, abs=0.01)


def test_motion_log_without_motion_is_a_one_line_error() -> None:
    period = 1e-3
    meta = RunMeta("flat", mode="motion", speed_mps=0.5, distance_m=2, sample_period_s=period)
    rng = np.random.default_rng(5)
    power = 23.3 + rng.normal(0, 0.1, 5000)
    run = Run("flat.csv", "wbpower-csv", meta, np.arange(5000) * period, power)
    with pytest.raises(LogError) as err:
        segment_run(run)
    assert "flat.csv" in str(err.value) and "\n" not in str(err.value)


# -- the command ---------------------------------------------------------------------------


def test_segment_command_json_and_table(tmp_path) -> None:
    config = replace(FAST, speeds_mps=(0.6,), trips=((10.0, 2),))
    (sim,) = simulate_runs(config)
    path = tmp_path / "run.csv"
    write_log(path, format_log(sim.run.meta, sim.run.power_W, time_column=True))
    runner = CliRunner()
    result = runner.invoke(app, ["segment", str(path), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["run_id"] == sim.truth["run_id"]
    keys = {"step", "phase", "t_start_s", "t_end_s", "duration_s", "mean_power_W", "energy_J"}
    assert all(keys <= set(p) for p in doc["phases"])
    # idle, (accel, cruise, idle) x 2
    assert [p["phase"] for p in doc["phases"]] == ["idle"] + ["accel", "cruise", "idle"] * 2
    table = runner.invoke(app, ["segment", str(path)])
    assert table.exit_code == 0 and "cruise" in table.stdout


def test_segment_command_bad_input_is_one_line_exit_2(tmp_path) -> None:
    result = CliRunner().invoke(app, ["segment", str(tmp_path / "missing.csv")])
    assert result.exit_code == 2
    assert "missing.csv" in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_segment_command_has_help() -> None:
    result = CliRunner().invoke(app, ["segment", "--help"])
    assert result.exit_code == 0 and "--supply-voltage" in result.stdout


@settings(max_examples=200, deadline=None)
@given(
    values=st.lists(
        st.one_of(st.floats(-1e6, 1e6), st.just(float("-inf"))), min_size=1, max_size=300
    ),
    half=st.integers(0, 40),
)
def test_sliding_max_equals_scipys_maximum_filter(values, half):
    from scipy.ndimage import maximum_filter1d

    from wifibot_power.changepoint import sliding_max

    x = np.array(values)
    expected = maximum_filter1d(x, size=2 * half + 1, mode="constant", cval=-np.inf)
    assert np.array_equal(sliding_max(x, 2 * half + 1), expected)


def test_false_start_up_spikes_on_sample_logs_are_few() -> None:
    """sample_logs/ holds no start transient, but its 1 W wheel ripple runs during the ramps
    and a step of a fraction of a watt starts each: 43 accelerations carried a false
    'start-up spike' (two were drawn in red on the README's trace figure). With the spike
    judged against the ramp's own scatter and required to hold 1% of its acceleration's
    energy, 8 remain, all at 0.7-0.9 m/s, where the ramp holds about two ripple periods
    and a hump of the ripple at its start still stands out (a known gap: the ripple is not
    modelled in the ramp). Measured: 8; none at 0.6 m/s or below."""
    from wifibot_power.io import ReadOptions, read_log

    root = Path(__file__).resolve().parents[1] / "sample_logs"
    found = {}
    for path in sorted(root.glob("v*.csv.gz")):
        spikes = segment_run(read_log(path, ReadOptions())).spikes
        if spikes:
            found[path.name] = len(spikes)
    assert sum(found.values()) <= 8, found
    assert all(float(name[1:5]) >= 0.7 for name in found), found


def _field_run(v: float, seed: int, effects: dict[str, float] | None = None):
    """One 10 m run in one step at `simulate --realism field`, 1 ms samples."""
    from wifibot_power.simulate import realism

    config = SimConfig(
        speeds_mps=(v,),
        trips=((10.0, 1),),
        repeats=1,
        modes=(),
        seed=seed,
        sample_period_s=0.001,
        effects=effects or {},
        **realism("field"),
    )
    (sim,) = simulate_runs(config)
    return sim


def _with_lower_level(sim, v: float, low: float, length_s: float, own_stop: bool):
    """The run with the last `length_s` of its cruise at `low` x v (power lowered by
    11.2 W/(m/s) x (1 - low) v); with `own_stop`, its stop phase scaled to that speed too."""
    phases = {p["phase"]: p for p in sim.truth["phases"]}
    dt = sim.run.sample_period_s
    i_end = round(phases["cruise"]["t_end_s"] / dt)
    power_W = sim.run.power_W.copy()
    power_W[i_end - round(length_s / dt) : i_end] -= 11.2 * v * (1.0 - low)
    if own_stop:  # the stop from the lower speed: P_dec's speed term scaled by `low`
        a = round(phases["decel"]["t_start_s"] / dt)
        b = round(phases["decel"]["t_end_s"] / dt)
        speed_left = 1.0 - (np.arange(b - a) + 0.5) / (b - a)
        power_W[a:b] -= (1.0 - low) * 0.5 * 11.2 * v * speed_left
    return replace(sim.run, power_W=power_W), phases["cruise"]["t_end_s"] - length_s


LOWER_LEVELS = [(1.0, 0.3), (0.6, 0.1), (0.3, 0.3)]  # (cruise speed [m/s], level / cruise)


@pytest.mark.parametrize("length_s", [1.0, 2.0, 3.0, 4.0])
@pytest.mark.parametrize(("v", "low"), LOWER_LEVELS)
def test_a_second_lower_level_at_a_cruise_end_is_doubted_not_taken_for_a_stop(v, low, length_s):
    """A cruise whose last 1-4 s run at a lower speed (the review's reproduction: 1 m/s,
    its last 3 s at 0.3 m/s; seeds 1-3 at field realism) is doubted as holding a second
    level, and no stop phase is put inside that level. Before the stop-shape test, stops
    were looked for up to 1.5 s and 1 s levels became a "decel" phase with no doubt (and, at
    seed 1, 2-4 s levels at 1 m/s held a 0.8 s "decel"); looking up to 5 s with only the
    old test (a line that falls and ends near idle), every such level did. Measured with
    the test: every level of 1-4 s at 0.3, 0.6 and 1 m/s, at 0.1, 0.3 and 0.5 of the
    speed, doubted and none taken for a stop (seeds 1-3, 108 runs; also at 0.3 and 1.5 W
    lab noise and at 10 kHz, 48 runs)."""
    for seed in (1, 2, 3):
        sim = _field_run(v, seed)
        run, level_start_s = _with_lower_level(sim, v, low, length_s, own_stop=False)
        seg = segment_run(run)
        assert not seg.of("decel"), (seed, [(p.t_start_s, p.t_end_s) for p in seg.of("decel")])
        assert any("second speed level" in d for d in seg.doubts), (seed, seg.doubts)


@pytest.mark.parametrize("length_s", [1.0, 2.0, 4.0])
def test_a_lower_level_ending_in_its_own_stop_keeps_the_stop_and_is_doubted(length_s):
    """The level ends with its own stop phase (0.4 s, from the lower speed): the level's
    flat first part drops the long candidate (level and stop as one "stop"), and the search
    again after the level's start finds the stop itself, within 20 ms (measured: exact at
    0.6 and 1 m/s with levels at 0.3 and 0.5 of the speed, 1-4 s, seeds 1-3, 48 runs).
    Over 0.3-1 m/s and levels at 0.1-0.5 of the speed (108 runs), 100 were right, 7 lost
    the level's own stop but were doubted, and 1 (a 2 s level at 0.1 of 0.3 m/s, whose own
    stop falls 0.34 W) was taken for one long stop with no doubt (docs/segmentation.md)."""
    for v in (0.6, 1.0):
        for seed in (1, 2):
            sim = _field_run(v, seed, {"decel_phase": 0.4})
            run, level_start_s = _with_lower_level(sim, v, 0.3, length_s, own_stop=True)
            stop_start_s = next(p for p in sim.truth["phases"] if p["phase"] == "decel")[
                "t_start_s"
            ]
            seg = segment_run(run)
            (decel,) = seg.of("decel")
            assert decel.t_start_s == pytest.approx(stop_start_s, abs=0.02), (v, seed)
            assert any("second speed level" in d for d in seg.doubts), (v, seed, seg.doubts)


def test_exponential_stops_up_to_4_s_are_found_at_field_realism():
    """tests/fieldgen.py's stops (speed v exp(-t/tau), power 0.6 W + 0.5 x 11.2 v(t) while
    stopping) with 5 tau = 1-4 s, every speed of its grid, 2 m and 10 m in one step: each
    found, with no doubt, its start within 10 ms of the truth and its end within 10 ms of
    the drive switching off. Measured on seeds 1-3 (120 runs): start within 5.6 ms, end
    within 6 ms. Before: stops looked for up to 1.5 s, 85 of the 120 missed (the cruise
    doubted as holding two levels), and a stop's end put up to 2.3 s early (a line through
    the whole decay)."""
    import fieldgen

    for stop_s in (1.0, 2.0, 3.0, 4.0):
        batch = fieldgen.Batch(
            trips=((2.0, 1), (10.0, 1)),
            repeats=1,
            idle_runs=0,
            effects={"decel_phase": stop_s * 3.0 / 5.0},
            seed=1,
        )
        generated = fieldgen.generate(batch)
        for g, run in zip(generated, fieldgen.to_runs(generated), strict=True):
            v, d = g.meta["speed_mps"], g.meta["distance_m"]
            tau, t_acc = g.truth["tau_stop_s"], g.truth["t_acc_s"]
            cruise_s = (d - v * t_acc / 2 - v * tau) / v
            (start_s,) = g.truth["phase_starts_s"]
            seg = segment_run(run)
            (decel,) = seg.of("decel")
            assert not seg.doubts, (stop_s, run.meta.run_id, seg.doubts)
            assert decel.t_start_s == pytest.approx(start_s + t_acc + cruise_s, abs=0.01)
            assert decel.t_end_s == pytest.approx(start_s + t_acc + cruise_s + 5 * tau, abs=0.01)


def test_linear_stops_up_to_4_s_are_found_at_field_realism():
    """The simulator's stops (causes.md's form: a drop, then a line down to idle + drive)
    of 0.2-4 s at `--realism field`, 0.1-0.9 m/s: each found, its start and end within
    10 ms (measured on 118 runs, seeds 1-2, 2 m and 10 m: within 5 and 6 ms). Before: 52
    of the 118 (all the stops over 1.5 s) missed."""
    for t_dec, v in [(0.2, 0.1), (1.0, 0.5), (2.0, 0.9), (3.0, 0.3), (4.0, 0.1), (4.0, 0.7)]:
        sim = _field_run(v, 1, {"decel_phase": t_dec})
        truth = next(p for p in sim.truth["phases"] if p["phase"] == "decel")
        seg = segment_run(sim.run)
        (decel,) = seg.of("decel")
        assert not seg.doubts, (t_dec, v, seg.doubts)
        assert decel.t_start_s == pytest.approx(truth["t_start_s"], abs=0.01), (t_dec, v)
        assert decel.t_end_s == pytest.approx(truth["t_end_s"], abs=0.01), (t_dec, v)


def test_stop_shape_by_hand():
    """`_falls_from_start` on noiseless shapes over 2 s of 1 ms blocks, idle 23.3 W after
    them: a linear fall and an exponential decay to idle + 0.6 W are stops; a flat level,
    and a flat level whose last 0.4 s fall to idle + 0.6 W (its own stop), are not; a
    phase of 20 blocks is too short to judge (kept)."""
    from wifibot_power.segment import MotionParams, _falls_from_start, _Trace

    n = 2000
    x = np.arange(n) / n
    top_W, end_W = 23.3 + 0.6 + 2.8, 23.3 + 0.6
    shapes = {
        "linear": top_W - (top_W - end_W) * x,
        "exponential": end_W + (top_W - end_W) * np.exp(-5.0 * x),
        "flat": np.full(n, top_W),
        "flat, then its own stop": np.where(
            x < 0.8, top_W, top_W - (top_W - end_W) * (x - 0.8) / 0.2
        ),
    }
    expected = {
        "linear": True,
        "exponential": True,
        "flat": False,
        "flat, then its own stop": False,
    }
    params = MotionParams()
    for name, shape in shapes.items():
        y = np.concatenate((shape, np.full(500, 23.3)))
        trace = _Trace(y, 0.001, 0.25, params)  # 1 ms blocks, noise sd 0.25 W
        assert _falls_from_start(trace, 0, n) is expected[name], name
    y = np.concatenate((np.full(20, top_W), np.full(500, 23.3)))
    assert _falls_from_start(_Trace(y, 0.001, 0.25, params), 0, 20)
