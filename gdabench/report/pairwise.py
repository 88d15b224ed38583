"""Designer against designer, per environment: a test, a corrected p-value and an effect size.

**When runs are paired.**  Designers compared in one run (one ``run_id``) get the same seeds, and
a seed fixes everything random about a run: the designers that start from Evolution Gym's
sampler (ga, gda, random) even propose the same first generation under the same seed.  So two
designers' runs are *paired* when they come from the same run with the same seed.  With
``pairing="auto"`` (the default) a pair of designers is tested paired when every run of each has
its partner (the same (run id, seed) keys on both sides); otherwise -- tables
concatenated from different runs, or seeds missing on one side -- unpaired.  ``"paired"`` pairs
on the common keys and drops the rest; ``"unpaired"`` never pairs.

**Tests.**  Paired: Wilcoxon's signed-rank test on the per-seed differences (zero differences
dropped, exact p-values for small samples without ties, as scipy does).  Unpaired: the
Mann-Whitney U test.  Both two-sided.  A paired test rests on its *non-tied* pairs only (two
designers whose runs found the same best body under one seed tie there), and says how many
(``untied``); with fewer than :func:`~.power.minimum_seeds` of them no outcome can be significant.

**Primary and exploratory.**  An experiment may name one *primary* comparison before it runs
(:class:`~gdabench.experiment.config.Primary`): that pair is tested alone, on its metric, at its level, with
no correction.  Every other pair is *exploratory*: the p-values of all of them of one environment
and metric are one family, corrected with Holm's step-down procedure, which controls the chance
of any false "significant" among them at ``alpha``.

**Effect size.**  Vargha and Delaney's A12 = P(A > B) + P(A = B) / 2 over all runs of the two
designers (0.5: no effect), called negligible below 0.56 (or above 0.44), small below 0.64,
medium below 0.71 and large beyond.  The median difference is the median of the per-seed
differences when paired, the difference of the medians otherwise.
"""

from __future__ import annotations

import math
import warnings
from itertools import combinations
from typing import Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from scipy.stats import mannwhitneyu, wilcoxon

from ..errors import ConfigError
from ..experiment.config import Primary
from ..stats.core import with_run_id
from ..stats.power import ALPHA, POWER, minimum_seeds, seeds_needed
from .runtimes import resolve_metric, run_scores

PAIRINGS = ("auto", "paired", "unpaired")
#: |A12 - 0.5| thresholds of Vargha and Delaney (2000) for a small, medium and large effect
MAGNITUDES = ((0.06, "negligible"), (0.14, "small"), (0.21, "medium"))

COLUMNS = [
    "env", "designer_a", "designer_b", "metric", "role", "n_a", "n_b", "pairs", "untied", "test", "same_start",
    "median_a", "median_b", "difference", "statistic", "p", "p_holm", "a12", "magnitude",
    "significant", "seeds_for_power", "verdict",
]  # fmt: skip


def a12(x: ArrayLike, y: ArrayLike) -> float:
    """Vargha-Delaney A12: probability that a value of ``x`` beats one of ``y``, ties counting half."""
    a, b = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if not len(a) or not len(b):
        return math.nan
    greater = (a[:, None] > b[None, :]).mean()
    equal = (a[:, None] == b[None, :]).mean()
    return float(greater + 0.5 * equal)


def magnitude(a: float) -> str:
    """Vargha-Delaney's name for an A12 value."""
    if math.isnan(a):
        return "-"
    distance = abs(a - 0.5)
    for limit, name in MAGNITUDES:
        if distance < limit:
            return name
    return "large"


def holm(pvalues: Sequence[float]) -> np.ndarray:
    """Holm-adjusted p-values (NaN stays NaN and does not count towards the family size)."""
    p = np.asarray(pvalues, dtype=float)
    out = np.full(len(p), math.nan)
    valid = np.nonzero(~np.isnan(p))[0]
    m = len(valid)
    order = valid[np.argsort(p[valid], kind="stable")]
    running = 0.0
    for i, idx in enumerate(order):
        running = max(running, min(1.0, (m - i) * p[idx]))
        out[idx] = running
    return out


