"""Free-driving logs with known drive-model terms (`wbpower simulate --drive free`).

A skid-steer robot is driven along random routes: stops, straight runs and arcs at varying
speeds, turns in place, and reversing, on one surface per run (runs alternate over the
surfaces). Its power is the drive model's own terms (terms.py) with the true coefficients,
computed on a fine internal clock (`INTERNAL_S`) from a speed and rate of turn that change
with bounded acceleration, then delayed by the lag and logged.

Realism (`FREE_REALISM`): `lab`, an analyser-like logger (1 kHz, speed and rate of turn
exact); `field`, what a robot's own log carries: a slow logger (20 Hz), noise on power, speed
and rate of turn (a gyro's), speed quantized to encoder steps, drop-outs (the logger missing
a sample or two), and a run-to-run gain (battery voltage and temperature: every term of a run
scaled by one factor). Every logged sample is the mean over its period (log-format.md: power
as an analyser's, speed as an encoder's count over the period).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.drive.terms import power_W as drive_power_W
from wifibot_power.io.manifest import MANIFEST_HEADER
from wifibot_power.io.writer import csv_bytes, write_log
from wifibot_power.outputs import write_atomic

if TYPE_CHECKING:
    from wifibot_power.run import Run

#: The simulator's internal clock [s].
INTERNAL_S = 1e-3

#: Realism levels: logger period [s], power noise per logged sample [W], speed noise [m/s]
#: and encoder step [m/s] (0: none), rate-of-turn noise [rad/s], drop-outs per minute, and the
#: run-to-run gain's relative spread.
FREE_REALISM: dict[str, dict[str, float]] = {
    "lab": {
        "sample_period_s": 1e-3,
        "power_noise_W": 0.5,
        "speed_noise_mps": 0.0,
        "speed_step_mps": 0.0,
        "yaw_noise_radps": 0.0,
        "dropouts_per_min": 0.0,
        "gain_spread": 0.0,
    },
    "field": {
        "sample_period_s": 0.05,
        "power_noise_W": 2.0,
        "speed_noise_mps": 0.01,
        "speed_step_mps": 0.02,
        "yaw_noise_radps": 0.005,
        "dropouts_per_min": 2.0,
        "gain_spread": 0.01,
    },
}


@dataclass(frozen=True)
class FreeDriveConfig:
    """What `simulate --drive free` writes: `runs_per_surface` runs of `run_s` seconds on each
    surface, with the true terms below (a ~20 kg skid-steer robot; docs/drive-model.md)."""

    surfaces: tuple[str, ...] = ("asphalt", "grass")
    runs_per_surface: int = 8
    run_s: float = 90.0
    realism: str = "field"
    seed: int = 0
    lag_s: float = 0.2
    idle_W: float = 12.0
    drive_on_W: float = 3.0
    quadratic_W_per_mps2: float = 8.0
    effective_mass_kg: float = 30.0
    braking_mass_kg: float = 10.0
    rolling_W_per_mps: dict[str, float] = field(
        default_factory=lambda: {"asphalt": 20.0, "grass": 45.0}
    )
    turning_Nm: dict[str, float] = field(default_factory=lambda: {"asphalt": 25.0, "grass": 60.0})
    max_speed_mps: float = 1.5
    max_accel_mps2: float = 1.0
    max_yaw_radps: float = 1.5
    max_yaw_accel_radps2: float = 3.0
    #: override any FREE_REALISM value (e.g. {"sample_period_s": 1e-4} for a 10 kHz log)
    realism_overrides: dict[str, float] = field(default_factory=dict)
    #: which kinds of motion the routes hold (a test leaves turning out)
    turning: bool = True
    reversing: bool = True

    def level(self) -> dict[str, float]:
        if self.realism not in FREE_REALISM:
            from wifibot_power.errors import UsageError

            raise UsageError(
                f"realism '{self.realism}'", fix=f"give --realism {'|'.join(FREE_REALISM)}"
            )
        return {**FREE_REALISM[self.realism], **self.realism_overrides}

    def coefficients(self, surface: str) -> dict[str, float]:
        """The true coefficients on `surface` (terms.power_W's keys)."""
        return {
            "idle_W": self.idle_W,
            "drive_on_W": self.drive_on_W,
            "rolling_W_per_mps": self.rolling_W_per_mps[surface],
            "quadratic_W_per_mps2": self.quadratic_W_per_mps2,
            "effective_mass_kg": self.effective_mass_kg,
            "braking_mass_kg": self.braking_mass_kg,
            "turning_Nm": self.turning_Nm[surface] if self.turning else 0.0,
        }

    def truth(self) -> dict[str, object]:
        """truth.json's true terms, in the shape of the drive summary's `terms`/`surfaces`."""
        return {
            "terms": {
                "idle_W": self.idle_W,
                "drive_on_W": self.drive_on_W,
                "quadratic_W_per_mps2": self.quadratic_W_per_mps2,
                "effective_mass_kg": self.effective_mass_kg,
                "braking_mass_kg": self.braking_mass_kg,
            },
            "surfaces": {
                s: {
                    "rolling_W_per_mps": self.rolling_W_per_mps[s],
                    **({"turning_Nm": self.turning_Nm[s]} if self.turning else {}),
                }
                for s in self.surfaces
            },
            "lag_s": self.lag_s,
        }


@dataclass(frozen=True)
class FreeRun:
    """One simulated run: the logged columns, its surface, and its true energy [J]."""

    run_id: str
    surface: str
    time_s: np.ndarray
    power_W: np.ndarray
    speed_mps: np.ndarray
    yaw_rate_radps: np.ndarray
    true_energy_J: float
    gain: float


def simulate_free(config: FreeDriveConfig) -> list[FreeRun]:
    """The runs of `config` (same seed, same runs)."""
    level = config.level()
    rng = np.random.default_rng(config.seed)
    runs = []
    for k in range(config.runs_per_surface * len(config.surfaces)):
        surface = config.surfaces[k % len(config.surfaces)]
        runs.append(_one_run(config, level, rng, f"free_{k + 1:03d}_{surface}", surface))
    return runs


def _route(config: FreeDriveConfig, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Knots (time, speed) and (time, rate of turn) of a random route: a loop over segments
    (not samples); speed and rate of turn ramp between segment targets at bounded rates."""
    v_knots, w_knots = [(0.0, 0.0)], [(0.0, 0.0)]
    t = 0.0
    v = w = 0.0
    while t < config.run_s:
        kind = rng.choice(
            ["stop", "straight", "arc", "spin"],
            p=[0.25, 0.3, 0.3, 0.15] if config.turning else [0.3, 0.7, 0.0, 0.0],
        )
        if kind == "stop":
            target_v, target_w, hold = 0.0, 0.0, rng.uniform(0.5, 5.0)
        elif kind == "spin":
            target_v = 0.0
            target_w = rng.choice([-1, 1]) * rng.uniform(0.4, config.max_yaw_radps)
            hold = rng.uniform(1.0, 3.0)
        else:
            sign = -1.0 if config.reversing and rng.random() < 0.15 else 1.0
            target_v = sign * rng.uniform(0.15, config.max_speed_mps)
            target_w = 0.0
            if kind == "arc":
                target_w = rng.choice([-1, 1]) * rng.uniform(0.2, 1.0)
            hold = rng.uniform(1.5, 8.0)
        ramp = max(
            abs(target_v - v) / config.max_accel_mps2,
            abs(target_w - w) / config.max_yaw_accel_radps2,
        )
        t += ramp
        v_knots.append((t, target_v))
        w_knots.append((t, target_w))
        t += hold
        v_knots.append((t, target_v))
        w_knots.append((t, target_w))
        v, w = target_v, target_w
    return np.array(v_knots), np.array(w_knots)


def _one_run(
    config: FreeDriveConfig,
    level: dict[str, float],
    rng: np.random.Generator,
    run_id: str,
    surface: str,
) -> FreeRun:
    v_knots, w_knots = _route(config, rng)
    n = int(round(config.run_s / INTERNAL_S))
    t = np.arange(n) * INTERNAL_S
    speed = np.interp(t, v_knots[:, 0], v_knots[:, 1])
    yaw = np.interp(t, w_knots[:, 0], w_knots[:, 1])
    accel = np.gradient(speed, INTERNAL_S)
    gain = 1.0 + level["gain_spread"] * rng.standard_normal()
    true_W = gain * drive_power_W(speed, accel, yaw, config.coefficients(surface))
    lag = int(round(config.lag_s / INTERNAL_S))
    delayed_W = np.concatenate((np.full(lag, true_W[0]), true_W[: n - lag]))
    period = level["sample_period_s"]
    per = max(int(round(period / INTERNAL_S)), 1)
    if per > 1:  # each logged sample is the mean over its period (log-format.md), power as an
        # analyser's, speed as an encoder's count over the period, rate of turn as a gyro's
        count = n // per
        power_W, speed_s, yaw_s = (
            values[: count * per].reshape(count, per).mean(axis=1)
            for values in (delayed_W, speed, yaw)
        )
        time_s = np.arange(count) * per * INTERNAL_S
    else:  # a logger faster than the internal clock: interpolate (power varies slowly)
        time_s = np.arange(int(config.run_s / period)) * period
        power_W = np.interp(time_s, t, delayed_W)
        speed_s, yaw_s = np.interp(time_s, t, speed), np.interp(time_s, t, yaw)
    true_energy_J = float(np.sum(true_W) * INTERNAL_S)
    power_W = power_W + level["power_noise_W"] * rng.standard_normal(power_W.size)
    speed_s = speed_s + level["speed_noise_mps"] * rng.standard_normal(speed_s.size)
    if level["speed_step_mps"] > 0:
        speed_s = np.round(speed_s / level["speed_step_mps"]) * level["speed_step_mps"]
    yaw_s = yaw_s + level["yaw_noise_radps"] * rng.standard_normal(yaw_s.size)
    # drop-outs: 1 or 2 samples missing (the reader refuses longer gaps as energy unknown:
    # over 3 sample periods or 1% of the log, log-format.md), each apart from the others: one
    # that would touch or overlap another (within 3 samples: together a gap the reader
    # refuses; 32 of make bench's 200 one-hour runs were refused so) is not made. The draws
    # are the same either way, so a run without such a pair is the same log as before.
    keep = np.ones(time_s.size, dtype=bool)
    for _ in range(rng.poisson(level["dropouts_per_min"] * config.run_s / 60.0)):
        start = int(rng.integers(1, max(time_s.size - 3, 2)))
        stop = start + int(rng.integers(1, 3))
        if keep[max(start - 3, 0) : stop + 3].all():
            keep[start:stop] = False
    return FreeRun(
        run_id=run_id,
        surface=surface,
        time_s=time_s[keep],
        power_W=power_W[keep],
        speed_mps=speed_s[keep],
        yaw_rate_radps=yaw_s[keep],
        true_energy_J=true_energy_J,
        gain=gain,
    )


def format_free_log(run: FreeRun, decimals: int = 4) -> bytes:
    """The canonical CSV of a run: time, power, speed and rate of turn, with its surface."""
    header = ["# wbpower-log: 1", f"# run_id: {run.run_id}", f"# surface: {run.surface}"]
    columns = {
        "time_s": np.round(run.time_s, 6),
        "power_W": np.round(run.power_W, decimals),
        "speed_mps": np.round(run.speed_mps, 5),
        "yaw_rate_radps": np.round(run.yaw_rate_radps, 5),
    }
    return csv_bytes([*header, ",".join(columns)], columns)


def write_free(config: FreeDriveConfig, out_dir: Path) -> dict[str, object]:
    """Write the runs as canonical logs, `runs.csv` and `truth.json`; a summary."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    start = datetime(2026, 1, 1, tzinfo=UTC)
    manifest = [MANIFEST_HEADER]
    runs_truth = []
    total = 0
    runs = simulate_free(config)
    for k, run in enumerate(runs):
        name = f"{run.run_id}.csv"
        data = format_free_log(run)
        write_log(out_dir / name, data)
        total += len(data)
        started = (start + timedelta(seconds=k * (config.run_s + 60))).isoformat()
        manifest.append(",".join([name, run.run_id, "unknown", "", "", "", "", started]))
        runs_truth.append(
            {
                "file": name,
                "run_id": run.run_id,
                "surface": run.surface,
                "true_energy_J": run.true_energy_J,
                "gain": run.gain,
            }
        )
    write_atomic(out_dir / "runs.csv", lambda tmp: tmp.write_text("\n".join(manifest) + "\n"))
    truth = {
        "generator": "wbpower simulate --drive free",
        "seed": config.seed,
        "realism": config.realism,
        "level": config.level(),
        **config.truth(),
        "runs": runs_truth,
    }
    write_atomic(out_dir / "truth.json", lambda tmp: tmp.write_text(json.dumps(truth, indent=1)))
    return {"out_dir": str(out_dir), "runs": len(runs), "csv_bytes": total, "seed": config.seed}


def with_seed(config: FreeDriveConfig, seed: int) -> FreeDriveConfig:
    return replace(config, seed=seed)


def as_run(run: FreeRun) -> Run:
    """The run as the reader would give it from its log (no file written)."""
    from wifibot_power.run import Run, RunMeta

    step_s = np.diff(run.time_s)
    period_s = float(np.median(step_s)) if step_s.size else FREE_REALISM["lab"]["sample_period_s"]
    meta = RunMeta(run_id=run.run_id, sample_period_s=period_s, extra={"surface": run.surface})
    return Run(
        file=f"{run.run_id}.csv",
        format="wbpower-csv",
        meta=meta,
        stamps_s=run.time_s,
        power_W=run.power_W,
        speed_mps=run.speed_mps,
        yaw_rate_radps=run.yaw_rate_radps,
    )
