"""`fit -o DIR`: the files a fit writes (runs.parquet, phases.parquet, stop_and_go.parquet,
model.json), as one set."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from wifibot_power.outputs import json_file, parquet_file, write_set

if TYPE_CHECKING:
    import pandas as pd

    from wifibot_power.fit_result import FitResult


def write_fit(result: FitResult, out_dir: Path) -> list[Path]:
    """Write the fit's files as one set (`outputs.write_set`: all new, or all as they were).

    model.json (`FitResult.model_json`) is written only when the paper's model is complete
    (`FitResult.model_complete`: a model with unfitted coefficients would only fail later, in
    `energy --model`), or when no run was a step run and another family fitted
    (`FitResult.writes_model`: the drive model of free driving; model.json then holds its
    section alone, `energy --profile` and `export` read it). Else a model.json an
    earlier fit left in DIR is removed with the same set: beside this fit's tables it would be
    read by `energy --model DIR/model.json` as this fit's model.
    """
    files = {
        "runs.parquet": parquet_file(result.runs),
        "phases.parquet": parquet_file(result.phases),
        "stop_and_go.parquet": parquet_file(stop_and_go_frame(result)),
    }
    if result.writes_model:
        files["model.json"] = json_file(result.model_json())
    stale = () if result.writes_model else ("model.json",)
    return write_set(Path(out_dir), files, remove=stale)


def stop_and_go_frame(result: FitResult) -> pd.DataFrame:
    """The rows of `stop_and_go` as a table (stop_and_go.parquet): the interval as two
    columns, `overhead_ci95_low_pct` and `overhead_ci95_high_pct`."""
    import pandas as pd

    from wifibot_power.overhead import StopAndGo

    columns = [k for k in StopAndGo.__dataclass_fields__ if k != "overhead_ci95"]
    rows = []
    for item in result.stop_and_go:
        row = {k: getattr(item, k) for k in columns}
        row["overhead_ci95_low_pct"], row["overhead_ci95_high_pct"] = item.overhead_ci95
        rows.append(row)
    return pd.DataFrame(rows, columns=[*columns, "overhead_ci95_low_pct", "overhead_ci95_high_pct"])
