"""Column sets that shared/spec/cli.md promises, written from the spec (not from the code),
for the tests that check outputs against it."""

#: `fit -o`: runs.parquet has at least these columns (cli.md, `wbpower fit`).
RUNS_PARQUET_COLUMNS = frozenset({
    "run_id", "file", "mode", "speed_mps", "distance_m", "steps", "duration_s", "energy_J",
    "motion_energy_J", "t_acc_s", "accel_mean_power_W", "cruise_mean_power_W",
})  # fmt: skip

#: `fit -o`: phases.parquet has the `segment` columns plus run_id (cli.md).
PHASES_PARQUET_COLUMNS = frozenset({
    "run_id", "step", "phase", "t_start_s", "t_end_s", "duration_s", "mean_power_W", "energy_J",
})  # fmt: skip
