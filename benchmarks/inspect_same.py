"""Every answer of `inspect --json` on logs whose reading finds problems (gaps with their line
numbers, bursty and uneven stamps, CRLF, empty lines, .gz), written to a folder, so that a
change to the reader can be proven to change none of them byte for byte (`golden.py` does not
run `inspect`).

Sets: sample_logs/, the real logs in ../shared/real_logs and /work/real_drive (where present),
the first runs of the bench's free-driving corpus (drop-outs: a `gap` problem each, with its
line), and logs written here from one free-driving simulation at field realism: as written,
with CRLF line ends, with empty lines, gzipped (each with its gaps' line numbers).

    .venv/bin/python benchmarks/inspect_same.py OUT_DIR        # then: diff -r OLD NEW

Run it with the checkout before and after a change (it calls `python -m wifibot_power` from
the checkout it lives in).
"""

from __future__ import annotations

import gzip
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from golden import ROOT, SHARED, wbpower  # noqa: E402  (paths in the answers made alike)

#: the real free-driving logs, and the bench corpus (WBPOWER_BENCH_CORPUS); the real logs are
#: golden.py's SHARED (WBPOWER_REAL_LOGS)
REAL_DRIVE = Path("/work/real_drive")
BENCH_DRIVE = Path(os.environ.get("WBPOWER_BENCH_CORPUS", ROOT / "bench_corpus")) / "drive"


def logs(folder: Path) -> list[str]:
    """The log files under `folder` (sorted; not the manifests and READMEs)."""
    found = [
        p
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name.endswith((".csv", ".csv.gz", ".csv.zst")) and p.name != "runs.csv"
    ]
    return [str(p) for p in found]


def variants(work: Path) -> list[str]:
    """One simulated free-driving log at field realism (drop-outs) as written, with CRLF line
    ends, with an empty line after every 1000th, and gzipped."""
    sim = work / "sim"
    wbpower(work, "simulate", "simulate", "-o", str(sim), "--drive", "free", "--realism",
            "field", "--duration", "600", "--seed", "3")  # fmt: skip
    first = sorted(sim.glob("*.csv"))[0]
    data = first.read_bytes()
    (work / "crlf.csv").write_bytes(data.replace(b"\n", b"\r\n"))
    lines = data.split(b"\n")
    spaced = [line + (b"\n" if k % 1000 else b"\n\n") for k, line in enumerate(lines[:-1])]
    (work / "empty_lines.csv").write_bytes(b"".join(spaced))
    (work / "zipped.csv.gz").write_bytes(gzip.compress(data, mtime=0))
    names = ("crlf.csv", "empty_lines.csv", "zipped.csv.gz")
    return [str(first), *(str(work / name) for name in names)]


def main() -> None:
    out = Path(sys.argv[1]).resolve()
    work = out / "_work"
    work.mkdir(parents=True, exist_ok=True)
    sets = {
        "sample_logs": logs(ROOT / "sample_logs"),
        "real_logs": logs(SHARED),
        **{f"real_drive_{d.name}": logs(d) for d in sorted(REAL_DRIVE.glob("*")) if d.is_dir()},
        "bench_drive": logs(BENCH_DRIVE)[:6],
        "variants": variants(work),
    }
    for name, files in sets.items():
        if name == "variants":  # the same samples: one at a time (a batch reads copies once)
            for file in files:
                stem = Path(file).name.split(".")[0]
                wbpower(out, f"inspect_variant_{stem}", "inspect", file, "--json")
        elif files:
            wbpower(out, f"inspect_{name}", "inspect", *files, "--json")
        print(f"inspect_same: {name}: {len(files)} logs", flush=True)


if __name__ == "__main__":
    main()
