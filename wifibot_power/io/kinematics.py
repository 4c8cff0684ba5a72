"""What a log's motion columns cannot be, said as problems (read as logged: a unit slip is
likely, not certain).

`lateral_problem`: a rate of turn against the speed: the lateral acceleration they make,
|v·ω| (a body moving at v on a path turning at ω accelerates sideways at v·ω), sustained
beyond what tyres hold.

Wheels hold a sideways force up to μ·m·g: μ ~ 1 on dry asphalt for street tyres, ~1.7 for
racing slicks, far less for a skid-steer robot's wheels or tracks; without the downforce of
a racing car's wings no wheeled vehicle turns at `LATERAL_LIMIT_MPS2` (3 g). A log whose
|v·ω|, averaged over `WINDOW_S`, goes beyond it most likely has its rate of turn in deg/s
under a rad/s header (57.3x: a 0.35 rad/s arc at 1 m/s then reads 2 g, at 3 m/s 6 g), which
the absurd-rate check (validate.py, 30 rad/s) catches only in fast spins; or a speed too
large. A vehicle spinning out at speed (its heading turning while it slides) also reads so,
which is why this is said, not refused. Measured on the real logs with both columns
(BorealTC, Vulpi, a VESC e-board ride: docs/real-logs.md): at most 3.3 m/s² (the e-board
carving at 6 m/s), 0.54 on the robots.

`slow_speed_problem`: a speed sampled slower than every `SLOW_SPEED_S`. A robot speeds up and
brakes within a second or two; the drive model reads them over 0.5 s windows (drive/windows.py)
and its lag within 1 s. A speed logged every 50 s is most likely a time column in ms read as
seconds (a 20 Hz log's 50 ms steps), which makes every duration and energy of the log 1000x
too large and still fits: the power against the speed is unchanged, and the held-out energies
agree with themselves (measured: simulated free driving with its time x 1000, MAPE 1.2%). The
slowest real speed logs measured step 0.2-0.7 s (phone apps, docs/real-logs.md); a 1 Hz GPS
speed stays under the bound.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from wifibot_power.io.formats.base import TimeSource
from wifibot_power.run import Problem

#: Standard gravity [m/s^2].
G_MPS2 = 9.80665
#: Beyond this sustained |v·ω| [m/s^2] no tyre holds the turn (module docstring).
LATERAL_LIMIT_MPS2 = 3.0 * G_MPS2
#: The time |v·ω| is averaged over [s]: a glitch of one sample in either column is not a turn.
WINDOW_S = 0.5
#: A speed sampled slower than this [s] says nothing of speeding up or braking (docstring).
SLOW_SPEED_S = 2.0


def lateral_problem(
    speed_mps: np.ndarray,
    yaw_rate_radps: np.ndarray,
    period_s: float,
    line_of: Callable[[int], int],
    names: tuple[str, str],
) -> Problem | None:
    """The problem of a sustained |v·ω| over `LATERAL_LIMIT_MPS2` (module docstring), or None.
    `names`: the speed's and the rate of turn's columns, as the message names them."""
    found = lateral_peak(speed_mps, yaw_rate_radps, period_s)
    if found is None:
        return None
    first, worst, window_s = found
    speed_name, turn_name = names
    return Problem(
        "lateral",
        f"line {line_of(first)}: |{speed_name} x {turn_name}| reaches {worst:.3g} m/s^2 "
        f"({worst / G_MPS2:.2g} g) over {window_s:.2g} s, a sideways "
        f"acceleration no tyre holds (over {LATERAL_LIMIT_MPS2 / G_MPS2:.0f} g): the rate of "
        "turn is likely in deg/s, not rad/s (divide it by 57.3), or the speed too large; "
        "read as logged (a vehicle spinning out at speed also reads so)",
        None,
        None,
    )


def lateral_peak(
    speed_mps: np.ndarray, yaw_rate_radps: np.ndarray, period_s: float
) -> tuple[int, float, float] | None:
    """Where a sustained |v·ω| goes over `LATERAL_LIMIT_MPS2`: (the first sample over it, the
    highest window mean [m/s^2], the window [s]), or None. Unknown samples (NaN) count as 0
    (a text log's speed and rate of turn are finite by then: `validate.check_speed`; a
    library caller's need not be)."""
    if speed_mps.size == 0 or yaw_rate_radps.size != speed_mps.size:
        return None
    # the largest |v| times the largest |w| bounds every window's mean: most logs end here,
    # with four reductions instead of the windows' ten passes (1.8 ms a 20 Hz hour's log, 9%
    # of its read); fmax/fmin pass over NaN (an unknown sample)
    if not _magnitude(speed_mps) * _magnitude(yaw_rate_radps) > LATERAL_LIMIT_MPS2:
        return None
    lateral = np.abs(np.nan_to_num(speed_mps) * np.nan_to_num(yaw_rate_radps))
    width = min(max(int(round(WINDOW_S / period_s)), 1), lateral.size)
    sums = np.concatenate(([0.0], np.cumsum(lateral)))
    means = (sums[width:] - sums[:-width]) / width  # [i]: over samples i .. i + width - 1
    over = np.flatnonzero(means > LATERAL_LIMIT_MPS2)
    if not over.size:
        return None
    # named where it starts: the first window's first sample over the bound (a mean over it
    # holds one at least)
    first = int(over[0])
    first += int(np.argmax(lateral[first : first + width] > LATERAL_LIMIT_MPS2))
    return first, float(means.max()), width * period_s


def _magnitude(values: np.ndarray) -> float:
    """The largest |value| of `values`, NaN left out (0 when all are NaN)."""
    top = max(float(np.fmax.reduce(values)), -float(np.fmin.reduce(values)))
    return top if top == top else 0.0  # (NaN == NaN is False: every value NaN)


def slow_speed_problem(period_s: float, time: TimeSource | None) -> Problem | None:
    """The problem of a speed sampled every `period_s` [s] (the log's sample period, as the
    reader takes it: its median step, or its mean step between gaps for uneven stamps) over
    `SLOW_SPEED_S` (module docstring), or None. `time`: the log's time column and its unit
    (None: the period is the metadata's)."""
    if not period_s > SLOW_SPEED_S:
        return None
    if time is None or time.index:  # (an index counts samples of the metadata's period)
        where, fix = "sample_period_s", "if it is in ms, give it in s"
    elif time.scale_s == 1.0:
        where = f"time column '{time.column}'"
        fix = f"if the {where} is in ms, read it with --time-unit ms (or name it time_ms)"
    else:  # read in ms or us already: a unit smaller still is not likely; say what was taken
        where = f"time column '{time.column}', read in units of {time.scale_s:g} s"
        fix = "if that is not its unit, give --time-unit"
    return Problem(
        "slow_speed",
        f"the speed is sampled every {period_s:.3g} s ({where}): too slow to see a robot speed "
        f"up or brake (a second or two); {fix}, or every duration and energy read is 1000x "
        "too large",
        None,
        None,
    )


__all__ = [
    "LATERAL_LIMIT_MPS2",
    "SLOW_SPEED_S",
    "WINDOW_S",
    "lateral_peak",
    "lateral_problem",
    "slow_speed_problem",
]
