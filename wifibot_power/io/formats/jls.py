"""Joulescope recordings (`.jls`, log-format.md section 3), read with Joulescope's own
library `pyjls` (the optional extra `wbpower[jls]`).

A recording holds fixed-rate signals (up to 2 MHz): `current` [A], `voltage` [V] and, from
a JS220, `power` [W]. Power is the `power` signal where there is one (the instrument's own
sample-by-sample product), else current x voltage sample by sample, else current x
`--supply-voltage`; `--power-column`, `--current-column` and `--voltage-column` name the
signals when a recording's names differ.

Bounded memory: the full-rate samples are read in chunks of `CHUNK_SAMPLES` and reduced to
the means of blocks of `block` samples, with `block` the larger of `rate / MAX_RATE_HZ` (no
finer than the reference analyser's ~10 kHz: segmentation needs no more) and
`length / MAX_SAMPLES` (an hour at 1 MHz gives 2 M samples of 1.8 ms, not 3.6 G): memory is
flat in the recording's length. The block means are the run's samples; their energy is the
full-rate sum exactly (the rectangle rule over the full-rate samples, up to float
rounding), except for the last `length mod block` samples, which fill no block: they are
left out and reported with their energy. The summary levels the file also holds
(`Reader.fsr_statistics`) are not used: pyjls says their internal block boundaries are
approximate, so their energy would not be the full-rate sum.

Missing samples (the instrument dropped them: pyjls reads NaN) are a gap: each block's mean
is over the samples it has, a block without any is left out (the run's time then shows the
gap, whose energy is not counted), and the gap is reported; a gap longer than
`validate.MAX_GAP_S`, or gaps over `validate.MAX_GAP_PCT` of the recording, stop the
analysis, as for any log.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from wifibot_power.errors import LogError
from wifibot_power.io.formats.files import FileFormat, Samples, require
from wifibot_power.io.options import FORMAT_JLS, JLS_SUFFIX, ReadOptions
from wifibot_power.io.validate import MAX_GAP_PCT, MAX_GAP_S
from wifibot_power.run import Problem

#: The finest block rate the run keeps [Hz] (the reference analyser's 9765.625 Hz, rounded).
MAX_RATE_HZ = 10_000
#: The most samples a run keeps (16 MB of float64 power): memory flat in the length.
MAX_SAMPLES = 2_000_000
#: Full-rate samples read at a time (a few tens of MB for current, voltage and power).
CHUNK_SAMPLES = 1 << 20


class Joulescope(FileFormat):
    """A Joulescope `.jls` recording."""

    name: ClassVar[str] = FORMAT_JLS

    def claims(self, path: Path) -> bool:
        return path.name.lower().endswith(JLS_SUFFIX)

    def read_samples(self, path: Path, options: ReadOptions) -> Samples:
        pyjls = require("pyjls", "jls", path, "Joulescope recordings")
        if not path.is_file():
            raise LogError("no such file", file=path, fix="check the path")
        try:
            reader = pyjls.Reader(str(path))
        except Exception as exc:  # pyjls raises RuntimeError and its own for a bad file
            raise LogError(
                f"not a readable Joulescope recording ({exc.__class__.__name__}: {exc})",
                file=path,
                fix="check the file is a complete .jls",
            ) from None
        try:
            return _read(path, reader, options)
        finally:
            reader.close()


def block_of(rate_Hz: float, length: int) -> int:
    """Full-rate samples a run's sample is the mean of (module docstring)."""
    return max(1, math.ceil(rate_Hz / MAX_RATE_HZ), math.ceil(length / MAX_SAMPLES))


def _signals(path: Path, reader: Any) -> dict[str, Any]:
    """The fixed-rate signals, by lower-case name."""
    found = {}
    for signal in reader.signals.values():
        if signal.signal_id == 0 or signal.sample_rate <= 0:
            continue  # the annotation signal, variable-rate signals
        found[signal.name.strip().lower()] = signal
    return found


