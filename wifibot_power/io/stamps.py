"""Checks on a log's time stamps: the sample period, and the gaps judged by the logger's own
pattern (log-format.md, "Bad input" and "Loggers that stamp rows as they arrive").

A clocked instrument's stamps are read at their median step, and a gap over 1.5 of them
is dropped samples: reported when short, an error when long. A logger that stamps rows as
they arrive (bursty, or uneven: `_stamped_on_arrival`) is judged by its own pattern, its
gaps time missing, and the note on its stamps says how its energy is read
(`_on_the_grid`, `holdgrid`). Vectorised over the steps. Split out of `validate.py`
(issue 24: one job a module); the thresholds are documented in docs/log-format.md.
"""

from __future__ import annotations

import copyreg
from collections.abc import Callable

import numpy as np

from wifibot_power.errors import LogError
from wifibot_power.io.lines import LineMap
from wifibot_power.io.options import SAMPLE_PERIOD_RANGE_S
from wifibot_power.run import Problem

#: A single dropped-sample gap longer than this stops the analysis [s] ...
MAX_GAP_S = 0.05
#: ... unless it is at most this many sample periods of the log's own spacing: a slow logger
#: (~18 Hz: 55 ms a sample) that drops a sample, or three in a row, is not refused.
MAX_GAP_PERIODS = 3
#: Dropped samples adding up to more than this share of the log stop the analysis [%], when
#: they also add up to more than `MAX_GAP_PERIODS` sample periods: else a short log from a
#: slow logger (30 samples at 1 Hz) that drops one sample would be refused, which the spec
#: says it is not.
MAX_GAP_PCT = 1.0
#: A step between time stamps above this many sample periods is a gap (jitter stays below).
GAP_FACTOR = 1.5
#: A logger writes in bursts (`_is_bursty`) when over this share of its steps are long (over
#: `GAP_FACTOR` median steps) ...
BURSTY_STEP_SHARE = 0.1
#: ... and over this share of its time passes in them: waiting is what it mostly does (a
#: logger dropping samples is read only with under `MAX_GAP_PCT` of its time dropped).
BURSTY_TIME_SHARE = 0.5
#: A bursty logger's longest regular wait: this quantile of its waits (a tenth of its waits
#: may be longer: those over `GAP_FACTOR` times it are gaps).
BURST_WAIT_QUANTILE = 0.9
#: ... which needs at least this many waits (1 / (1 - `BURST_WAIT_QUANTILE`)) to stand below
#: the longest: fewer long steps are no pattern (a short log with one long pause is a gap).
BURSTY_MIN_WAITS = 10
#: Steps between gaps whose middle half (25th to 75th percentile) spreads over more than
#: this share of their median [%] come from a logger that stamps rows as they arrive
#: (`_stamped_on_arrival`): a clocked instrument's steps are equal to their rounding (0.0% on
#: every analyser, REGBOT and BorealTC log), the phone apps' and the F1/10 car's spread 4-60%.
ARRIVAL_SPREAD_PCT = 1.0
#: Time stamps whose mean step (between gaps) is further than this from their median [%]
#: are uneven (a logger stamping on arrival, e.g. ROS): the period is then their mean, so
#: that durations and energies follow the stamps (the bar is MAX_GAP_PCT's: as much time
#: miscounted as gaps that make energies wrong).
UNEVEN_PCT = 1.0


