"""The mass check (drive/plausible.py) on logs it did not make: real electric unicycles with
their riders' mass, BorealTC's Husky (a current proxy: never checked), and simulated field
logs; each as recorded and with its speed column multiplied by 3.6 (km/h under a
`speed_mps` header) and by 2.237 (mph). Prints the table docs/drive-model.md quotes ("The
mass check").

For each set: the lightest mass the logs give (`mass_kg` + `payload_kg`), the fitted
effective_mass_kg and its 95% interval (`wbpower fit FOLDER --json`, as a user runs it), the
interval's upper end over the mass, and whether the check's warning came. The real logs are
the converters' output (benchmarks/real_logs/, `$WBPOWER_REAL_DRIVE`, default /work/real_drive;
not committed: EUC_core is AGPL, docs/real-logs.md). Each scaled copy is written to a
temporary folder (the speed column only; everything else byte for byte).

    .venv/bin/python benchmarks/validate_mass_check.py [--sets euc,borealtc,sim] [--seeds 5]
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from wifibot_power.power_kind import unit_doubts  # noqa: E402

REAL = Path(os.environ.get("WBPOWER_REAL_DRIVE", "/work/real_drive"))
WBPOWER = str(Path(sys.executable).parent / "wbpower")
#: speed column factors tried: as logged, km/h, mph
SCALES = {"as logged": 1.0, "km/h": 3.6, "mph": 2.23694}
#: the mass given to the simulated logs (drive/simulate.py's robot: m_eff 30 kg, so a mass
#: of 20 kg is a drive of 67% efficiency with its wheels' inertia)
SIM_MASS_KG = 20.0
#: BorealTC surfaces fitted (current proxies all: one shows the check stays silent)
BOREALTC = ("asphalt", "flooring")


def scaled_copy(folder: Path, out: Path, scale: float, mass_kg: float | None) -> None:
    """`folder`'s logs (.csv, .csv.gz) in `out`, the `speed_mps` column times `scale`, a
    `mass_kg` line added when given."""
    for path in sorted(folder.rglob("*.csv*")):
        if path.name in ("runs.csv", "truth.json"):
            continue
        opener = gzip.open if path.suffix == ".gz" else open
        with opener(path, "rt") as source:
            lines = source.read().splitlines()
        head = next(k for k, line in enumerate(lines) if not line.startswith("#"))
        column = lines[head].split(",").index("speed_mps")
        body = []
        for line in lines[head + 1 :]:
            cells = line.split(",")
            if cells[column] not in ("", "nan"):
                cells[column] = repr(float(cells[column]) * scale)
            body.append(",".join(cells))
        mass = [f"# mass_kg: {mass_kg:g}"] if mass_kg is not None else []
        target = out / path.relative_to(folder)
        target.parent.mkdir(parents=True, exist_ok=True)
        with opener(target, "wt") as sink:
            sink.write("\n".join(lines[:head] + mass + [lines[head]] + body) + "\n")


def masses_of(folder: Path) -> list[float]:
    """The `mass_kg` + `payload_kg` each log of `folder` gives (none: an empty list)."""
    found = []
    for path in sorted(folder.rglob("*.csv*")):
        opener = gzip.open if path.suffix == ".gz" else open
        meta = {}
        with opener(path, "rt") as source:
            for line in source:
                if not line.startswith("#"):
                    break
                key, _, value = line[1:].partition(":")
                meta[key.strip().lower()] = value.strip()
        if "mass_kg" in meta:
            found.append(float(meta["mass_kg"]) + float(meta.get("payload_kg") or 0))
    return found


def fitted(folder: Path) -> tuple[dict | None, list[str], str | None]:
    """effective_mass_kg's term, the drive model's warnings, and why there is no drive model
    (None: there is one) from `wbpower fit --json`."""
    done = subprocess.run(
        [WBPOWER, "fit", str(folder), "--json"], capture_output=True, text=True, check=False
    )
    document = json.loads(done.stdout) if done.stdout else {}
    drive = document.get("drive")
    if not drive:
        skipped = document.get("skipped") or [{"reason": document.get("error") or "no output"}]
        reason = skipped[0]["reason"]
        return None, [], "absurd speed" if "absurd speed" in reason else reason[-60:]
    return drive["terms"].get("effective_mass_kg"), drive["warnings"], None


def row(name: str, unit: str, folder: Path, mass_kg: float | None) -> str:
    term, warnings, refused = fitted(folder)
    fired = bool(unit_doubts(warnings))  # the mass check's own warnings (power_kind.py)
    proxy = any("voltage_assumed_V" in w for w in warnings)
    ratio = ""
    if refused is not None:
        value = f"every log refused ({refused})"
    elif term is None or term["value"] is None:
        value = "not determined"
    else:
        low, high = term["ci95"]
        value = f"{term['value']:.1f} [{low:.1f}, {high:.1f}]"
        ratio = f"{high / mass_kg:.2f}" if mass_kg else ""
    mass = f"{mass_kg:g}" if mass_kg else "none"
    said = "yes" if fired else ("no (current proxy)" if proxy else "no")
    return f"| {name} | {unit} | {mass} | {value} | {ratio} | {said} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sets", default="euc,borealtc,sim")
    parser.add_argument("--seeds", type=int, default=5, help="simulated field sets")
    args = parser.parse_args()
    wanted = set(args.sets.split(","))
    print("| set | speed column | mass [kg] | effective_mass_kg [95%] | upper / mass | warned |")
    print("|---|---|---:|---|---:|---|")
    with tempfile.TemporaryDirectory() as scratch:
        scratch_path = Path(scratch)
        sets: list[tuple[str, Path, float | None]] = []
        if "euc" in wanted:
            for folder in sorted(p for p in (REAL / "euc_core").iterdir() if p.is_dir()):
                masses = masses_of(folder)
                sets.append((f"EUC {folder.name}", folder, min(masses) if masses else None))
        if "borealtc" in wanted:
            for folder in [REAL / "borealtc" / name for name in BOREALTC]:
                masses = masses_of(folder)
                sets.append((f"BorealTC {folder.name}", folder, min(masses) if masses else None))
        for seed in range(args.seeds if "sim" in wanted else 0):
            folder = scratch_path / f"sim{seed}"
            subprocess.run(
                [WBPOWER, "simulate", "-o", str(folder), "--drive", "free", "--realism", "field"]
                + ["--seed", str(seed)],
                capture_output=True,
                check=True,
            )
            sets.append((f"simulated field seed {seed}", folder, SIM_MASS_KG))
        for k, (name, folder, mass_kg) in enumerate(sets):
            simulated = name.startswith("simulated")
            for unit, scale in SCALES.items():
                if scale == 1.0 and not simulated:
                    target = folder
                else:
                    target = scratch_path / f"set{k}_{unit.replace('/', '_').replace(' ', '_')}"
                    scaled_copy(folder, target, scale, SIM_MASS_KG if simulated else None)
                print(row(name, unit, target, mass_kg), flush=True)


if __name__ == "__main__":
    main()
