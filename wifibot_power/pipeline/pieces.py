"""Logs of a batch that hold the same recording in part: a piece cut out of a longer log
given beside it (a logger's file and the files cut from it at its gaps), or two logs that
share a stretch of samples. A fit would count those samples twice, and the held-out check
could fit on a log and test on its piece: an accuracy that only looks good (the F1/10
excerpts, ds5 and its three sides, gave a drive-model MAPE of 2.8% so; BorealTC's snow run
pro_12 is the first 183 rows of pro_13, in the public data set).

Each worker returns the run's `piece_signature`: hashes of short windows of its samples
(`WINDOW_SAMPLES` values of power, and of speed when there is one), each starting at an
anchor the content chooses: a sample whose power's mixed bits (`_anchor_bits`) end in those
of `_PATTERN` (content-defined chunking, as rsync's and the "winnowing" fingerprints of
Schleimer, Wilkerson & Aiken 2003), so a piece, wherever it was cut, has the windows of the
log it came from at the same samples. A run anchors where `level` low bits agree: 4 (one
sample in 16) up to `LONG_SAMPLES` samples, one bit more each time the log doubles past it,
so a run keeps about 1,000 windows at most (the test is the only pass over every sample); a
window knows how many bits its anchor agrees on, and two runs are compared on the windows
both would have taken. (So a piece far shorter than a long log holds few windows at the long
log's level: a piece under ~1/60 of its log is too short to tell.) A value held over several
samples is hashed once (a log read on a hold grid repeats rows).

`overlaps` compares the signatures in the calling process: a log is a piece of a longer log
when at least `PIECE_SHARE` of its judged windows are the other's, each at about its
neighbour's offset (`_chained`: a resampled piece drifts by a row now and then), and they
reach over `PIECE_REACH` of its length; two logs share a stretch when `MIN_WINDOWS` or more
windows are found so, but not enough for a piece. Windows of fewer than `MIN_VALUES`
different values are left out (a quantized reading flicking between two levels is no
recording's own), and the one-offset rule leaves out windows equal by chance. Time is not
hashed: a piece's clock often restarts at 0.
"""

from __future__ import annotations

import base64
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

    from wifibot_power.run import Run

#: values in a window hashed, after a value held over several samples is taken once (a log
#: read on a hold grid repeats and skips its rows: the F1/10 side ds5_b, 691 rows, shares 33
#: of its 46 windows of 8 with the log it was cut from, 20 of 45 of 16)
WINDOW_SAMPLES = 8
#: at least this many different values in a window: fewer (a quantized reading flicking
#: between two levels) say nothing of which recording it is
MIN_VALUES = 4
#: the low bits an anchor's `_anchor_bits` agree with (24 bits: a level up to 24)
_PATTERN = 0x96E1D2B4870B
#: the fewest low bits an anchor agrees on: one sample in 2**4 = 16
LEVEL = 4
#: a run longer than this [samples] anchors on one more bit each time its length doubles
LONG_SAMPLES = 16_384
#: samples taken after an anchor to find `WINDOW_SAMPLES` values (a held value repeats)
SPAN_SAMPLES = 24
#: a log is a piece of another when this share of its judged windows are found in it at one
#: offset (a resampled piece's windows differ where its grid skipped a row: a share, not all)
PIECE_SHARE = 0.5
#: ... and those windows reach over this share of its own (an overlap at one end does not)
PIECE_REACH = 0.8
#: about one offset: two neighbouring shared windows within this many samples (a resampled
#: piece drifts by a row now and then), or `OFFSET_BAND` of the samples between them if more
OFFSET_SAMPLES = 4
OFFSET_BAND = 0.1
#: fewer windows judged than this: too short to tell (an anchor every ~16 samples: ~130
#: samples)
MIN_WINDOWS = 8

#: odd 64-bit constants: mixing a sample's bits (`_mixed`) and weighting a window's samples
_MIX = 0x9E3779B97F4A7C15
_MIX_SPEED = 0xC2B2AE3D27D4EB4F
#: a window's bytes in a signature: its hash, first sample and level
_WINDOW_BYTES = 8 + 4 + 1
#: samples the anchor test takes at a time (`_anchors`): 256 kB of scratch
_ANCHOR_CHUNK = 32_768


