"""Convert electric-unicycle ride logs (phone apps EUC World and WheelLog) into canonical CSV.

The second kind of vehicle of docs/real-logs.md ("Free driving"): electric unicycles
(EUCs) ridden on roads, 1-7 kW, logged over Bluetooth by a phone app. Two public sources:

- `euc_core`: Tritbool/EUC_core (AGPL-3.0), `trips/<brand>/<wheel>/<trip>/<trip>.csv` with
  `meta.csv` beside it (rider weight, tyre pressure, temperature, wind, rain, the app) and
  the wheel's data sheet in `build/specs/<wheel>.csv` (its net weight). 11 wheels (Begode,
  InMotion, KingSong, Leaperkim, Ninebot, Nosfet), two apps:
  - EUC World: `datetime` (ISO 8601 with the phone's UTC offset, ms), `speed` [km/h],
    `voltage` [V], `current` [A] (battery side), `power` [W], `gps_speed` [km/h], ...;
  - WheelLog: `date`, `time` (local, ms), `speed` [km/h], `voltage` [V], `current` [A],
    `power` [W], ...
- `wheellog_storvild`: Storvild/wheellog_graph (Apache-2.0), `data_samples/*.csv`: two
  rides of one (unnamed, ~64 V) wheel logged by an older WheelLog (`date,time,speed,
  voltage,current,power,...`).

Each ride becomes one `.csv.gz`: `time_s` from its first row (to the ms), `voltage_V`,
`current_A` as logged (wbpower's power is their product; the app's own `power` column
equals it to the app's rounding and is not copied), `speed_mps` = speed / 3.6 (the wheel's
own speed: its motor's, not GPS), and, not read by wbpower, `gps_speed_mps` and
`gps_altitude_m` (the phone's GPS; EUC World only, empty where it had no fix): climbs and
descents (m g dh) are a share of a ride's energy that neither the speed nor the power
column shows (docs/real-logs.md). Rows with an empty voltage, current or speed (an app's last,
half-written row) or a time stamp not after the one before are dropped, their number in
the metadata (`rows_dropped`). The apps log in bursts (rows 20-40 ms apart, then up to seconds of
nothing): the stamps are kept as they are, never evened out.

Metadata: `run_id` (`<source>/<wheel>/<trip>`), `mode: motion`, `speed_mps` (the largest
|speed| of the ride: the reader refuses a motion run without one), `vehicle` (the wheel),
`mass_kg` (the wheel's net weight from its data sheet, where there is one),
`payload_kg` (the rider's weight from meta.csv), `app`, the ride's conditions as logged
(`tyre_pressure_bar`, `temperature_C`, `wind`, `rain`), and the provenance keys. No
`surface` (roads, not said which) and no `max_power_W` (the data sheets give a rated
motor power that the rides exceed several times over, not a limit).

Usage (the mirrors are git directories from the `fetch` tool; output outside the
repository, by default `$WBPOWER_REAL_DRIVE/<source>` or /work/real_drive/<source>):

    python benchmarks/real_logs/convert_euc.py euc_core /work/.mirror/Tritbool+EUC_core/repo
    python benchmarks/real_logs/convert_euc.py wheellog_storvild \
        /work/.mirror/Storvild+wheellog_graph/repo/.git

Files the mirror lacks (kept out of the snapshot: over 4 MiB) are listed and skipped.
Standard library + numpy only.
"""

from __future__ import annotations

import argparse
import csv
import io
import subprocess
import sys
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import canonical_out as co  # noqa: E402  (a module beside this one)
from canonical_out import canonical_text, git, write_gzip  # noqa: E402

KMH_PER_MPS = 3.6


@dataclass(frozen=True)
class Source:
    repo: str
    commit: str
    licence: str
    folder: str


SOURCES = {
    "euc_core": Source(
        "Tritbool/EUC_core",
        # the newest commit of the default branch when fetched (2026-01-17)
        "472481b8f60c1ad91bb613ccb49a8a87f7599812",
        "AGPL-3.0 (the repository's LICENSE, GNU Affero General Public License v3)",
        "trips",
    ),
    "wheellog_storvild": Source(
        "Storvild/wheellog_graph",
        # the newest commit of the default branch when fetched (2020-08-23)
        "6ad5473e46493a0cf0c9e4457b8dd1448e363e98",
        "Apache-2.0 (the repository's LICENSE)",
        "data_samples",
    ),
}

