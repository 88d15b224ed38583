"""The report's section on re-evaluated scores (the scores themselves: :mod:`gdabench.stats.reevaluated`)."""

from __future__ import annotations

import pandas as pd

from ..stats.core import median_interval
from ..stats.reevaluated import TRIAL, body_noise, pooled_sd, trial_scores
from .content import Section, Table
from .tables import number, with_interval


def which_bodies(top: int) -> str:
    """How many of a trial's bodies were re-evaluated, in words ("best body" for one)."""
    return "best body" if top == 1 else f"{top} best bodies"


def section(frame: pd.DataFrame, reevaluations: pd.DataFrame, designers: list[str], confidence: float):
    """The report's section on re-evaluated scores, and its CSV tables."""
    trials = trial_scores(frame, reevaluations)
    bodies = body_noise(reevaluations)
    several = trials["env"].nunique() > 1
    top = int(bodies.groupby([*TRIAL])["rank"].max().max()) if len(bodies) else 0
    rows = []
    for (env, designer), g in trials.groupby(["env", "designer"], sort=False):
        raw, again = median_interval(g["raw_best"], confidence), median_interval(g["reevaluated_best"], confidence)
        noise = pooled_sd(bodies[(bodies["env"] == env) & (bodies["designer"] == designer)])
        changed = int((g["raw_body"] != g["reevaluated_body"]).sum())
        rows.append([designer, *([env] if several else []), str(len(g)),
                     with_interval(raw.median, raw.low, raw.high, level=raw.level, confidence=confidence),
                     with_interval(again.median, again.low, again.high, level=again.level, confidence=confidence),
                     number(float(g["drop"].median())), number(noise, 3),
                     f"{changed}/{len(g)}" if top > 1 else "-"])  # fmt: skip
    order = {d: i for i, d in enumerate(designers)}
    rows.sort(key=lambda r: order.get(r[0], len(order)))
    replicates = int(bodies["replicates"].max()) if len(bodies) else 0
    ci = f"median [{confidence:.0%} CI]"
    table = Table(
        "Raw and re-evaluated best per designer",
        ["designer", *(["env"] if several else []), "trials", f"raw best, {ci}", f"re-evaluated best, {ci}",
         "drop, median", "noise SD (pooled)", "best body changed"],  # fmt: skip
        rows,
        "Raw best: the highest reward of the trial, each body trained once. Re-evaluated best: the highest mean, "
        f"over {replicates} further training seeds, of the trial's {which_bodies(top)}. Drop: raw minus re-evaluated, "
        "per trial. Noise SD: the SD of a body's rewards over the further seeds, pooled over the designer's "
        "re-evaluated bodies. Best body changed: trials whose re-evaluated best is another body than the raw best"
        + (" (-: with one body re-evaluated per trial it cannot change)." if top == 1 else "."),
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
    again_how = (f"best body was trained again under {replicates} further seeds" if top == 1 else
                 f"{top} best bodies were trained again under {replicates} further seeds each")  # fmt: skip
    score_how = "that body's mean" if top == 1 else "the best of those bodies' means"
    intro = (
        f"A trial's best reward is the largest of many single trainings, so part of it is the luck of a training "
        f"seed (the winner's curse). After the trials, each trial's {again_how} (seeds of their own, never the one "
        f"that selected the body); the trial's re-evaluated best is {score_how}. The statistics below test and "
        f"aggregate the re-evaluated best."
    )
    tables = {
        "reevaluated_trials.csv": (trials, "per trial: raw best, re-evaluated best and its body's SD, drop"),
        "reevaluated_bodies.csv": (bodies, "per re-evaluated body: the reward that selected it, and its rewards over "
                                           "the further seeds (count, mean, SD, min, max)"),  # fmt: skip
    }
    return Section("Re-evaluated scores", [], intro, tables=[table, per_trial]), tables
