"""The drive model as a model family (cli.md, "The drive model"), the second of
`models.registry.FAMILIES`: the thin adapter between the pipeline and `wifibot_power.drive`.
Nothing here computes; it names what the pipeline calls:

- `name`: its section of `fit --json` and model.json, "drive";
- `run_stats(run, segmentation)`: in the worker, the run reduced to bins
  (`drive.stats.drive_stats`: small, picklable; None without a speed, or a step run's speed
  from its phases) and its per-trip sums (`drive.sums.sums_of`: what the fit reads, made where
  the runs are spread over the workers: `WorkerStats`; a plain fit's plan leaves the bins
  out, `WorkerStats.without_bins`, read again from the log if asked for);
  `stats_to_json`/`stats_from_json` for the cache (the bins only: a kept run's sums are
  made again when a fit needs them);
- `fit(records, options)`: the model from every run's statistics (each record's
  `models["drive"]`; `drive.model.fit_drive_stats`; None when no run had a speed);
- `load(section, file=)`: model.json's section back to the model (`DriveModel.from_json`).

What a warm `fit --cache` reads back stays JSON until it is used (`KeptStats`, `KeptDrive`):
a warm `fit --json` prints the kept summary without importing numpy (docs/benchmarks.md).
The fitted `DriveModel` lives in `drive/` and imports nothing of `models` (the package would
import itself through this registry): it has `FittedModel`'s methods without subclassing it.

A batch of free driving alone (no step run) fits this family and not the paper's: `fit`
is then a success, with a note that the paper's models need step runs (`fit.fit_records`).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, ClassVar

from wifibot_power.models.base import FitOptions, FittedModel, ModelFamily

if TYPE_CHECKING:
    from wifibot_power.drive.model import DriveModel
    from wifibot_power.drive.standing import StandingStops
    from wifibot_power.drive.stats import DriveStats
    from wifibot_power.drive.sums import RunSums
    from wifibot_power.drive.windows import RunWindows
    from wifibot_power.phases import Segmentation
    from wifibot_power.run import Run


class KeptStats:
    """A run's drive statistics as the cache kept them (`DriveStats.to_json`), made a
    `DriveStats` at the first attribute asked for."""

    def __init__(self, kept: dict) -> None:
        self.kept = kept

    @functools.cached_property
    def stats(self) -> DriveStats:
        from wifibot_power.drive.stats import DriveStats

        return DriveStats.from_json(self.kept)

    def __getattr__(self, name: str) -> object:
        if name.startswith("__") or name in ("kept", "stats"):
            raise AttributeError(name)
        return getattr(self.stats, name)


class WorkerStats:
    """A run's drive statistics as the worker made them: its bins (`stats`, a `DriveStats`)
    and its per-trip sums (`sums`, a `drive.sums.RunSums`); any other attribute is the bins'.

    A fit reads only the sums (and a few scalars of the bins: `bin_s`, `has_turning`, ...):
    `without_bins()` leaves the bins' arrays out of what goes back to the parent (1.9 MB a
    run of an hour at 20 Hz, against 0.4 MB of sums), unless the run fits itself so well
    that a lag search may need its windows (`drive.sums.AT_RISK_SHARE`). Asked for later (a
    search whose sums lose their digits, a trace), they are read again from the log
    (`read_again`, set by `pipeline.gather`), every such run of the batch at once."""

    def __init__(
        self,
        stats: DriveStats | None,
        sums: RunSums,
        standing: StandingStops | None = None,
        windows: RunWindows | None = None,
    ) -> None:
        self._stats = stats
        self.sums = sums
        #: the windows the sums were made from (in the worker only: `without_bins` sends them
        #: with the bins of a run at risk when they weigh little, `SEND_WINDOWS_SHARE`)
        self._windows = windows
        #: a current proxy's stops (`drive.standing.standing_stops`: the idle check's), else None
        self.standing = standing
        #: the bins' scalars (`DriveStats` with its arrays None) while the bins are left out
        self._scalars: DriveStats | None = None
        #: reads the left-out bins of the batch again (`pipeline.gather.ReadAgain`)
        self.read_again: Callable[[], None] | None = None

    @property
    def bins_left_out(self) -> bool:
        return self._stats is None

    @property
    def stats(self) -> DriveStats:
        """The bins: as made, or read again from the log (`read_again`)."""
        if self._stats is None:
            if self.read_again is None:
                raise RuntimeError("a run's drive bins were left out and cannot be read again")
            self.read_again()
        assert self._stats is not None, "the log's bins were not read again"
        return self._stats

    def without_bins(self) -> WorkerStats:
        """The same statistics without the bins' arrays (class docstring); itself when the run
        may be needed for a lag search over the windows."""
        from wifibot_power.drive.sums import AT_RISK_SHARE, own_share

        # the record never keeps the worker's windows and their bins-sized caches (in
        # process, `--jobs 1`, the record is this object): sent, they are a copy of their
        # fields on the bins (`send_with`)
        windows, self._windows = self._windows, None
        if self._stats is None or not own_share(self.sums) >= AT_RISK_SHARE:
            if windows is not None and _light(windows):
                from wifibot_power.drive.sums import send_with

                send_with(windows)  # the parent's lag search takes them (`windows_of`)
            return self
        light = WorkerStats(None, self.sums, self.standing)
        light._scalars = dataclasses.replace(self._stats, **dict.fromkeys(_BIN_ARRAYS))
        return light

    def bins_from(self, again: object) -> None:
        """Take the bins of the same run read again (`again`: its statistics as a worker made
        them with the bins); a run whose log changed since (other scalars) is an error."""
        from wifibot_power.drive.stats import DriveStats
        from wifibot_power.errors import LogError

        stats = getattr(again, "stats", again)
        same = isinstance(stats, DriveStats) and repr(
            dataclasses.replace(stats, **dict.fromkeys(_BIN_ARRAYS))
        ) == repr(self._scalars)
        if not same:  # other scalars, or no drive statistics at all now (a column removed)
            raise LogError(
                "the log changed while it was read",
                file=self._scalars.file,
                fix="read the logs again when no program writes them",
            )
        self._stats = stats

    def __getstate__(self) -> dict[str, object]:
        """Pickled without its `read_again` (the batch's reader stays in its process) and its
        windows (sent with the bins where they weigh little: `without_bins`)."""
        return {**self.__dict__, "read_again": None, "_windows": None}

    def __getattr__(self, name: str) -> object:
        """The bins' attribute (`DriveStats`), for what reads a run's drive statistics: a
        scalar from the scalars kept while the bins are left out, else from the bins."""
        if name.startswith("_") or name in ("stats", "sums", "read_again", "standing"):
            raise AttributeError(name)
        if self._stats is None and name in _SCALAR_FIELDS:
            return getattr(self._scalars, name)
        return getattr(self.stats, name)


#: A run at risk (its bins kept for the parent's lag search over the windows) sends its windows
#: with them when they weigh under this share of its samples (8 bytes each): the parent then
#: takes them instead of making them again (~0.3 ms a step run, all overhead on its ~70
#: windows). A 10 kHz log's (500 samples a bin) are 0.2% of its samples; a 1 kHz log's
#: (~49), 1.7%, are not sent: its record stays within tests/test_parallel.py's 2 bytes a
#: sample (a run's record, its bins included, is ~1.9 there)
SEND_WINDOWS_SHARE = 0.01


def _light(windows: RunWindows) -> bool:
    """Whether `windows` weigh under `SEND_WINDOWS_SHARE` of their run's samples."""
    stats = windows.stats
    weight = sum(
        getattr(getattr(windows, f.name), "nbytes", 0) for f in dataclasses.fields(windows)
    )
    return weight <= SEND_WINDOWS_SHARE * 8.0 * stats.samples_per_bin * stats.bins


#: `DriveStats`' per-bin arrays (what `WorkerStats.without_bins` leaves out)
_BIN_ARRAYS = ("power_W", "speed_mps", "yaw_rate_radps", "surface_index")
#: ... and its other fields, kept
_SCALAR_FIELDS = frozenset(
    ("run_id", "file", "bin_s", "surfaces", "has_turning", "energy_J", "duration_s")
    + ("speed_noise_mps", "yaw_noise_radps", "samples_per_bin", "speed_from_phases")
    + ("notes", "current_proxy", "track_m", "mass_kg")
)


class KeptDrive(FittedModel):
    """A fitted drive model as the cache kept it (`DriveModel.to_json`): its summary and
    model.json section straight from the kept values; anything else from the `DriveModel`
    made at first use."""

    family: ClassVar[str] = "drive"

    def __init__(self, kept: dict) -> None:
        self.kept = kept

    @functools.cached_property
    def model(self) -> DriveModel:
        from wifibot_power.drive.model import DriveModel

        return DriveModel.from_json(self.kept)

    def summary(self) -> dict[str, object]:
        keys = ("terms", "surfaces", "lag_s", "lag_ci95_s", "n_runs", "heldout")
        keys += ("not_determined", "warnings")
        return {key: self.kept[key] for key in keys}

    def to_json(self) -> dict[str, object]:
        return self.kept

    def predict_energy_J(self, record: object) -> float:
        return self.model.predict_energy_J(record)

    def __getattr__(self, name: str) -> object:
        if name.startswith("__") or name in ("kept", "model"):
            raise AttributeError(name)
        return getattr(self.model, name)


class DriveFamily(ModelFamily):
    """The drive model family (module docstring)."""

    name: ClassVar[str] = "drive"

    def run_stats(self, run: Run, segmentation: Segmentation | None) -> WorkerStats | None:
        from wifibot_power.drive.stats import drive_stats
        from wifibot_power.drive.sums import run_sums
        from wifibot_power.drive.windows import run_windows

        # an empty segmentation (a run of unknown mode the pipeline did not segment) has no
        # phases to reconstruct a speed from: the run's own speed column, if any, is used
        stats = drive_stats(run, segmentation if segmentation and segmentation.phases else None)
        if stats is None:
            return None
        # a current proxy's stops for the idle check, here where the bins are (the fit's
        # records leave them out)
        standing = None
        if stats.current_proxy:
            from wifibot_power.drive.standing import standing_stops

            standing = standing_stops(stats)
        windows = run_windows(stats)  # (`sums_of`, the windows kept: `without_bins`)
        return WorkerStats(stats, run_sums(windows), standing, windows)

    def stats_to_json(self, stats: DriveStats | WorkerStats | KeptStats | None) -> object:
        if stats is None:
            return None
        if isinstance(stats, KeptStats):
            return stats.kept
        return getattr(stats, "stats", stats).to_json()

    def stats_from_json(self, kept: object) -> KeptStats | None:
        return None if kept is None else KeptStats(kept)  # type: ignore[arg-type]

    def fit(
        self, records: Sequence[object], options: FitOptions | None = None
    ) -> DriveModel | None:
        """From the records' `models["drive"]` (or the statistics themselves)."""
        from wifibot_power.drive.model import fit_drive_stats

        del options  # nothing of the paper's options applies to the drive model
        # a worker's statistics as they are: their bins are read only if the fit needs them
        return fit_drive_stats(
            [_fit_stats(record) for record in records],
            sums=[drive_sums_of(record) for record in records],
        )

    def load(self, data: dict, *, file: str = "model.json") -> DriveModel:
        from wifibot_power.drive.model import DriveModel

        del file  # errors of a damaged section: drive.profile.load_drive_model names it
        return DriveModel.from_json(data)

    def from_cache(self, kept: object) -> KeptDrive:
        if not isinstance(kept, dict) or "coef" not in kept:
            raise KeyError("drive")
        return KeptDrive(kept)


def drive_stats_of(record: object) -> DriveStats | None:
    """A record's drive statistics (`record.models["drive"]`, as computed or as kept), or the
    statistics themselves; None for a run without them."""
    stats = _family_stats(record)
    return stats.stats if isinstance(stats, KeptStats | WorkerStats) else stats


def _fit_stats(record: object) -> DriveStats | WorkerStats | None:
    """What `fit_drive_stats` reads of a record: its worker's statistics as they are while
    their bins are left out (read again only if the fit needs them), else the bins
    themselves (`drive_stats_of`: a fit over the windows reads them without going through
    `WorkerStats.__getattr__` at each attribute)."""
    stats = _family_stats(record)
    if isinstance(stats, WorkerStats) and stats.bins_left_out:
        return stats
    return drive_stats_of(record)


def drive_sums_of(record: object) -> RunSums | None:
    """A record's per-trip sums as its worker made them (None: not made, or a kept run)."""
    stats = _family_stats(record)
    return stats.sums if isinstance(stats, WorkerStats) else None


def _family_stats(record: object) -> object:
    """The record's `models["drive"]` (or the record itself when it is the statistics)."""
    if record is None or isinstance(record, WorkerStats) or hasattr(record, "bin_s"):
        return record
    return getattr(record, "models", {}).get(DriveFamily.name)


FAMILY = DriveFamily()