@dataclass(frozen=True)
class PieceSignature:
    """A run's window hashes (sorted, unique), each window's first sample and its anchor's
    level (low bits agreeing with `_PATTERN`), the run's sample count and its own level."""

    hashes: np.ndarray  # uint64
    positions: np.ndarray  # int64
    levels: np.ndarray  # uint8
    samples: int
    level: int

    def encode(self) -> str:
        """As text (base64 of the arrays), for the fingerprint a batch compares and keeps."""
        raw = (
            self.hashes.astype("<u8").tobytes()
            + self.positions.astype("<u4").tobytes()  # a log of 4 G samples is not read
            + self.levels.astype("u1").tobytes()
        )
        return f"{self.samples}:{self.level}:{base64.b64encode(raw).decode('ascii')}"

    @classmethod
    def decode(cls, text: str) -> PieceSignature:
        import numpy as np

        samples, level, raw = text.split(":", 2)
        data = base64.b64decode(raw)
        n = len(data) // _WINDOW_BYTES
        hashes = np.frombuffer(data[: 8 * n], dtype="<u8").astype(np.uint64)
        positions = np.frombuffer(data[8 * n : 12 * n], dtype="<u4").astype(np.int64)
        levels = np.frombuffer(data[12 * n :], dtype=np.uint8).copy()
        return cls(hashes, positions, levels, int(samples), int(level))


def run_level(samples: int) -> int:
    """The low bits a run of `samples` anchors on: `LEVEL`, one more each doubling past
    `LONG_SAMPLES`."""
    import math

    return LEVEL + max(0, math.ceil(math.log2(max(samples, 1) / LONG_SAMPLES)))


def piece_signature(run: Run) -> PieceSignature:
    """The run's window hashes at its content-defined anchors (module docstring). Only the
    anchor test passes over every sample (`_anchors`); a window is the `WINDOW_SAMPLES`
    samples after its anchor, or where a value is held in them, the first as many values
    of the `SPAN_SAMPLES` after it."""
    import numpy as np

    power = np.ascontiguousarray(run.power_W, dtype=np.float64).view(np.uint64)
    samples = int(power.size)
    level = run_level(samples)
    starts = _anchors(power, level)
    starts = starts[starts + WINDOW_SAMPLES <= samples]
    speed = None
    if run.speed_mps is not None and run.speed_mps.size == samples:
        speed = np.ascontiguousarray(run.speed_mps, dtype=np.float64).view(np.uint64)
    windows, kept = _held_once(power, speed, starts, WINDOW_SAMPLES)
    repeats = ~kept  # a value held inside the window: take the wider span, each value once
    if repeats.any():
        wide, wide_kept = _held_once(power, speed, starts[repeats], SPAN_SAMPLES)
        windows[repeats] = wide
        kept[repeats] = wide_kept
    windows, starts = windows[kept], starts[kept]
    ordered = np.sort(windows, axis=1)
    varied = 1 + (ordered[:, 1:] != ordered[:, :-1]).sum(axis=1) >= MIN_VALUES
    weights = (np.arange(1, WINDOW_SAMPLES + 1, dtype=np.uint64) * np.uint64(_MIX)) | np.uint64(1)
    hashes = (windows[varied] * weights).sum(axis=1, dtype=np.uint64)
    # sorted; a window seen twice in the run is left out (a pattern of the reading, as a
    # quantized reading's few values make, is no recording's own)
    hashes, first, seen = np.unique(hashes, return_index=True, return_counts=True)
    hashes, starts = hashes[seen == 1], starts[varied][first[seen == 1]]
    # the low bits each anchor agrees on: the trailing zeros of its bits xor the pattern
    differ = _anchor_bits(power[starts]) ^ np.uint64(_PATTERN & 0xFFFFFF)
    levels = np.bitwise_count((differ & (~differ + np.uint64(1))) - np.uint64(1))
    return PieceSignature(hashes, starts.astype(np.int64), levels.astype(np.uint8), samples, level)


