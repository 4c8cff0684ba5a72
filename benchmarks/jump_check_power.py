"""How often thermal drift's jump check (`step_beside_line`, p < 1e-3 Bonferroni over the
splits) sees a step between the session's halves beside a line, with 0.5 % run-to-run
scatter of the ratio, by session length: the table docs/diagnose.md ("What the checks cost")
quotes. Seeded; a few seconds.

    .venv/bin/python benchmarks/jump_check_power.py
"""

from __future__ import annotations

import numpy as np

from wifibot_power.causes.thermal_drift import step_beside_line

DRAWS = 300


def main() -> None:
    rng = np.random.default_rng(1)
    print("| runs | step 1% | step 2% | step 4% | step 8% |")
    print("| --- | --- | --- | --- | --- |")
    for n in (12, 30):
        tau_min = np.linspace(0.5, 12, n)
        cells = []
        for step in (0.01, 0.02, 0.04, 0.08):
            hits = 0
            for _ in range(DRAWS):
                ratio = 0.005 * tau_min + rng.normal(0, 0.005, n)
                ratio += step * (np.arange(n) >= n // 2)
                hits += step_beside_line(ratio, tau_min)[0] < 1e-3
            cells.append(f"{100 * hits / DRAWS:.0f}%")
        print(f"| {n} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