COLUMNS = (
    ("time_s", "%.3f"),
    ("voltage_V", "%.2f"),
    ("current_A", "%.2f"),
    ("speed_mps", "%.4f"),
    ("gps_speed_mps", "%.4f"),
    ("gps_altitude_m", "%.1f"),
)


def _number(text: str) -> float:
    return float(text) if text.strip() else np.nan


def parse_ride(text: str, source: str) -> tuple[dict[str, np.ndarray], int]:
    """The canonical columns of one app log, and how many rows were dropped."""
    rows = list(csv.reader(io.StringIO(text)))
    if len(rows) < 2:
        raise SystemExit(f"{source}: no rows")
    header = [h.strip() for h in rows[0]]
    body = [r for r in rows[1:] if r]
    missing = [n for n in ("speed", "voltage", "current") if n not in header]
    if missing:
        raise SystemExit(f"{source}: no column {', '.join(missing)} in {header}")

    def column(name: str) -> list[str]:
        k = header.index(name)
        return [r[k] if len(r) > k else "" for r in body]

    if "datetime" in header:  # EUC World: ISO 8601 with the offset
        stamps = [
            datetime.fromisoformat(s).timestamp() if s else np.nan for s in column("datetime")
        ]
    elif "date" in header and "time" in header:  # WheelLog: local date and time
        stamps = [
            datetime.fromisoformat(f"{d}T{t}").timestamp() if d and t else np.nan
            for d, t in zip(column("date"), column("time"), strict=True)
        ]
    else:
        raise SystemExit(f"{source}: no datetime or date,time columns in {header}")
    t = np.array(stamps, dtype=float)
    v = np.array([_number(x) for x in column("voltage")])
    i = np.array([_number(x) for x in column("current")])
    kmh = np.array([_number(x) for x in column("speed")])
    gps, alt = (
        np.array([_number(x) for x in column(name)]) if name in header else np.full(t.size, np.nan)
        for name in ("gps_speed", "gps_alt")
    )
    keep = np.isfinite(t) & np.isfinite(v) & np.isfinite(i) & np.isfinite(kmh)
    # a stamp not after the last kept one: drop (vectorised: the running maximum before it)
    prior = np.maximum.accumulate(np.where(keep, t, -np.inf))
    later = np.concatenate([[True], t[1:] > prior[:-1]])
    keep &= later
    t0 = t[keep][0]
    cols = {
        "time_s": np.round(t[keep] - t0, 3),
        "voltage_V": v[keep],
        "current_A": i[keep],
        "speed_mps": kmh[keep] / KMH_PER_MPS + 0.0,
        "gps_speed_mps": gps[keep] / KMH_PER_MPS + 0.0,
        "gps_altitude_m": alt[keep],
    }
    if np.any(np.diff(cols["time_s"]) <= 0):
        raise SystemExit(f"{source}: time stamps not increasing after rounding to the ms")
    return cols, int(np.size(t) - np.count_nonzero(keep))


def _table_csv(text: str) -> dict[str, str]:
    """A one-row CSV (meta.csv) as a dict."""
    rows = list(csv.reader(io.StringIO(text)))
    return dict(zip(rows[0], rows[1], strict=True)) if len(rows) > 1 else {}


def _net_weight_kg(mirror: Path, commit: str, wheel: str) -> float | None:
    """The wheel's net weight from EUC_core's `build/specs/<wheel>.csv` (`Field|Data`)."""
    try:
        text = git(mirror, "show", f"{commit}:build/specs/{wheel}.csv").decode()
    except subprocess.CalledProcessError:
        return None
    for line in text.splitlines():
        field, _, value = line.partition("|")
        if field.strip().lower() == "net weight":
            return float(value.strip().split()[0])
    return None