def _anchor_bits(power_bits: np.ndarray) -> np.ndarray:
    """The bits an anchor is chosen by: a sample's power bits mixed (the high half folded
    onto the low, times `_MIX`, as splitmix64's finalizer: Steele, Lea & Flood 2014), their
    top 24 bits. A value with a short mantissa (0.25 W steps: its low 45 bits 0) anchors
    as a noisy reading does."""
    import numpy as np

    mixed = np.right_shift(power_bits, np.uint64(32))  # in place from here: one array
    np.bitwise_xor(mixed, power_bits, out=mixed)
    np.multiply(mixed, np.uint64(_MIX), out=mixed)
    return np.right_shift(mixed, np.uint64(40), out=mixed)


def _anchors(power_bits: np.ndarray, level: int, chunk: int = _ANCHOR_CHUNK) -> np.ndarray:
    """Samples whose `_anchor_bits` agree with `_PATTERN` in their lowest `level` bits, the
    first of each held value (a value held over samples anchors once, where it starts).
    The test by stretches of `chunk` samples, each through one scratch array that stays in
    the processor's cache (its five passes over a stretch instead of over the whole log:
    ~1.3x faster on 10 kHz logs), on the mixed bits in place (bits 40 up of `_anchor_bits`'
    product compared where they are, not shifted down)."""
    import numpy as np

    low = (1 << level) - 1
    mask, want = np.uint64(low << 40), np.uint64((_PATTERN & low) << 40)
    size = power_bits.size
    scratch = np.empty(min(chunk, size), dtype=np.uint64)
    match = np.empty(scratch.size, dtype=bool)
    parts = []
    for first in range(0, size, chunk):
        bits = power_bits[first : first + chunk]
        mixed, hit = scratch[: bits.size], match[: bits.size]
        np.right_shift(bits, np.uint64(32), out=mixed)  # as `_anchor_bits`, in the scratch
        np.bitwise_xor(mixed, bits, out=mixed)
        np.multiply(mixed, np.uint64(_MIX), out=mixed)
        np.bitwise_and(mixed, mask, out=mixed)
        np.equal(mixed, want, out=hit)
        parts.append(np.flatnonzero(hit) + first)
    found = np.concatenate(parts) if parts else np.zeros(0, dtype=np.intp)
    after_first = int(found.size > 0 and found[0] == 0)  # sample 0 is no repeat
    held = found[after_first:]
    repeat = np.zeros(found.size, dtype=bool)
    repeat[after_first:] = power_bits[held] == power_bits[held - 1]
    return found[~repeat]  # (in order, as found: a mask, not a set difference's sort)


def _held_once(
    power: np.ndarray, speed: np.ndarray | None, starts: np.ndarray, span: int
) -> tuple[np.ndarray, np.ndarray]:
    """The first `WINDOW_SAMPLES` values after each start within `span` samples, a held
    value once (mixed: power bits xor speed bits times a constant, times `_MIX`), and
    whether the span held that many."""
    import numpy as np

    spans = np.minimum(starts[:, None] + np.arange(span), power.size - 1)
    mixed = power[spans]
    if speed is not None:
        mixed = mixed ^ (speed[spans] * np.uint64(_MIX_SPEED))
    mixed = mixed * np.uint64(_MIX)
    unchanged = np.zeros(mixed.shape, dtype=bool)
    unchanged[:, 1:] = mixed[:, 1:] == mixed[:, :-1]
    unchanged |= starts[:, None] + np.arange(span) >= power.size  # past the end
    if span == WINDOW_SAMPLES:
        return mixed, ~unchanged.any(axis=1)
    order = np.argsort(unchanged, axis=1, kind="stable")[:, :WINDOW_SAMPLES]  # changes first
    kept = ~np.take_along_axis(unchanged, order, axis=1).any(axis=1)
    return np.take_along_axis(mixed, order, axis=1), kept


def _empty_u8() -> np.ndarray:
    import numpy as np

    return np.empty(0, dtype=np.uint64)