def _check_time(
    file: str, time_s: np.ndarray, line_of: Callable[[int], int], default_period_s: float
) -> tuple[float, list[Problem], np.ndarray | None]:
    """The sample period and the problems of the time stamps; for a logger that stamps rows
    as they arrive (bursty, or uneven: `_stamped_on_arrival`) also its gaps (the steps
    after those samples), its first problem the note that says its pattern; else None."""
    if not time_s.size:
        return default_period_s, [], None
    if time_s.size < 2:
        _time_error(file, time_s, np.diff(time_s), line_of)
        return default_period_s, [], None
    # one diff serves every check on a clean log (the usual case): steps all finite and > 0
    # with finite ends mean every stamp is finite and time goes forwards; anything else is
    # found again, exactly as before, by the slow path
    step_s = np.diff(time_s)
    low_s, high_s = step_s.min(), step_s.max()
    if not (np.isfinite(low_s) and np.isfinite(high_s) and np.isfinite(time_s[0]) and low_s > 0):
        _time_error(file, time_s, step_s, line_of)
    # time stamps carry far fewer than 10 significant digits: drop the float noise of the diff
    period_s, reordered = _median_10_digits(step_s)
    if abs(period_s - default_period_s) <= 1e-6 * default_period_s:
        period_s = default_period_s  # the stated period, not its float-rounded echo
    spacing_s = period_s  # the median step: gaps are judged against it
    gaps = np.empty(0, dtype=np.intp)
    if high_s > GAP_FACTOR * spacing_s:
        if reordered:  # the median sorted the steps in place: a fresh diff (one held at a time)
            step_s = None
            step_s = np.diff(time_s)
            reordered = False
        gaps = np.flatnonzero(step_s > GAP_FACTOR * spacing_s)
        if _is_bursty(time_s, step_s, gaps):
            return _bursty(file, time_s, step_s, gaps, line_of)
    uneven: list[Problem] = []
    # the steps between gaps: their mean is within high - low of their median, so a log
    # spaced evenly to 1% (every analyser's, and with its gaps left out a clocked logger's
    # that drops samples: `_regular_spread_s`) is not looked at again; their sum is the
    # span less the gaps' steps (no pass over the steps)
    regular = step_s.size - gaps.size
    spread_s = _regular_spread_s(step_s, gaps, low_s, high_s, spacing_s)
    if regular and spread_s > UNEVEN_PCT / 100.0 * spacing_s:
        if reordered:
            step_s = None
            step_s = np.diff(time_s)
            reordered = False
        stamped = _stamped_on_arrival(file, time_s, step_s, spacing_s, line_of)
        if stamped is not None:
            return stamped
        gap_steps_s = float(np.sum(time_s[gaps + 1] - time_s[gaps]))
        mean_s = float(f"{(float(time_s[-1] - time_s[0]) - gap_steps_s) / regular:.10g}")
        if abs(mean_s - spacing_s) > UNEVEN_PCT / 100.0 * spacing_s:
            period_s = mean_s
            if reordered:
                step_s = None
                step_s = np.diff(time_s)
            longest_s = float(np.max(step_s[step_s <= GAP_FACTOR * spacing_s]))
            uneven.append(
                Problem(
                    "uneven",
                    f"uneven time stamps (steps of {1e3 * float(low_s):.3g}-"
                    f"{1e3 * longest_s:.3g} ms between gaps): the sample period is their "
                    f"mean, {1e3 * mean_s:.4g} ms, so that durations and energies follow the "
                    f"stamps (their median, {1e3 * spacing_s:.4g} ms, would count "
                    f"{100 * (spacing_s / mean_s - 1) if mean_s else float('inf'):+.2g}% of "
                    "both)",
                )
            )
    del step_s
    if not gaps.size:
        return period_s, uneven, None
    gap_list = _gap_problems(file, time_s, gaps, period_s, period_s, line_of)
    return period_s, uneven + gap_list, None


def _regular_spread_s(
    step_s: np.ndarray, gaps: np.ndarray, low_s: float, high_s: float, spacing_s: float
) -> float:
    """How far the steps spread (`high_s` - `low_s`, the gaps' steps included), or 0 when
    those between the `gaps` lie within half the `UNEVEN_PCT` band of `spacing_s` of each
    other: their quartiles and their mean then lie within the band too, so neither
    `_stamped_on_arrival` nor an uneven period can come of them (a clocked logger that
    drops samples, whose gaps alone made the spread: two quantiles of every step were
    taken for nothing). `step_s`: the fresh diff (its gaps' steps are put back)."""
    if not gaps.size:
        return float(high_s - low_s)
    held = step_s[gaps]
    step_s[gaps] = low_s  # (a gap's step is no regular step: out of the maximum)
    regular_high_s = float(step_s.max())
    step_s[gaps] = held
    if regular_high_s - low_s <= UNEVEN_PCT / 200.0 * spacing_s:
        return 0.0
    return float(high_s - low_s)


