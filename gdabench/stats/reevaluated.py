"""Re-evaluated scores: a trial scored by its best body's mean over further training seeds.

A trial's raw best is the highest reward among the bodies it evaluated, each trained once; where the
reward depends on the training seed that maximum is biased upward (the winner's curse).  The run's
re-evaluation (:mod:`gdabench.running.reevaluation`) trains the trial's ``top`` best bodies again
under ``seeds`` further seeds each.  Here:

* a body's **evaluation noise** is the standard deviation of its rewards over those further seeds
  (ddof 1), beside the reward that selected it;
* the trial's **re-evaluated best** is the highest of its re-evaluated bodies' means over the further
  seeds (the training that selected a body is left out, so its luck does not count; choosing the best
  of ``top`` means of ``seeds`` rewards keeps a much smaller upward bias than the best of a budget's
  single trainings);
* the **drop** is raw best minus re-evaluated best: how much of the raw figure was luck.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from ..statuses import OK
from .core import with_run_id

TRIAL = ["env", "designer", "run_id", "seed"]
BODY_COLUMNS = [*TRIAL, "rank", "body", "body_hash", "first_reward", "replicates", "mean", "sd", "min", "max"]
TRIAL_COLUMNS = [*TRIAL, "raw_best", "raw_body", "reevaluated_best", "reevaluated_body", "reevaluated_sd",
                 "replicates", "bodies", "drop"]  # fmt: skip


def body_noise(reevaluations: pd.DataFrame) -> pd.DataFrame:
    """One row per re-evaluated body of every trial: the reward that selected it and its rewards over the
    further seeds (count, mean, SD, min, max)."""
    ok = with_run_id(reevaluations[reevaluations["status"] == OK])
    if ok.empty:
        return pd.DataFrame(columns=BODY_COLUMNS)
    keys = [*TRIAL, "rank", "body", "body_hash", "first_reward"]
    out = ok.groupby(keys, sort=False)["reward"].agg(replicates="count", mean="mean", sd="std", min="min", max="max")
    return out.reset_index()[BODY_COLUMNS]


def trial_scores(frame: pd.DataFrame, reevaluations: pd.DataFrame) -> pd.DataFrame:
    """One row per trial with re-evaluations: raw best (and its body), re-evaluated best (the best mean over
    further seeds, its body and that body's SD), replicates behind it, bodies re-evaluated, and the drop."""
    bodies = body_noise(reevaluations)
    ok = with_run_id(frame[frame["status"] == OK])
    rows = []
    for key, mine in bodies.groupby(TRIAL, sort=False):
        trial = ok[(ok[TRIAL] == pd.Series(key, index=TRIAL)).all(axis=1)]
        raw = trial.loc[trial["reward"].idxmax()] if len(trial) else None
        best = mine.sort_values(["mean", "rank"], ascending=[False, True], kind="stable").iloc[0]
        raw_best = float(raw["reward"]) if raw is not None else math.nan
        rows.append({
            **dict(zip(TRIAL, key)), "raw_best": raw_best, "raw_body": raw["body"] if raw is not None else "",
            "reevaluated_best": float(best["mean"]), "reevaluated_body": best["body"],
            "reevaluated_sd": float(best["sd"]) if best["replicates"] > 1 else math.nan,
            "replicates": int(best["replicates"]), "bodies": len(mine), "drop": raw_best - float(best["mean"]),
        })  # fmt: skip
    return pd.DataFrame(rows, columns=TRIAL_COLUMNS)


def pooled_sd(bodies: pd.DataFrame) -> float:
    """The evaluation noise of a table's bodies in one figure: the SD pooled over bodies (each weighted by its
    replicates minus one)."""
    usable = bodies[bodies["replicates"] > 1]
    if usable.empty:
        return math.nan
    dof = usable["replicates"] - 1
    return float(np.sqrt((dof * usable["sd"] ** 2).sum() / dof.sum()))

