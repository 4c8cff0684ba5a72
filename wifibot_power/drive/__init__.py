"""The drive model (cli.md, "The drive model"): a robot's instantaneous power as a sum of
physically named terms, identified from any log with a speed column, free driving included.

One module per stage: `terms` (the physics), `stats` (a run reduced to bins: what a pipeline
worker computes), `windows` (the design the terms are fitted on), `identify` (lag, determined
terms, bounded least squares, cluster-robust intervals), `heldout` (K-fold by trip),
`model` (`DriveModel`, `fit_drive`, `fit_drive_stats`), `profile` (a planned route's energy)
and `simulate` (free-driving logs with known terms).
"""

from wifibot_power.drive.model import DriveModel, fit_drive, fit_drive_stats
from wifibot_power.drive.stats import DriveStats, drive_stats

__all__ = ["DriveModel", "DriveStats", "drive_stats", "fit_drive", "fit_drive_stats"]