def _gap_problems(
    file: str,
    time_s: np.ndarray,
    gaps: np.ndarray,
    period_s: float,
    spacing_s: float,
    line_of: Callable[[int], int],
    pattern: str = "",
    *,
    stamped: bool = False,
) -> list[Problem]:
    """The problems of the gaps after the samples `gaps` (each sample holds `period_s`; the
    rest of its step is missing), or the error when they are too long for the log's own
    `spacing_s`: its sample period, or a stamping logger's longest regular step (`pattern`
    names it in the messages). A logger that stamps rows as they arrive (`stamped`: a phone
    app, a ROS bridge) is read whatever its gaps, their time missing, unless they hold more
    time than its samples cover (`_mostly_missing`)."""
    missing_s = (time_s[gaps + 1] - time_s[gaps]) - period_s
    longest = int(np.argmax(missing_s))
    span_s = float(time_s[-1] - time_s[0]) + period_s
    missing_pct = 100.0 * float(missing_s.sum()) / (span_s if span_s > 0 else 1.0)
    summary = (
        f"{gaps.size} gap(s) of dropped samples{pattern}, {missing_s.sum():.4g} s in all "
        f"({missing_pct:.2g}% of the log), longest {missing_s[longest]:.4g} s after "
        f"t = {time_s[gaps[longest]]:.6g} s"
    )
    if stamped:
        covered_s = time_s.size * period_s
        if float(missing_s.sum()) > covered_s:
            _mostly_missing(file, summary, covered_s, line_of(int(gaps[longest]) + 1))
        return _gap_list(time_s, gaps, missing_s, period_s, line_of, pattern)
    spacings = "sample periods" if not pattern else "of its waits"
    limit_s = max(MAX_GAP_S, MAX_GAP_PERIODS * spacing_s)
    too_much = missing_pct > MAX_GAP_PCT and float(missing_s.sum()) > MAX_GAP_PERIODS * spacing_s
    if missing_s[longest] > limit_s or too_much:
        raise LogError(
            summary,
            file=file,
            where=f"line {line_of(int(gaps[longest]) + 1)}",
            fix=f"a gap over {limit_s:.4g} s (the longer of {MAX_GAP_S:g} s and "
            f"{MAX_GAP_PERIODS} {spacings}), or gaps adding up to over {MAX_GAP_PCT:g}% of "
            f"the log and over {MAX_GAP_PERIODS} {spacings}, make energies wrong; "
            "re-record, or cut the log at the gap",
        )
    return _gap_list(time_s, gaps, missing_s, period_s, line_of, pattern)


def _gap_list(
    time_s: np.ndarray,
    gaps: np.ndarray,
    missing_s: np.ndarray,
    period_s: float,
    line_of: Callable[[int], int],
    pattern: str,
) -> list[Problem]:
    """One `gap` problem a gap: its line, where it starts and how much is missing (each
    message written when first read: `GapProblem`)."""
    return [
        GapProblem(line_of, index, at_s, missing, period_s, pattern)
        for index, at_s, missing in zip(
            gaps.tolist(), time_s[gaps].tolist(), missing_s.tolist(), strict=True
        )
    ]


class GapProblem(Problem):
    """A `gap` problem whose message is written when it is first read: its line number
    takes a scan of the file (io/lines.py `LineMap`: ~1.5 ms a 2 MB log, five times the
    problems themselves), and a batch says the messages of its first few files only (the
    others' gaps are counted: cli `warn_problems`); `inspect --json` lists each. The same
    fields, message, equality and hash as the `Problem` it stands for. Pickled (a worker's
    problems sent back) with its line map when that can read the file again (`LineMap.
    rereadable`: no bytes held), else, or once written, as that plain `Problem`. A message
    whose file can no longer be read for its line (gone since) names the data row."""

    def __init__(
        self,
        line_of: Callable[[int], int],
        index: int,
        at_s: float,
        missing_s: float,
        period_s: float,
        pattern: str,
    ) -> None:
        vars(self).update(  # (frozen, as `Problem`: its fields set once, here)
            kind="gap",
            t_start_s=at_s + period_s,
            duration_s=missing_s,
            _line_of=line_of,
            _index=index,
            _at_s=at_s,
            _pattern=pattern,
        )

    @property
    def message(self) -> str:  # type: ignore[override]
        written = self.__dict__.get("_message")
        if written is None:
            try:
                where = f"line {self._line_of(self._index + 1)}"
            except (OSError, LogError):
                where = f"data row {self._index + 2} (the file could not be read again)"
            written = (
                f"{where}: {self.duration_s * 1e3:.4g} ms of samples dropped after "
                f"t = {self._at_s:.6g} s{self._pattern}"
            )
            object.__setattr__(self, "_message", written)
        return written

    def _fields(self) -> tuple[object, ...]:
        return (self.kind, self.message, self.t_start_s, self.duration_s)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Problem):
            return NotImplemented
        return self._fields() == (other.kind, other.message, other.t_start_s, other.duration_s)

    def __hash__(self) -> int:
        return hash(self._fields())

    def __reduce__(self):
        holder = getattr(self._line_of, "__self__", None)
        if "_message" in self.__dict__ or not (isinstance(holder, LineMap) and holder.rereadable):
            return (Problem, self._fields())
        return (copyreg.__newobj__, (GapProblem,), dict(self.__dict__))