def _pick(path: Path, signals: dict[str, Any], options: ReadOptions) -> dict[str, Any]:
    """The signals power comes from: {"power": s} or {"current": s, "voltage": s | None}."""

    def named(name: str, option: str) -> Any:
        signal = signals.get(name.strip().lower())
        if signal is None:
            raise LogError(
                f"no signal '{name}' (signals: {', '.join(sorted(signals)) or 'none'})",
                file=path,
                fix=f"check {option}",
            )
        return signal

    def by_unit(quantity: str, unit: str) -> Any:
        if quantity in signals:
            return signals[quantity]
        matches = [s for s in signals.values() if s.units.strip() == unit]
        return matches[0] if len(matches) == 1 else None

    if options.power_columns:
        if len(options.power_columns) > 1:
            raise LogError(
                "a recording's power is one signal", file=path, fix="name one --power-column"
            )
        return {"power": named(options.power_columns[0], "--power-column")}
    if options.current_column:
        current = named(options.current_column, "--current-column")
        voltage = (
            named(options.voltage_column, "--voltage-column") if options.voltage_column else None
        )
    else:
        power = by_unit("power", "W")
        if power is not None:
            return {"power": power}
        current, voltage = by_unit("current", "A"), by_unit("voltage", "V")
    if current is None:
        raise LogError(
            f"no power or current signal (signals: {', '.join(sorted(signals)) or 'none'})",
            file=path,
            fix="name the signals with --power-column, or --current-column and --voltage-column",
        )
    if voltage is None and options.supply_voltage_V is None:
        raise LogError(
            "a current signal but no voltage signal",
            file=path,
            fix="give --supply-voltage V, or name the voltage signal with --voltage-column",
        )
    return {"current": current, "voltage": voltage}