def test_pair(x: ArrayLike, y: ArrayLike, paired: bool) -> tuple[str, float, float]:
    """(test name, statistic, two-sided p) for ``x`` against ``y``; NaN p below two runs a side."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    name = "Wilcoxon signed-rank" if paired else "Mann-Whitney U"
    if len(x) < 2 or len(y) < 2:
        return name, math.nan, math.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-zero differences: scipy warns, p = 1
        result = wilcoxon(x, y) if paired else mannwhitneyu(x, y, alternative="two-sided")
    p = float(result.pvalue)
    return name, float(result.statistic), 1.0 if math.isnan(p) else p


def _same_start(frame: pd.DataFrame, env: str, a: str, b: str, keys: list[tuple[str, int]]) -> str:
    """Whether the paired runs proposed the same first generation: yes, no or partly."""
    if not keys or "generation" not in frame.columns:
        return "-"
    first = with_run_id(frame[(frame["env"] == env) & (frame["generation"] == 0) & frame["designer"].isin([a, b])])
    bodies = {
        (d, r, int(s)): frozenset(g["body_hash"]) for (d, r, s), g in first.groupby(["designer", "run_id", "seed"])
    }
    same = [bodies.get((a, r, s)) == bodies.get((b, r, s)) and bodies.get((a, r, s)) is not None for r, s in keys]
    return "yes" if all(same) else "no" if not any(same) else "partly"


def _verdict(row: dict, alpha: float, comparisons: int, target_power: float) -> str:
    a, b = row["designer_a"], row["designer_b"]
    primary = row["role"] == "primary"
    if math.isnan(row["p"]):
        return "cannot be tested: fewer than two seeds per designer, so nothing can be concluded"
    p_text = f"p = {row['p']:.2g}, tested alone" if primary else f"Holm p = {row['p_holm']:.2g}"
    effect = f"A12 = {row['a12']:.2f}, {row['magnitude']}"
    if row["significant"]:
        better, worse = (a, b) if row["a12"] > 0.5 else (b, a)
        return f"{better} better than {worse}: significant at {alpha:g} ({p_text}; {effect})"
    text = f"no significant difference at {alpha:g} ({p_text}; {effect})"
    if row["test"].startswith("Wilcoxon"):
        needed = minimum_seeds(alpha / comparisons)
        untied = int(row["untied"])
        if untied < needed:
            rests = f"{untied} non-tied pair{'s' if untied != 1 else ''}" + (
                f" of {row['pairs']}" if untied != row["pairs"] else ""
            )
            after = "" if primary else " after correction"
            text += f"; {rests} cannot give a significant result{after} (at least {needed} needed)"
    if row["seeds_for_power"] is not None:
        text += f"; ~{row['seeds_for_power']} seeds would detect an effect this size {target_power:.0%} of the time"
    return text


def _compare(runs: pd.DataFrame, a: str, b: str, pairing: str) -> dict:
    """The test of ``a`` against ``b`` on the runs' scores, before any correction."""
    x = runs[runs["designer"] == a].set_index(["run_id", "seed"])["score"].dropna()
    y = runs[runs["designer"] == b].set_index(["run_id", "seed"])["score"].dropna()
    common = x.index.intersection(y.index)
    paired = pairing == "paired" or (pairing == "auto" and len(common) > 0 and len(common) == len(x) == len(y))
    if paired:
        xs, ys = x.loc[common].to_numpy(), y.loc[common].to_numpy()
        difference = float(np.median(xs - ys)) if len(common) else math.nan
    else:
        xs, ys = x.to_numpy(), y.to_numpy()
        difference = float(np.median(xs) - np.median(ys)) if len(xs) and len(ys) else math.nan
    test, statistic, p = test_pair(xs, ys, paired)
    effect = a12(xs, ys)
    return {
        "designer_a": a, "designer_b": b, "n_a": len(x), "n_b": len(y), "pairs": len(common) if paired else 0,
        "untied": int(np.sum(xs != ys)) if paired else 0, "test": test, "common": list(common) if paired else [],
        "median_a": float(np.median(xs)) if len(xs) else math.nan,
        "median_b": float(np.median(ys)) if len(ys) else math.nan,
        "difference": difference, "statistic": statistic, "p": p, "a12": effect,
        "magnitude": magnitude(effect) if not math.isnan(p) else "-",
    }  # fmt: skip


