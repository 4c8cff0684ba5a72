"""What is in a log: format, samples, period, duration, mean power, energy, metadata, problems."""

from __future__ import annotations

from pathlib import Path

from wifibot_power.io import ReadOptions, Skipped
from wifibot_power.io.batch import map_runs
from wifibot_power.io.options import FORMAT_ROSBAG
from wifibot_power.run import Run, energy_J


def summarize(run: Run) -> dict[str, object]:
    """The `inspect --json` object of one log (cli.md)."""
    return {
        "file": run.file,
        "format": run.format,
        "run_id": run.meta.run_id,
        "samples": run.samples,
        "sample_period_s": run.sample_period_s,
        "duration_s": run.duration_s,
        "mean_power_W": run.mean_power_W,
        "energy_J": run.energy_J,
        "meta": run.meta.as_dict(),
        # the channels summed into the power (log-format.md "Several channels"); [] for one
        "channels": [
            {
                "name": name,
                "mean_power_W": float(channel_W.mean()) if channel_W.size else float("nan"),
                "energy_J": energy_J(channel_W, run.sample_period_s),
            }
            for name, channel_W in run.channels_W.items()
        ],
        "speed_column": run.speed_mps is not None,
        # a bag's topics, with their types, message counts and rates (log-format.md section 3)
        **({"topics": _topics(run.file)} if run.format == FORMAT_ROSBAG else {}),
        "problems": [p.message for p in run.problems],
        "problem_details": [
            {
                "kind": p.kind,
                "message": p.message,
                "t_start_s": p.t_start_s,
                "duration_s": p.duration_s,
            }
            for p in run.problems
        ],
    }


def _topics(file: str) -> list[dict[str, object]]:
    from wifibot_power.io.formats.rosbag import bag_topics

    return [topic.as_dict() for topic in bag_topics(file)]


def inspect_logs(
    paths: list[Path], options: ReadOptions | None = None, **kwargs: object
) -> tuple[list[dict[str, object]], list[Skipped]]:
    """One `summarize` row per readable log under `paths`, and the inputs skipped (and why)."""
    return map_runs(paths, options or ReadOptions(), summarize, **kwargs)
