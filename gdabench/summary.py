"""Per-designer summary of a run, computed from the evaluations table alone.

One row per (designer, env, controller): how good the best body is over seeds (median and
spread), how many seeds reached the environment's optimum and after how many evaluations, and
how long a run took.  Runs that never reach the optimum are censored: they count as "not
reached" in the median instead of being dropped, so the median is not flattered.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from .evaluation import COUNTED, OK

GROUP = ["designer", "env", "controller"]


def per_run(evaluations: pd.DataFrame, optimum: float | None = None, tol: float = 1e-9) -> pd.DataFrame:
    """One row per (designer, env, controller, seed): best reward, evaluations, time to optimum."""
    keys = GROUP + ["seed"]
    rows = []
    for key, g in evaluations.groupby(keys, sort=False, dropna=False):
        ok = g[g["status"] == OK]
        best = float(ok["reward"].max()) if len(ok) else math.nan
        to_opt = math.nan
        if optimum is not None and len(ok):
            hit = ok[ok["reward"] >= optimum - tol]
            if len(hit):
                to_opt = float(hit["n_evals"].min())
        rows.append(
            {
                **dict(zip(keys, key)),
                "best_reward": best,
                "evaluations": int(g["status"].isin(COUNTED).sum()),
                "evals_to_optimum": to_opt,
                "wall_seconds": float(g["elapsed_seconds"].max()),
            }
        )
    return pd.DataFrame(rows, columns=keys + ["best_reward", "evaluations", "evals_to_optimum", "wall_seconds"])


def _censored_median(values: pd.Series) -> float:
    """Median where NaN means "never reached" (+inf); inf when half or more never reached."""
    v = values.to_numpy(dtype=float)
    return float(np.median(np.where(np.isnan(v), np.inf, v))) if len(v) else math.nan


def summarize(evaluations: pd.DataFrame, optimum: float | None = None) -> pd.DataFrame:
    """Summary table, one row per (designer, env, controller), in the order designers appear."""
    runs = per_run(evaluations, optimum)
    out = []
    for key, g in runs.groupby(GROUP, sort=False, dropna=False):
        best = g["best_reward"]
        row = {
            **dict(zip(GROUP, key)),
            "seeds": len(g),
            "best_median": float(best.median()),
            "best_q25": float(best.quantile(0.25)),
            "best_q75": float(best.quantile(0.75)),
            "best_min": float(best.min()),
            "best_max": float(best.max()),
            "evaluations_median": float(g["evaluations"].median()),
            "optimum": optimum if optimum is not None else math.nan,
            "seeds_at_optimum": int(g["evals_to_optimum"].notna().sum()) if optimum is not None else 0,
            "evals_to_optimum_median": _censored_median(g["evals_to_optimum"]) if optimum is not None else math.nan,
            "wall_seconds_median": float(g["wall_seconds"].median()),
        }
        out.append(row)
    return pd.DataFrame(out)
