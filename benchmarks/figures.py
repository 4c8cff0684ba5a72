"""How long a trace figure takes to draw, against the length of the log (docs/report.md).

A trace is drawn from a min/max envelope per pixel column (`figures.trace.envelope`), so the
time should hardly grow with the number of samples: this script times, for 10 k to 10 M
samples of a synthetic level log, the envelope (`trace_view`), building the figure
(`trace_figure`) and writing the PNG (`save_figure`), median of a few repeats.

Usage: `.venv/bin/python benchmarks/figures.py [--repeats N]` (never part of `make test`).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from wifibot_power.figures import save_figure, trace_figure, trace_view
from wifibot_power.phases import Phase, Segmentation
from wifibot_power.run import Run, RunMeta


def synthetic(n: int) -> tuple[Run, Segmentation]:
    """n samples at 0.1024 ms of a load stepping between 10 levels, with noise."""
    dt = 0.1024e-3
    rng = np.random.default_rng(0)
    level = np.repeat(np.arange(10) % 5 + 23.0, -(-n // 10))[:n]
    power = level + rng.normal(0, 0.3, n)
    run = Run("synthetic.csv", "canonical", RunMeta("synthetic", sample_period_s=dt),
              np.arange(n) * dt, power)  # fmt: skip
    bounds = np.linspace(0, n, 11).astype(int)
    phases = tuple(
        Phase(k + 1, "level", int(a), int(b), a * dt, b * dt, float(level[a]), 0.0)
        for k, (a, b) in enumerate(zip(bounds[:-1], bounds[1:], strict=True))
    )
    return run, Segmentation("synthetic", phases)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print("| samples | envelope s | figure s | PNG s | total s |")
    print("| ---: | ---: | ---: | ---: | ---: |")
    with tempfile.TemporaryDirectory() as folder:
        trace_figure(*synthetic(1000))  # matplotlib's import and font cache, not timed
        for n in (10_000, 100_000, 1_000_000, 10_000_000):
            run, segmentation = synthetic(n)
            times = []
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                view = trace_view(run, segmentation)
                t1 = time.perf_counter()
                figure = trace_figure(view)
                t2 = time.perf_counter()
                save_figure(figure, Path(folder) / "trace.png")
                t3 = time.perf_counter()
                times.append((t1 - t0, t2 - t1, t3 - t2, t3 - t0))
            med = [statistics.median(column) for column in zip(*times, strict=True)]
            print(f"| {n:,} | " + " | ".join(f"{m:.3f}" for m in med) + " |")


if __name__ == "__main__":
    main()