@dataclass(frozen=True)
class Overlap:
    """Log `this` (an index of the batch) shares samples with log `other`: `windows` of its
    `judged` windows at about one offset (`this`'s sample k is near `other`'s k + `offset`),
    reaching over `reach` of the span of its judged windows."""

    this: int
    other: int
    windows: int
    judged: int
    offset: int
    reach: float

    #: `this` is shorter than `other` (of two logs as long, neither is a piece of the other)
    shorter: bool = True

    @property
    def is_piece(self) -> bool:
        """Its samples are the other log's, throughout, and fewer (module docstring)."""
        share, reach = self.windows >= PIECE_SHARE * self.judged, self.reach >= PIECE_REACH
        return self.shorter and share and reach

    @property
    def share(self) -> float:
        return self.windows / self.judged


def overlaps(signatures: list[str | None]) -> list[Overlap]:
    """Every pair of logs sharing `MIN_WINDOWS` windows or more at about one offset, as an
    `Overlap` of the shorter (`this`; of two alike, the later) in the longer. `signatures`
    as `PieceSignature.encode` gives them. Only logs sharing a window hash are compared: a
    log with the first log (in the batch's order) that holds each of its windows, found by
    one dictionary over every log's hashes in plain Python: a batch with no overlap (a warm
    batch, every result kept) loads no numpy. The dictionary is filled from the last log to
    the first, each log's hashes at once (`dict.update`, the earlier log's index written
    over the later's), and read a log at a time (`map`): no Python step per window."""
    hashes = {k: _hashes(text) for k, text in enumerate(signatures) if text is not None}
    first_with: dict[int, int] = {}
    for k in reversed(hashes):
        first_with.update(dict.fromkeys(hashes[k], k))
    pairs = {
        (other, k) for k, own in hashes.items() for other in set(map(first_with.__getitem__, own))
    }
    pairs = {(other, k) for other, k in pairs if other != k}
    decoded = {k: PieceSignature.decode(signatures[k]) for pair in pairs for k in pair}  # type: ignore[arg-type]
    found = [_overlap(a, b, decoded[a], decoded[b]) for a, b in sorted(pairs)]
    return [o for o in found if o is not None]


def _hashes(text: str) -> list[int]:
    """The window hashes of an encoded signature (its first 8 bytes a window, as integers)."""
    data = base64.b64decode(text.split(":", 2)[2])
    n = len(data) // _WINDOW_BYTES
    return memoryview(data)[: 8 * n].cast("Q").tolist()


def _overlap(a: int, b: int, first: PieceSignature, second: PieceSignature) -> Overlap | None:
    """Whether the shorter of logs `a` and `b` shares windows with the longer at about one offset
    (`overlaps`), judged on the windows both would have taken (`level`)."""
    import numpy as np

    (this, small), (other, large) = sorted(
        ((a, first), (b, second)), key=lambda pair: (pair[1].samples, -pair[0])
    )
    level = max(small.level, large.level)  # the windows both runs would have taken
    judged = small.levels >= level
    taken = large.levels >= level
    _, in_small, in_large = np.intersect1d(
        small.hashes[judged], large.hashes[taken], assume_unique=True, return_indices=True
    )
    if in_small.size < MIN_WINDOWS:
        return None
    order = np.argsort(small.positions[judged][in_small])
    positions = small.positions[judged][in_small][order]
    offsets = large.positions[taken][in_large][order] - positions
    chained = _chained(positions, offsets)
    if chained.sum() < MIN_WINDOWS:
        return None
    own = small.positions[judged]
    span = max(int(own.max() - own.min()), 1)
    reach = float(positions[chained].max() - positions[chained].min()) / span
    offset = int(np.median(offsets[chained]))
    shorter = small.samples < large.samples
    return Overlap(this, other, int(chained.sum()), int(judged.sum()), offset, reach, shorter)


def _chained(positions: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Which shared windows (in the order of their samples) have a neighbour at about their
    offset: within `OFFSET_SAMPLES`, or `OFFSET_BAND` of the samples between them (a piece
    re-timed onto a grid drifts by a row now and then). Windows equal by chance (a reading
    of few values) sit at offsets scattered over the logs: no neighbour agrees."""
    import numpy as np

    tolerance = np.maximum(OFFSET_SAMPLES, OFFSET_BAND * np.diff(positions))
    agree = np.abs(np.diff(offsets)) <= tolerance
    chained = np.zeros(positions.size, dtype=bool)
    chained[:-1] |= agree
    chained[1:] |= agree
    return chained
