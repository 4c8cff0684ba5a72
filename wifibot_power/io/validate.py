"""Checks on the samples of a log: the numbers must be ones we can trust.

Vectorised over samples. Errors name the file and the line; short gaps are kept
as reported problems, everything that would make a number quietly wrong is an error.
"""

from __future__ import annotations

import numpy as np

from wifibot_power.errors import LogError
from wifibot_power.run import PAPER_SAMPLE_PERIOD_S, Problem

#: Above this the robot cannot be drawing power: a unit or column mistake.
ABSURD_POWER_W = 1000.0
#: Below this a reading is negative, not an offset around zero.
NEGATIVE_POWER_W = -1.0
#: A dropped-sample gap longer than this (or gaps adding up to more) stops the analysis.
MAX_GAP_S = 0.05
#: Consecutive identical readings at the trace's maximum that mean the range clipped.
SATURATION_SAMPLES = 10


def check_samples(
    file: str,
    time_s: np.ndarray | None,
    power_W: np.ndarray,
    *,
    first_data_line: int,
    default_period_s: float = PAPER_SAMPLE_PERIOD_S,
) -> tuple[float, list[Problem]]:
    """Validate samples; return the sample period [s] and the problems that did not stop reading."""
    problems: list[Problem] = []
    _check_power(file, power_W, first_data_line)
    if time_s is None:
        return default_period_s, problems
    bad = ~np.isfinite(time_s)
    if bad.any():
        index = int(np.argmax(bad))
        raise LogError("time is NaN or inf", file=file, where=f"line {first_data_line + index}",
                       fix="fix or delete that line")
    if time_s.size < 2:
        return default_period_s, problems
    step_s = np.diff(time_s)
    nonpositive = step_s <= 0
    if nonpositive.any():
        index = int(np.argmax(nonpositive))
        what = "duplicated" if step_s[index] == 0 else "goes backwards"
        raise LogError(
            f"time {what} (t = {time_s[index + 1]:.7g} s)", file=file,
            where=f"line {first_data_line + index + 1}",
            fix="the log is out of order or two logs were joined; sort or split it",
        )
    period_s = float(np.median(step_s))
    if abs(period_s - default_period_s) <= 1e-6 * default_period_s:
        period_s = default_period_s  # the stated period, not its float-rounded echo
    gaps = np.flatnonzero(step_s > 1.5 * period_s)
    if gaps.size:
        missing_s = step_s[gaps] - period_s
        longest = int(gaps[np.argmax(missing_s)])
        where = f"line {first_data_line + longest + 1}"
        summary = (
            f"{gaps.size} gap(s) of dropped samples, {missing_s.sum():.4g} s in all, longest "
            f"{missing_s.max():.4g} s at t = {time_s[longest]:.6g} s"
        )
        if missing_s.sum() > MAX_GAP_S:
            raise LogError(
                summary, file=file, where=where,
                fix=f"gaps over {MAX_GAP_S} s in all make energies wrong; re-record or cut the log there",
            )
        for index, missing in zip(gaps, missing_s, strict=True):
            problems.append(Problem("gap", f"dropped samples: {missing:.4g} s", float(time_s[index]),
                                    float(missing)))
    return period_s, problems


def _check_power(file: str, power_W: np.ndarray, first_data_line: int) -> None:
    finite = np.isfinite(power_W)
    if not finite.all():
        index = int(np.argmax(~finite))
        raise LogError(f"power is {power_W[index]}", file=file,
                       where=f"line {first_data_line + index}", fix="fix or delete that line")
    negative = power_W < NEGATIVE_POWER_W
    if negative.any():
        index = int(np.argmax(negative))
        raise LogError(
            f"negative power ({power_W[index]:.4g} W)", file=file,
            where=f"line {first_data_line + index}",
            fix="check the current sign and the columns used (--current-column/--voltage-column)",
        )
    absurd = power_W > ABSURD_POWER_W
    if absurd.any():
        index = int(np.argmax(absurd))
        raise LogError(
            f"absurd power ({power_W[index]:.4g} W, over {ABSURD_POWER_W:g} W)", file=file,
            where=f"line {first_data_line + index}",
            fix="check the units (mA vs A, mW vs W) and the columns used",
        )
    _check_saturation(file, power_W, first_data_line)


def _check_saturation(file: str, power_W: np.ndarray, first_data_line: int) -> None:
    peak = power_W.max()
    at_peak = power_W == peak
    if at_peak.sum() < SATURATION_SAMPLES or peak <= np.median(power_W) * 1.05:
        return
    # longest run of consecutive samples at the peak
    edges = np.diff(np.concatenate(([0], at_peak.view(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    lengths = ends - starts
    longest = int(np.argmax(lengths))
    if lengths[longest] >= SATURATION_SAMPLES:
        raise LogError(
            f"saturated readings: {lengths[longest]} samples flat at the maximum {peak:.6g} W",
            file=file, where=f"line {first_data_line + int(starts[longest])}",
            fix="the analyser range clipped; re-record with a higher current range",
        )