def _mostly_missing(file: str, summary: str, covered_s: float, line: int) -> None:
    """The one gap rule of a logger that stamps rows as they arrive: its gaps may hold any
    time (reported missing) as long as it is less than the time its samples cover; beyond,
    the file is mostly absence (sessions hours apart in one file, a logger that lost the
    robot), not one run."""
    raise LogError(
        f"{summary}: more time missing than the {covered_s:.4g} s its samples cover",
        file=file,
        where=f"line {line}",
        fix="the file holds separate sessions, not one run: cut it at its longest gap (that "
        "line) and read each part",
    )


def _stamped_on_arrival(
    file: str,
    time_s: np.ndarray,
    step_s: np.ndarray,
    median_s: float,
    line_of: Callable[[int], int],
) -> tuple[float, list[Problem], np.ndarray] | None:
    """A logger that stamps rows as they arrive (a phone app over Bluetooth, a ROS node),
    told by its steps between gaps: their middle half spreads over more than
    `ARRIVAL_SPREAD_PCT` of the median (a clocked instrument's steps are equal to their
    rounding: 0.0% on every analyser, REGBOT and BorealTC log; 4-60% on the phone apps and
    the F1/10 car, docs/log-format.md). Judged by its own pattern, as a bursty logger is:
    its longest regular step is the `BURST_WAIT_QUANTILE` of its steps, a step over
    `GAP_FACTOR` times that is a gap (time missing, reported; `_gap_problems`), and the
    sample period is the mean of the other steps, so that durations and energies follow
    the stamps (the median would miscount both by the distance between the two: 0.65% on
    euc_core/mten4/0). None for a clocked logger."""
    between_s = step_s[step_s <= GAP_FACTOR * median_s]
    q25_s, q75_s = (float(q) for q in np.quantile(between_s, [0.25, 0.75]))
    if q75_s - q25_s <= ARRIVAL_SPREAD_PCT / 100.0 * median_s:
        return None
    longest_s = float(np.quantile(step_s, BURST_WAIT_QUANTILE))
    gaps, period_s, missing_s = _gaps_beyond(time_s, step_s, longest_s)
    kept_s = np.delete(step_s, gaps)
    note = Problem(
        "uneven",
        f"uneven time stamps, as a logger writes rows when they arrive (steps of "
        f"{1e3 * float(kept_s.min()):.3g}-{1e3 * float(kept_s.max()):.3g} ms between gaps, "
        f"the middle half {1e3 * q25_s:.3g}-{1e3 * q75_s:.3g} ms): the sample period is "
        f"their mean, {1e3 * period_s:.4g} ms, so that durations and energies follow the "
        f"stamps (their median, {1e3 * median_s:.4g} ms, would count "
        f"{100 * (median_s / period_s - 1):+.2g}% of both); {gaps.size} gap(s) beyond "
        f"{GAP_FACTOR:g} x its 90th-percentile step, {1e3 * longest_s:.3g} ms: "
        f"{missing_s:.4g} s missing (not counted)",
    )
    pattern = f" (beyond this logger's steps of up to {1e3 * longest_s:.3g} ms; not counted)"
    return _noted(file, time_s, gaps, period_s, longest_s, line_of, pattern, note)


def _is_bursty(time_s: np.ndarray, step_s: np.ndarray, gaps: np.ndarray) -> bool:
    """A logger that writes in bursts (rows a few ms apart, then seconds of nothing: phone
    apps, ROS bridges): its long steps are its habit, not dropped samples. Told by both
    `BURSTY_STEP_SHARE` of the steps being long (at least `BURSTY_MIN_WAITS` of them) and
    `BURSTY_TIME_SHARE` of the time passing in them; a logger that drops samples now and
    then (under `MAX_GAP_PCT` of its time: what is read at all) is never taken for one."""
    if gaps.size <= BURSTY_STEP_SHARE * step_s.size or gaps.size < BURSTY_MIN_WAITS:
        return False
    span_s = float(time_s[-1] - time_s[0])
    return float(np.sum(step_s[gaps])) > BURSTY_TIME_SHARE * span_s


