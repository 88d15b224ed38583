"""Per-designer summary of a run, computed from the evaluations table alone.

One row per (designer, env, controller): how good the best body is over seeds (median with its
exact order-statistic interval and that interval's coverage, and the spread), how many seeds reached a threshold (the
environment's optimum unless another is chosen) and after how many evaluations, the mean
best-so-far reward (area under the best-so-far curve per evaluation), and how long a run took.
Runs that never reach the threshold are censored: they count as "not reached" in the median and
its interval instead of being dropped, so the median is not flattered (see
:mod:`.stats`).
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Union

import pandas as pd

from ..statuses import COUNTED, OK
from .core import (
    CONFIDENCE,
    best_so_far_curve,
    censored,
    censored_median,
    first_reach,
    mean_best_so_far,
    median_interval,
)

GROUP = ["designer", "env", "controller"]
PER_RUN_COLUMNS = ["best_reward", "evaluations", "evals_to_threshold", "mean_best_so_far", "wall_seconds"]
#: one threshold for every environment, or one per environment label (None: none)
Threshold = Union[float, Mapping[str, Union[float, None]], None]


def threshold_of(threshold: Threshold, env: str) -> float | None:
    if isinstance(threshold, Mapping):
        return threshold.get(env)
    return threshold


def thresholds(meta: Mapping[str, Any], override: float | None = None) -> Threshold:
    """The threshold of each environment of a run: ``override``, else each environment's optimum
    as ``run.json`` recorded it (None where unknown)."""
    if override is not None:
        return override
    envs = meta.get("envs")
    if isinstance(envs, Mapping):
        return {label: (info or {}).get("optimum") for label, info in envs.items()}
    return meta.get("env_optimum")


def per_run(evaluations: pd.DataFrame, threshold: Threshold = None) -> pd.DataFrame:
    """One row per (designer, env, controller, seed): best reward, evaluations, time to threshold."""
    keys = GROUP + ["seed"]
    rows = []
    for key, g in evaluations.groupby(keys, sort=False, dropna=False):
        ok = g[g["status"] == OK]
        evaluations_used = int(g["status"].isin(COUNTED).sum())
        target = threshold_of(threshold, key[1])
        rows.append(
            {
                **dict(zip(keys, key)),
                "best_reward": float(ok["reward"].max()) if len(ok) else math.nan,
                "evaluations": evaluations_used,
                "evals_to_threshold": first_reach(g, target) if target is not None else math.nan,
                "mean_best_so_far": mean_best_so_far(best_so_far_curve(g, evaluations_used)),
                "wall_seconds": float(g["elapsed_seconds"].max()),
            }
        )
    return pd.DataFrame(rows, columns=keys + PER_RUN_COLUMNS)


def summarize(
    evaluations: pd.DataFrame,
    threshold: Threshold = None,
    *,
    confidence: float = CONFIDENCE,
    reevaluations: pd.DataFrame | None = None,
) -> pd.DataFrame:
    """Summary table, one row per (designer, env, controller), in the order designers appear.

    With the run's ``reevaluations``, ``reevaluated_*`` columns give the median over seeds of the trials'
    re-evaluated best (:mod:`.reevaluated`) and its interval (NaN for designers without re-evaluations).

    ``*_ci_low`` / ``*_ci_high`` bound the median over seeds (exact order-statistic interval of at
    least ``confidence`` where the seeds allow it); ``*_ci_level`` is that interval's coverage, below
    ``confidence`` when there are too few seeds (5 seeds: 0.9375).  Evaluations to the threshold are
    ``inf`` where censored runs decide.
    """
    runs = per_run(evaluations, threshold)
    again = None
    if reevaluations is not None and len(reevaluations):
        from .reevaluated import trial_scores

        again = trial_scores(evaluations, reevaluations)
    out = []
    for key, g in runs.groupby(GROUP, sort=False, dropna=False):
        target = threshold_of(threshold, key[1])
        best = g["best_reward"].dropna()
        auc = g["mean_best_so_far"].dropna()
        to_threshold = censored(g["evals_to_threshold"])
        row = {
            **dict(zip(GROUP, key)),
            "seeds": len(g),
            "best_median": float(best.median()),
            **_ci("best", best, confidence),
            "best_q25": float(best.quantile(0.25)),
            "best_q75": float(best.quantile(0.75)),
            "best_min": float(best.min()),
            "best_max": float(best.max()),
            "evaluations_median": float(g["evaluations"].median()),
            "threshold": target if target is not None else math.nan,
            "seeds_reached": int(g["evals_to_threshold"].notna().sum()) if target is not None else 0,
            "evals_to_threshold_median": censored_median(g["evals_to_threshold"]) if target is not None else math.nan,
            **_ci("evals_to_threshold", to_threshold if target is not None else [], confidence),
            "mean_best_so_far_median": float(auc.median()),
            **_ci("mean_best_so_far", auc, confidence),
            "wall_seconds_median": float(g["wall_seconds"].median()),
        }
        if again is not None:
            mine = again[(again["designer"] == key[0]) & (again["env"] == key[1])]["reevaluated_best"]
            row.update(reevaluated_median=float(mine.median()) if len(mine) else math.nan,
                       **_ci("reevaluated", mine, confidence))  # fmt: skip
        out.append(row)
    return pd.DataFrame(out)


def _ci(name: str, values, confidence: float) -> dict[str, float]:
    interval = median_interval(values, confidence)
    return {f"{name}_ci_low": interval.low, f"{name}_ci_high": interval.high, f"{name}_ci_level": interval.level}


#: statuses of rows whose body was not scored
PROBLEMS = ("error", "timeout", "invalid")


def failure_counts(evaluations: pd.DataFrame, examples: int = 2) -> pd.DataFrame:
    """Per (designer, env) with any problem: error, timeout and invalid rows, the first distinct
    messages, and how many trials had every evaluation fail (a trial that measured nothing)."""
    rows = []
    for (designer, env), g in evaluations.groupby(["designer", "env"], sort=False):
        counts = {status: int((g["status"] == status).sum()) for status in PROBLEMS}
        if not any(counts[s] for s in ("error", "timeout")) and not counts["invalid"]:
            continue
        failed = g[g["status"].isin(("error", "timeout"))]
        messages = list(dict.fromkeys(failed["message"].astype(str)))[:examples]
        counted = g[g["status"].isin(COUNTED)]
        hopeless = (
            int((counted.groupby("seed")["status"].apply(lambda s: bool((s != OK).all()))).sum()) if len(counted) else 0
        )
        parts = [f"{n} {status}" for status, n in counts.items() if n]
        line = ", ".join(parts) + (f"; first: {'; '.join(messages)}" if messages else "")
        rows.append(
            {
                "designer": designer,
                "env": env,
                **counts,
                "all_failed_trials": hopeless,
                "messages": messages,
                "line": line,
            }
        )
    return pd.DataFrame(rows, columns=["designer", "env", *PROBLEMS, "all_failed_trials", "messages", "line"])


def nothing_measured(counts: pd.DataFrame) -> str | None:
    """The line that says trials measured nothing (every evaluation failed), from :func:`failure_counts`;
    None if none did."""
    hopeless = counts[counts["all_failed_trials"] > 0]
    if not len(hopeless):
        return None
    first = hopeless.iloc[0]
    return (
        f"every evaluation failed in {int(hopeless['all_failed_trials'].sum())} trial(s), "
        f"e.g. {first['designer']} on {first['env']}"
    )