def pairwise(
    frame: pd.DataFrame,
    metric: str = "best_reward",
    *,
    alpha: float = ALPHA,
    pairing: str = "auto",
    target_power: float = POWER,
    primary: Primary | None = None,
    reevaluations: pd.DataFrame | None = None,
) -> pd.DataFrame:
    """Every pair of designers of every environment: test, p, Holm-corrected p, A12 and a verdict.

    ``designer_a`` comes before ``designer_b`` in the table; ``difference`` and ``a12`` are A
    against B (A12 > 0.5: A's runs tend to score higher; every metric is higher-is-better).
    ``seeds_for_power`` (for pairs not found significant) is how many paired seeds would detect
    the observed A12 with ``target_power`` at the corrected level (see :mod:`.power`).

    With ``primary``, its pair comes first (``role`` primary), tested alone on its own metric at its own
    level; the other pairs (``role`` exploratory) are corrected together with Holm's method.
    ``metric`` ``auto`` (and the primary's ``auto``) is the re-evaluated best where ``reevaluations``
    has rows, else the best reward.
    """
    if pairing not in PAIRINGS:
        raise ConfigError(f"unknown pairing {pairing!r}; choose one of {', '.join(PAIRINGS)}")
    if not 0.0 < alpha < 1.0:
        raise ConfigError(f"the significance level must be between 0 and 1, got {alpha}")
    metric = resolve_metric(metric, reevaluations)
    scores = run_scores(frame, metric, reevaluations)
    chosen = None if primary is None else resolve_metric(primary.metric, reevaluations)
    primary_scores = None if primary is None else run_scores(frame, chosen or metric, reevaluations)
    rows = []
    for env, runs in scores.groupby("env", sort=False):
        designers = list(pd.unique(runs["designer"]))
        first = primary is not None and (primary.env or env) == env and {primary.a, primary.b} <= set(designers)
        family = []
        for a, b in combinations(designers, 2):
            if first and {a, b} == {primary.a, primary.b}:  # type: ignore[union-attr]
                continue
            family.append({"env": env, "metric": metric, "role": "exploratory", **_compare(runs, a, b, pairing)})
        corrected = holm([r["p"] for r in family])
        comparisons = int(np.sum(~np.isnan(corrected)))
        for row, p_holm in zip(family, corrected):
            row["p_holm"] = p_holm
            _conclude(row, alpha, max(1, comparisons), target_power)
        if first:
            assert primary is not None and primary_scores is not None
            mine = primary_scores[primary_scores["env"] == env]
            row = {"env": env, "metric": chosen, "role": "primary", **_compare(mine, primary.a, primary.b, pairing)}
            row["p_holm"] = row["p"]
            _conclude(row, primary.alpha, 1, target_power)
            family.insert(0, row)
        for row in family:
            row["same_start"] = _same_start(frame, env, row["designer_a"], row["designer_b"], row.pop("common"))
        rows += family
    table = pd.DataFrame(rows, columns=COLUMNS)
    return table.astype({"seeds_for_power": "Int64"})


def _conclude(row: dict, alpha: float, comparisons: int, target_power: float) -> None:
    """Significance, the seeds a not significant pair would need, and the verdict, at ``alpha`` over
    ``comparisons`` (the primary comparison: 1)."""
    row["significant"] = bool(row["p_holm"] < alpha)
    needs_power = not math.isnan(row["p"]) and not row["significant"]
    row["seeds_for_power"] = (
        seeds_needed(row["a12"], alpha=alpha, target_power=target_power, comparisons=comparisons)
        if needs_power
        else None
    )
    row["verdict"] = _verdict(row, alpha, comparisons, target_power)
