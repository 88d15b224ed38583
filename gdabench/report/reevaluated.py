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
from .runtimes import with_run_id

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


def section(frame: pd.DataFrame, reevaluations: pd.DataFrame, designers: list[str], confidence: float):
    """The report's section on re-evaluated scores, and its CSV tables."""
    from .content import Section, Table
    from .stats import median_interval
    from .tables import number, with_interval

    trials = trial_scores(frame, reevaluations)
    bodies = body_noise(reevaluations)
    several = trials["env"].nunique() > 1
    rows = []
    for (env, designer), g in trials.groupby(["env", "designer"], sort=False):
        raw, again = median_interval(g["raw_best"], confidence), median_interval(g["reevaluated_best"], confidence)
        noise = pooled_sd(bodies[(bodies["env"] == env) & (bodies["designer"] == designer)])
        changed = int((g["raw_body"] != g["reevaluated_body"]).sum())
        rows.append([designer, *([env] if several else []), str(len(g)),
                     with_interval(raw.median, raw.low, raw.high, level=raw.level, confidence=confidence),
                     with_interval(again.median, again.low, again.high, level=again.level, confidence=confidence),
                     number(float(g["drop"].median())), number(noise, 3), f"{changed}/{len(g)}"])  # fmt: skip
    order = {d: i for i, d in enumerate(designers)}
    rows.sort(key=lambda r: order.get(r[0], len(order)))
    top = int(bodies.groupby([*TRIAL])["rank"].max().max()) if len(bodies) else 0
    replicates = int(bodies["replicates"].max()) if len(bodies) else 0
    ci = f"median [{confidence:.0%} CI]"
    table = Table(
        "Raw and re-evaluated best per designer",
        ["designer", *(["env"] if several else []), "trials", f"raw best, {ci}", f"re-evaluated best, {ci}",
         "drop, median", "noise SD (pooled)", "best body changed"],  # fmt: skip
        rows,
        "Raw best: the highest reward of the trial, each body trained once. Re-evaluated best: the highest mean, "
        f"over {replicates} further training seeds, of the trial's {top} best bodies. Drop: raw minus re-evaluated, "
        "per trial. Noise SD: the SD of a body's rewards over the further seeds, pooled over the designer's "
        "re-evaluated bodies. Best body changed: trials whose re-evaluated best is another body than the raw best.",
    )
    per_trial = Table(
        "Per trial",
        ["designer", *(["env"] if several else []), "seed", "raw best", "re-evaluated best (SD)", "drop", "body"],
        [[r.designer, *([r.env] if several else []), str(r.seed), number(r.raw_best),
          f"{number(r.reevaluated_best)} ({number(r.reevaluated_sd, 3)})", number(r.drop),
          r.reevaluated_body + (" (not the raw best)" if r.reevaluated_body != r.raw_body else "")]
         for r in trials.sort_values(["designer", "seed"], key=lambda c: c.map(order) if c.name == "designer" else c,
                                     kind="stable").itertuples()],  # fmt: skip
    )
    intro = (
        f"A trial's best reward is the largest of many single trainings, so part of it is the luck of a training "
        f"seed (the winner's curse). After the trials, each trial's {top} best bodies were trained again under "
        f"{replicates} further seeds each (seeds of their own, never the one that selected the body); the trial's "
        f"re-evaluated best is the best of those bodies' means. The statistics below test and aggregate the "
        f"re-evaluated best."
    )
    tables = {
        "reevaluated_trials.csv": (trials, "per trial: raw best, re-evaluated best and its body's SD, drop"),
        "reevaluated_bodies.csv": (bodies, "per re-evaluated body: the reward that selected it, and its rewards over "
                                           "the further seeds (count, mean, SD, min, max)"),  # fmt: skip
    }
    return Section("Re-evaluated scores", [], intro, tables=[table, per_trial]), tables