def _read(path: Path, reader: Any, options: ReadOptions) -> Samples:
    picked = {k: s for k, s in _pick(path, _signals(path, reader), options).items() if s}
    first = next(iter(picked.values()))
    rate_Hz, length = float(first.sample_rate), int(first.length)
    for signal in picked.values():
        if float(signal.sample_rate) != rate_Hz or int(signal.length) != length:
            raise LogError(
                f"signals '{first.name}' and '{signal.name}' differ in rate or length "
                f"({rate_Hz:g} Hz x {length} against {signal.sample_rate:g} Hz x "
                f"{signal.length})",
                file=path,
                fix="name signals recorded together",
            )
    block = block_of(rate_Hz, length)
    blocks = length // block
    sums = np.empty(blocks, dtype=np.float64)
    counts = np.full(blocks, block, dtype=np.int64)
    gaps = _Gaps()
    chunk = max(block, CHUNK_SAMPLES // block * block)
    for start in range(0, blocks * block, chunk):
        n = min(chunk, blocks * block - start)
        power_W = _power_chunk(path, reader, picked, start, n, options)
        first_block = start // block
        finite = np.isfinite(power_W)
        if finite.all():
            sums[first_block : first_block + n // block] = power_W.reshape(-1, block).sum(axis=1)
            gaps.add(None, start)
            continue
        gaps.add(~finite, start)
        per_block = power_W.reshape(-1, block)
        sums[first_block : first_block + n // block] = np.nansum(per_block, axis=1)
        counts[first_block : first_block + n // block] = finite.reshape(-1, block).sum(axis=1)
        del per_block
    period_s = block / rate_Hz
    time_s = None
    if counts.min() == 0:  # whole blocks missing: left out, so that time shows the gap
        kept = counts > 0
        time_s = np.flatnonzero(kept) * period_s
        sums, counts = sums[kept], counts[kept]
    mean_W = sums / counts
    problems = []
    if block > 1:
        problems.append(
            Problem(
                "blocks",
                f"{length:,} samples at {rate_Hz:g} Hz read as the means of blocks of {block} "
                f"({1e3 * period_s:.4g} ms): energy is the full-rate sum",
            )
        )
    tail = length - blocks * block
    if tail:
        tail_W = _power_chunk(path, reader, picked, blocks * block, tail, options)
        tail_J = float(np.nansum(tail_W, dtype=np.float64)) / rate_Hz
        problems.append(
            Problem(
                "tail",
                f"the last {tail} sample(s) ({tail / rate_Hz:.3g} s, {tail_J:.4g} J) fill no "
                f"block of {block}: left out",
                blocks * period_s,
                tail / rate_Hz,
            )
        )
    problems += gaps.problems(path, rate_Hz, length)
    metadata = {"sample_period_s": repr(period_s), "instrument": _instrument(reader, first)}
    if options.sample_period_s is not None:
        problems.append(
            Problem(
                "sample_period_ignored",
                f"--sample-period {options.sample_period_s:g} not used: the recording says "
                f"its own rate ({rate_Hz:g} Hz)",
            )
        )
    return Samples(
        power_W=mean_W,
        time_s=time_s,
        metadata=metadata,
        problems=problems,
        gaps_reported=True,
    )


def _power_chunk(
    path: Path, reader: Any, picked: dict[str, Any], start: int, n: int, options: ReadOptions
) -> np.ndarray:
    """Full-rate power [W] of samples start .. start + n, float64."""

    def read(signal: Any) -> np.ndarray:
        try:
            return np.asarray(reader.fsr(signal.signal_id, start, n), dtype=np.float64)
        except Exception as exc:
            raise LogError(
                f"signal '{signal.name}' could not be read at samples {start}-{start + n} "
                f"({exc.__class__.__name__}: {exc})",
                file=path,
                fix="the recording may be cut short: re-save it in the Joulescope UI",
            ) from None

    if "power" in picked:
        return read(picked["power"])
    power_W = read(picked["current"])
    if "voltage" in picked:
        power_W *= read(picked["voltage"])
    else:
        power_W *= float(options.supply_voltage_V)
    return power_W


def _instrument(reader: Any, signal: Any) -> str:
    source = reader.sources.get(signal.source_id)
    if source is None:
        return "Joulescope"
    return " ".join(p for p in (source.vendor, source.model, source.serial_number) if p)


class _Gaps:
    """Stretches of missing (NaN) full-rate samples, across chunks: (start, length)."""

    def __init__(self) -> None:
        self.stretches: list[tuple[int, int]] = []
        self.open_start: int | None = None

    def add(self, missing: np.ndarray | None, start: int) -> None:
        """The missing samples of the chunk from full-rate sample `start` (None: none)."""
        if missing is None:
            self._close(start)
            return
        edges = np.diff(np.concatenate(([0], missing.view(np.int8), [0])))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        if not (starts.size and starts[0] == 0):
            self._close(start)  # a stretch open at the chunk's start ended there
        for s, e in zip(starts.tolist(), ends.tolist(), strict=True):
            begin = self.open_start if self.open_start is not None else start + s
            self.open_start = None
            if e == missing.size:
                self.open_start = begin  # goes on into the next chunk
            else:
                self.stretches.append((begin, start + e - begin))

    def _close(self, at: int) -> None:
        if self.open_start is not None:
            self.stretches.append((self.open_start, at - self.open_start))
            self.open_start = None

    def problems(self, path: Path, rate_Hz: float, length: int) -> list[Problem]:
        self._close(length)
        if not self.stretches:
            return []
        total = sum(n for _, n in self.stretches)
        start, longest = max(self.stretches, key=lambda s: s[1])
        summary = (
            f"{len(self.stretches)} gap(s) of missing samples, {total / rate_Hz:.4g} s in all "
            f"({100 * total / length:.2g}% of the recording), longest {longest / rate_Hz:.4g} s "
            f"from t = {start / rate_Hz:.6g} s"
        )
        if longest / rate_Hz > MAX_GAP_S or 100 * total / length > MAX_GAP_PCT:
            raise LogError(
                summary,
                file=path,
                fix=f"a gap over {MAX_GAP_S:g} s, or gaps over {MAX_GAP_PCT:g}% of the "
                "recording, make energies wrong; re-record, or cut the recording at the gap",
            )
        return [
            Problem(
                "gap",
                f"{summary}: each block's mean power is over the samples it has",
                start / rate_Hz,
                longest / rate_Hz,
            )
        ]
