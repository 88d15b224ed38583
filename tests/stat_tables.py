"""Hand-made evaluations tables for the statistics and export tests."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd


def table(runs: dict[tuple[str, str, int], list[float]], *, population: int = 2, run_id: str = "r1") -> pd.DataFrame:
    """A minimal evaluations table: one row per evaluation; NaN rewards are failed evaluations."""
    rows = []
    for (env, designer, seed), rewards in runs.items():
        for n, reward in enumerate(rewards, start=1):
            failed = isinstance(reward, float) and math.isnan(reward)
            rows.append(
                {
                    "run_id": run_id, "designer": designer, "env": env, "controller": "", "population": population,
                    "budget": len(rewards), "seed": seed, "generation": (n - 1) // population, "index": (n - 1) % population,
                    "body": "44444/44444/44444/44444/44444", "body_hash": f"{designer}-{seed}-{n}", "reward": reward,
                    "status": "error" if failed else "ok", "n_evals": n, "best_so_far": np.nan, "elapsed_seconds": 0.0,
                }
            )  # fmt: skip
    return pd.DataFrame(rows)
