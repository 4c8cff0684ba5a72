"""A long Joulescope recording, inspected and segmented in bounded memory (issue 30).

Writes (once) a recording of `--samples` full-rate samples (default 100 M: 100 s at 1 MHz)
with pyjls's own writer: current and voltage signals, float32, as a JS110 saves them (no
power signal, so the reader multiplies them sample by sample: its heavier path), a load
that steps between three levels. While writing, it sums the full-rate power (float64 of
the float32 product), independently of wbpower's reader. Then it runs `wbpower inspect
--json` and `wbpower segment --json` on it, each in its own process, and reports their
wall time, throughput (full-rate samples a second) and peak memory (the child's max RSS),
and the energy against the full-rate sum.

    .venv/bin/python benchmarks/jls_long.py [--samples 100000000] [--dir bench_corpus]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

RATE_HZ = 1_000_000
CHUNK = 1 << 22


def write(path: Path, samples: int) -> float:
    """Write the recording; return its full-rate energy [J] (the rectangle rule)."""
    import pyjls

    rng = np.random.default_rng(30)
    total_W = 0.0
    tmp = path.with_suffix(".tmp.jls")
    with pyjls.Writer(str(tmp)) as writer:
        writer.source_def(
            source_id=1, name="js110", vendor="Jetperch", model="JS110", version="1",
            serial_number="bench",
        )  # fmt: skip
        for signal_id, (name, units) in enumerate((("current", "A"), ("voltage", "V")), 1):
            writer.signal_def(
                signal_id=signal_id, source_id=1, signal_type=pyjls.SignalType.FSR,
                data_type=pyjls.DataType.F32, sample_rate=RATE_HZ, name=name, units=units,
            )  # fmt: skip
        for start in range(0, samples, CHUNK):
            n = min(CHUNK, samples - start)
            t = (start + np.arange(n)) / RATE_HZ
            level = np.where((t % 30.0) < 10.0, 0.15, np.where((t % 30.0) < 20.0, 0.6, 1.2))
            current = (level + rng.normal(0, 0.005, n)).astype(np.float32)
            voltage = (5.0 - 0.05 * current + rng.normal(0, 0.001, n)).astype(np.float32)
            writer.fsr(1, start, current)
            writer.fsr(2, start, voltage)
            total_W += float(np.sum(current.astype(np.float64) * voltage.astype(np.float64)))
    tmp.rename(path)
    return total_W / RATE_HZ


def measured(command: list[str]) -> tuple[dict, float, float]:
    """The command's JSON, wall time [s] and peak memory [MB] (its max RSS)."""
    started = time.perf_counter()
    pid = os.fork()
    if pid == 0:  # the child: its own max RSS, not this process's
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
        out = os.open(str(OUT), os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
        os.dup2(out, 1)
        os.execv(command[0], command)
    _, status, usage = os.wait4(pid, 0)
    wall_s = time.perf_counter() - started
    if os.waitstatus_to_exitcode(status) not in (0, 1):
        raise SystemExit(f"{' '.join(command)} failed")
    return json.loads(OUT.read_text()), wall_s, usage.ru_maxrss / 1024


OUT = Path("/tmp/wbpower_jls_long.json")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=100_000_000)
    parser.add_argument(
        "--dir", type=Path, default=Path(os.environ.get("WBPOWER_BENCH_CORPUS", "bench_corpus"))
    )
    args = parser.parse_args()
    args.dir.mkdir(parents=True, exist_ok=True)
    path = args.dir / f"long_{args.samples}.jls"
    energy_file = path.with_suffix(".energy_J")
    if not (path.is_file() and energy_file.is_file()):
        started = time.perf_counter()
        energy_file.write_text(repr(write(path, args.samples)))
        print(f"wrote {path} ({path.stat().st_size / 1e6:.0f} MB) in "
              f"{time.perf_counter() - started:.0f} s", file=sys.stderr)  # fmt: skip
    full_J = float(energy_file.read_text())
    wbpower = str(Path(sys.executable).with_name("wbpower"))
    rows = []
    for name in ("inspect", "segment"):
        document, wall_s, peak_MB = measured([wbpower, name, str(path), "--json"])
        if name == "inspect":
            energy_J = document[0]["energy_J"]
        else:
            energy_J = sum(p["energy_J"] for p in document["phases"])
        rows.append(
            {
                "command": name,
                "samples": args.samples,
                "wall_s": round(wall_s, 2),
                "Msamples_per_s": round(args.samples / wall_s / 1e6, 1),
                "peak_MB": round(peak_MB),
                "energy_J": energy_J,
                "full_rate_J": full_J,
                "rel_error": abs(energy_J - full_J) / full_J,
            }
        )
    print(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