def _bursty(
    file: str,
    time_s: np.ndarray,
    step_s: np.ndarray,
    waits: np.ndarray,
    line_of: Callable[[int], int],
) -> tuple[float, list[Problem], np.ndarray]:
    """A bursty log judged by its own pattern (log-format.md, "Bad input"): its waits (the
    steps `waits`, long against the median step) are its spacing; a step over `GAP_FACTOR`
    times its longest regular wait (the `BURST_WAIT_QUANTILE` of its waits) is a gap, and
    its time beyond one sample is reported missing, never counted as zero power nor as
    covered. Each sample holds the mean step over the time covered (the gaps' excess left
    out), so the run's energy (samples x that period, additive over phases) is its mean
    power over the time the log covers."""
    waits_s = step_s[waits]
    wait_s = float(np.quantile(waits_s, BURST_WAIT_QUANTILE))
    gaps, period_s, missing_s = _gaps_beyond(time_s, step_s, wait_s)
    in_burst_s = np.delete(step_s, waits)
    covered_s = period_s * time_s.size
    burst_ms = (
        f"{1e3 * float(in_burst_s.min()):.3g}-{1e3 * float(in_burst_s.max()):.3g} ms"
        if in_burst_s.size
        else "none"
    )
    note = Problem(
        "bursty",
        f"bursty time stamps: rows in bursts (steps of {burst_ms}) with waits of "
        f"{float(waits_s.min()):.3g}-{float(waits_s.max()):.3g} s between them ({waits.size} of "
        f"{step_s.size} steps): judged by this pattern, not the median step; energy over the "
        f"{covered_s:.6g} s the log covers, at its mean step, "
        f"{1e3 * period_s:.4g} ms; {gaps.size} gap(s) beyond waits of {GAP_FACTOR:g} x "
        f"{wait_s:.3g} s, {missing_s:.4g} s missing (not counted)",
    )
    pattern = f" (beyond this bursty logger's waits of up to {wait_s:.3g} s; not counted)"
    return _noted(file, time_s, gaps, period_s, wait_s, line_of, pattern, note)


def _gaps_beyond(
    time_s: np.ndarray, step_s: np.ndarray, longest_s: float
) -> tuple[np.ndarray, float, float]:
    """The gaps of a stamping logger whose longest regular step is `longest_s` (the steps
    over `GAP_FACTOR` times it), its period (the mean of the other steps, to 10 digits) and
    the time missing [s] (each gap's step beyond one period)."""
    gaps = np.flatnonzero(step_s > GAP_FACTOR * longest_s)
    regular = step_s.size - gaps.size
    gap_steps_s = float(np.sum(step_s[gaps]))
    period_s = float(f"{(float(time_s[-1] - time_s[0]) - gap_steps_s) / regular:.10g}")
    return gaps, period_s, gap_steps_s - gaps.size * period_s


def _noted(
    file: str,
    time_s: np.ndarray,
    gaps: np.ndarray,
    period_s: float,
    spacing_s: float,
    line_of: Callable[[int], int],
    pattern: str,
    note: Problem,
) -> tuple[float, list[Problem], np.ndarray]:
    """A stamping logger's period, its `note` and its gaps' problems (`_gap_problems`, judged
    against its own longest regular step `spacing_s`), and the gaps."""
    if not gaps.size:
        return period_s, [note], gaps
    gap_list = _gap_problems(
        file, time_s, gaps, period_s, spacing_s, line_of, pattern, stamped=True
    )
    return period_s, [note, *gap_list], gaps


def _grid_is_nearer(energies_J: tuple[float, float, float]) -> bool:
    """Whether a stamping logger's rows are read on the even grid (`holdgrid`): when each
    row held for the mean step misses the hold integral by more than `UNEVEN_PCT` (the bar
    of every energy the stamps can miscount) and the grid misses it by less. Else the rows
    are kept as logged (the grid would drop the rows of a burst and shift the others by
    up to a step, for no better energy: on a short log its rounding is as large)."""
    hold_J, mean_J, grid_J = energies_J
    if hold_J == 0.0 or not np.isfinite(hold_J):
        return False
    mean_off = abs(mean_J / hold_J - 1.0)
    return mean_off > UNEVEN_PCT / 100.0 and abs(grid_J / hold_J - 1.0) < mean_off


