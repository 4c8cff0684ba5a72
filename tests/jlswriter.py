"""Joulescope recordings for the tests, written by pyjls's own writer in a child process.

pyjls's writer can deadlock (seen twice in CI, pyjls 0.x): its writer thread logs a message
(a skipped stretch: "fsr 1 skip: in=3200 expect=1200") through the binding's Python callback
(`pyjls.binding._log_cbk`), which needs the GIL, while the calling thread holds the GIL in
`Writer.signal_def` waiting for the writer's lock. No Python-level timeout can fire then
(pytest-timeout's thread waits for the GIL too), so the test run hung until CI killed it.
`write` runs the writer in a child and kills and retries a child that hangs: a test run never
hangs on it. After a skipping write the child sleeps (`SKIP_LOG_S`), so the writer thread logs
its skip while no call holds the GIL: on an idle machine the deadlock had become certain (5 of
5 children hung, the sixteenth session; 3 of 3 written with the pause).

    python tests/jlswriter.py ARRAYS.npz OUT.jls OPTIONS_JSON   # the child's command line
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

RATE_HZ = 100_000  # blocks of 10 samples: 10 kHz
#: how long one child may take [s], and how many children are tried
CHILD_TIMEOUT_S = 30
ATTEMPTS = 5
#: a pause after a skipping write, while the writer thread logs the skip [s]
SKIP_LOG_S = 0.2


def write(
    path: Path,
    current: np.ndarray,
    voltage: np.ndarray,
    *,
    power: bool = True,
    names=("current", "voltage", "power"),
    skip: tuple[int, int] | None = None,
) -> Path:
    """A recording as a JS220 saves one; `skip=(start, n)` leaves n samples out (dropped).
    Written by a child process (module docstring), retried when one hangs."""
    options = {"power": power, "names": list(names), "skip": list(skip) if skip else None}
    with tempfile.TemporaryDirectory() as tmp:
        arrays = Path(tmp) / "arrays.npz"
        np.savez(arrays, current=current, voltage=voltage)
        command = [sys.executable, __file__, str(arrays), str(path), json.dumps(options)]
        for _ in range(ATTEMPTS):
            try:
                subprocess.run(command, check=True, timeout=CHILD_TIMEOUT_S)
                return path
            except subprocess.TimeoutExpired:  # the writer's deadlock: kill it, try again
                print(f"jlswriter: pyjls's writer hung writing {path}; again", file=sys.stderr)
                Path(path).unlink(missing_ok=True)
    raise RuntimeError(f"pyjls's writer hung {ATTEMPTS} times writing {path}")


def _write_here(path: str, current, voltage, power: bool, names, skip) -> None:
    import pyjls

    signals = [(names[0], "A", current), (names[1], "V", voltage)]
    if power:
        signals.append((names[2], "W", current * voltage))
    with pyjls.Writer(path) as writer:
        writer.source_def(
            source_id=1, name="js220", vendor="Jetperch", model="JS220", version="1",
            serial_number="000415",
        )  # fmt: skip
        for signal_id, (name, units, data) in enumerate(signals, start=1):
            writer.signal_def(
                signal_id=signal_id, source_id=1, signal_type=pyjls.SignalType.FSR,
                data_type=pyjls.DataType.F32, sample_rate=RATE_HZ, name=name, units=units,
            )  # fmt: skip
            if skip is None:
                writer.fsr(signal_id, 0, np.ascontiguousarray(data))
            else:
                start, n = skip
                writer.fsr(signal_id, 0, np.ascontiguousarray(data[:start]))
                writer.fsr(signal_id, start + n, np.ascontiguousarray(data[start + n :]))
                # the writer thread logs the skip through Python (it needs the GIL): give it
                # the GIL now, before signal_def holds it waiting for the writer's lock
                time.sleep(SKIP_LOG_S)


if __name__ == "__main__":
    arrays_path, out, raw = sys.argv[1:4]
    options = json.loads(raw)
    with np.load(arrays_path) as arrays:
        _write_here(
            out, arrays["current"], arrays["voltage"], options["power"], options["names"],
            tuple(options["skip"]) if options["skip"] else None,
        )  # fmt: skip