def _top(cols: dict[str, np.ndarray]) -> dict[str, str]:
    """`speed_mps` metadata: the largest |speed| of the ride (the reader refuses a motion run
    without one; free driving has no commanded speed)."""
    return {"speed_mps": f"{np.max(np.abs(cols['speed_mps'])):.2f}"}


def _provenance(src: Source, paths: str) -> dict[str, str]:
    return {
        "source_repo": f"https://github.com/{src.repo}",
        "source_commit": src.commit,
        "source_path": paths,
        "source_licence": src.licence,
    }


def write(cols: dict[str, np.ndarray], meta: dict[str, str], target: Path) -> Path:
    table = np.column_stack([cols[name] for name, _ in COLUMNS])
    names, formats = [n for n, _ in COLUMNS], [f for _, f in COLUMNS]
    if np.all(np.isnan(cols["gps_speed_mps"])):  # no GPS columns in this app's log
        table, names, formats = table[:, :-2], names[:-2], formats[:-2]
    target.parent.mkdir(parents=True, exist_ok=True)
    # the GPS columns, the last two, are empty where the app had no fix
    text = canonical_text(meta, names, formats, table)
    text = text.replace(",nan,", ",,").replace(",nan\n", ",\n").replace(",nan,", ",,")
    write_gzip(target, text)
    return target


def convert(name: str, mirror: Path, out: Path) -> tuple[list[Path], list[str]]:
    """Convert every ride of source `name`; returns (written, paths the mirror lacks)."""
    src = SOURCES[name]
    listing = git(mirror, "ls-tree", "-r", "--name-only", src.commit, src.folder).decode()
    logs = sorted(p for p in listing.split() if p.endswith(".csv") and Path(p).name != "meta.csv")
    written, lacking = [], []
    for path in logs:
        try:
            text = git(mirror, "show", f"{src.commit}:{path}").decode()
        except subprocess.CalledProcessError:
            lacking.append(path)
            continue
        cols, dropped = parse_ride(text, f"{src.repo}:{path}")
        if name == "euc_core":
            brand, wheel, trip = Path(path).parts[1:4]
            about = _table_csv(
                git(mirror, "show", f"{src.commit}:{Path(path).parent}/meta.csv").decode()
            )
            mass = _net_weight_kg(mirror, src.commit, wheel)
            meta = {"run_id": f"{name}/{wheel}/{trip}", "mode": "motion", **_top(cols)}
            meta["vehicle"] = wheel
            if mass is not None:
                meta["mass_kg"] = f"{mass:g}"
            meta |= {
                "payload_kg": about.get("rider_weight", ""),
                "app": about.get("app", ""),
                "trip_type": about.get("trip_type", ""),
                "tyre_pressure_bar": about.get("tire_pressure", ""),
                "temperature_C": about.get("temperature", ""),
                "wind": about.get("wind", ""),
                "rain": about.get("rain", ""),
                "rows_dropped": f"{dropped}",
                **_provenance(
                    src,
                    f"{path}, {Path(path).parent}/meta.csv"
                    + (f", build/specs/{wheel}.csv" if mass is not None else ""),
                ),
                "robot": f"{brand} {wheel} electric unicycle",
            }
            target = out / wheel / f"{trip}.csv.gz"
        else:
            stem = Path(path).stem
            meta = {
                "run_id": f"{name}/{stem}",
                "mode": "motion",
                **_top(cols),
                "vehicle": "storvild_wheel",
                "app": "wheel_log",
                "rows_dropped": f"{dropped}",
                **_provenance(src, path),
                "robot": "electric unicycle (model not stated; ~64 V battery: 16 cells)",
            }
            target = out / f"{stem}.csv.gz"
        written.append(write(cols, meta, target))
    return written, lacking


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("source", choices=sorted(SOURCES))
    parser.add_argument("mirror", type=Path, help="git directory of the fetched repository")
    co.add_out_argument(parser, "SOURCE")
    args = parser.parse_args(argv)
    folder = args.out or co.real_drive_root() / args.source
    written, lacking = convert(args.source, args.mirror, folder)
    for path in lacking:
        print(
            f"{path}: not in the mirror (over the snapshot's size limit), skipped", file=sys.stderr
        )
    print(f"{len(written)} log(s) written to {folder}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