def _on_the_grid(note: Problem, energies_J: tuple[float, float, float]) -> Problem:
    """`note` (a stamping logger's pattern) with how its rows are read said, measured on the
    log itself against the hold integral (each row over its own step): each row held for
    the mean step, or, where that is further off than `_grid_is_nearer` allows, on an even
    grid by sample and hold (`holdgrid`)."""
    hold_J, mean_J, grid_J = energies_J
    if hold_J == 0.0 or not np.isfinite(hold_J):
        return note
    mean_pct = 100.0 * (mean_J / hold_J - 1.0)
    grid_pct = 100.0 * (grid_J / hold_J - 1.0)
    hold = f"the hold integral (each row over its own step, {hold_J:.6g} J)"
    if _grid_is_nearer(energies_J):
        how = (
            f"read on an even grid at that step, each point the last row before it (sample "
            f"and hold): the energy is {grid_pct:+.2g}% off {hold}, where each row held for "
            f"the mean step would be {mean_pct:+.2g}% off"
        )
    else:
        how = f"each row holding that step, the energy is {mean_pct:+.2g}% off {hold}"
    return Problem(note.kind, f"{note.message}; {how}", note.t_start_s, note.duration_s)


def _check_period(file: str, period_s: float) -> None:
    """A sample period from the time stamps outside the plausible range: the time column is
    in another unit than read (`time_us` holding seconds, `--time-unit` wrong)."""
    low_s, high_s = SAMPLE_PERIOD_RANGE_S
    if not low_s <= period_s <= high_s:
        raise LogError(
            f"the time stamps give a sample period of {period_s:.4g} s, outside the plausible "
            f"{low_s:g}-{high_s:g} s",
            file=file,
            fix="the time column is in another unit than read: check its name and --time-unit",
        )


def _time_error(
    file: str, time_s: np.ndarray, step_s: np.ndarray, line_of: Callable[[int], int]
) -> None:
    """Raise the error for time stamps that are not all finite or do not go forwards: the
    first non-finite stamp, else the first step that is not forwards; else return."""
    if not np.isfinite(time_s).all():
        index = int(np.argmax(~np.isfinite(time_s)))
        raise LogError(
            "time is missing, NaN or inf",
            file=file,
            where=f"line {line_of(index)}",
            fix="fix or delete that line",
        )
    if not (step_s <= 0).any():
        return  # finite stamps whose steps overflow (1e308 apart): nothing wrong here
    index = int(np.argmax(step_s <= 0))
    what = "is duplicated" if step_s[index] == 0 else "goes backwards"
    raise LogError(
        f"time {what} (t = {time_s[index + 1]:.7g} s after {time_s[index]:.7g} s)",
        file=file,
        where=f"line {line_of(index + 1)}",
        fix="the log is out of order or two logs were joined; sort or split it",
    )


#: Every this-many-th step is looked at to guess the median (`_median_10_digits`).
_MEDIAN_STRIDE = 64


def _median_10_digits(step_s: np.ndarray) -> tuple[float, bool]:
    """`float(f"{np.median(step_s):.10g}")`, without sorting the steps when it can be had by
    counting: the median of a strided subsample gives a guess `c` (10 significant digits);
    if fewer than half the steps lie below the band of values that round to `c` and fewer
    than half above it, both middle steps lie in that band, so their mean rounds to `c` too
    (correctly rounded printing is monotonic). Two counting passes instead of a partial
    sort (about 25 ns a step, as much as parsing a short line); when the guess misses (an
    irregular log) the steps are sorted in place as before: the second value says whether
    `step_s` was reordered so."""
    n = step_s.size
    guess = float(np.median(step_s[::_MEDIAN_STRIDE]))
    rounded = f"{guess:.10g}"
    center = float(rounded)
    if np.isfinite(center) and center > 0:
        unit = 10.0 ** (np.floor(np.log10(center)) - 9)  # one unit in the 10th digit
        for share in (0.49, 0.049):  # narrower if the digit's unit changes below `center`
            low, high = center - share * unit, center + share * unit
            if f"{low:.10g}" == rounded and f"{high:.10g}" == rounded:
                below = int(np.count_nonzero(step_s < low))
                above = int(np.count_nonzero(step_s > high))
                # the middle steps have ranks (n - 1) // 2 and n // 2 (0-based)
                if below <= (n - 1) // 2 and above <= n - 1 - n // 2:
                    return center, False
                break
    return float(f"{float(np.median(step_s, overwrite_input=True)):.10g}"), True
