"""The report's statistics sections: significance in words, fixed target, fixed budget, aggregate.

:func:`statistics_sections` turns a run table into report sections (text, tables, figures),
the CSV tables behind them and the definitions of every number, using :mod:`.pairwise`,
:mod:`.runtimes`, :mod:`.power` and :mod:`.aggregate`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import pandas as pd

from ..experiment.config import Primary
from ..names import file_name
from ..stats.core import CONFIDENCE
from ..stats.power import ALPHA, POWER, REFERENCE_EFFECTS, minimum_seeds, seeds_needed
from . import plots, stat_plots
from .aggregate import PROFILE_POINTS, aggregate_scores, normalisation_words, normalised_scores
from .content import Figure, Section, Table
from .pairwise import pairwise
from .runtimes import ECDF_TARGETS, METRIC_NAMES, fixed_budget, fixed_target, resolve_metric, runtime_ecdf
from .tables import NOT_REACHED, number, with_interval


@dataclass
class StatisticsPages:
    sections: list[Section]
    tables: dict[str, tuple[pd.DataFrame, str]] = field(default_factory=dict)
    definitions: list[tuple[str, str]] = field(default_factory=list)


def statistics_sections(
    frame: pd.DataFrame,
    *,
    optima: Mapping[str, float] | None = None,
    confidence: float = CONFIDENCE,
    alpha: float = ALPHA,
    primary: Primary | None = None,
    named_before: bool = True,
    reevaluations: pd.DataFrame | None = None,
) -> StatisticsPages:
    """Sections for the report of ``frame`` (one or several environments).

    Tests and aggregates score each run by its re-evaluated best where ``reevaluations`` has rows
    (:mod:`.reevaluated`), else by its best reward; ``primary`` is the comparison tested alone, ``named_before``
    whether the experiment named it before the run (else it was named for the report).
    """
    designers = [str(d) for d in pd.unique(frame["designer"])]
    envs = [str(e) for e in pd.unique(frame["env"])]
    pages = StatisticsPages([], definitions=definitions(confidence, alpha))
    metric = resolve_metric("auto", reevaluations)

    tests = pairwise(frame, metric, alpha=alpha, primary=primary, reevaluations=reevaluations)
    pages.tables["pairwise.csv"] = (
        tests,
        f"every pair of designers per environment: role (primary or exploratory), test, pairs and non-tied pairs, "
        f"p, Holm-corrected p, A12, verdict ({METRIC_NAMES[metric]})",
    )
    pages.sections.append(_significance(frame, tests, envs, alpha, primary, metric, named_before))

    ert = fixed_target(frame, optima=optima, confidence=confidence)
    ecdf = runtime_ecdf(frame, optima=optima)
    pages.tables["fixed_target.csv"] = (
        ert,
        "ERT, success rate and median runtime per environment, designer and target",
    )
    pages.tables["runtime_ecdf.csv"] = (ecdf, "share of (run, target) pairs reached after each evaluation count")
    pages.sections.append(
        Section(
            "Fixed target: evaluations to reach a reward",
            [
                Figure(
                    f"ecdf_{_slug(env)}.png",
                    f"Runtime ECDF: {env}",
                    f"Share of (run, target) pairs reached after n evaluations, over {ECDF_TARGETS} targets evenly "
                    f"spaced as in the ERT table.",
                    plots.png(stat_plots.ecdf_figure(ecdf, designers, env, ECDF_TARGETS)),
                )
                for env in envs
            ],
            "Expected running time (ERT, COCO's definition): evaluations spent by all runs, an unsuccessful run "
            "counting all of its evaluations, divided by the successful runs. Cells: ERT [bootstrap CI] (runs that "
            "reached the target / runs).",
            tables=[_ert_table(ert, env, designers, confidence) for env in envs],
        )
    )

    budget = fixed_budget(frame, optima=optima, confidence=confidence)
    pages.tables["fixed_budget.csv"] = (
        budget,
        "best-so-far reward of every designer at chosen budgets: median, its order-statistic interval and that "
        "interval's coverage, quartiles, mean",
    )
    pages.sections.append(
        Section(
            "Fixed budget: reward after a number of evaluations",
            [],
            f"Best-so-far reward after the given number of evaluations: median over seeds [order-statistic interval "
            f"of at least {confidence:.0%} where the seeds allow, else the seeds' range with its coverage].",
            tables=[_budget_table(budget, env, designers, confidence) for env in envs],
        )
    )
    if len(envs) > 1:
        pages.sections.append(_aggregate(frame, designers, envs, optima, confidence, pages.tables, metric,
                                         reevaluations))  # fmt: skip
    return pages


def _slug(name: str) -> str:
    return file_name(name, "A-Za-z0-9_.-")


# -- significance ---------------------------------------------------------------------------------
def _significance(
    frame: pd.DataFrame,
    tests: pd.DataFrame,
    envs: list[str],
    alpha: float,
    primary: Primary | None,
    metric: str,
    named_before: bool,
) -> Section:
    seeds = frame.groupby(["env", "designer"])["seed"].nunique()
    exploratory = tests[tests["role"] == "exploratory"]
    comparisons = max(1, int(exploratory.groupby("env").size().max())) if len(exploratory) else 1
    paragraphs, tables = [], []
    if primary is not None:
        paragraphs.append(_primary_words(primary, tests, seeds, named_before))
    for env in envs:
        mine = tests[tests["env"] == env]
        fewest = int(seeds.loc[env].min())
        where = f" on {env}" if len(envs) > 1 else ""
        if len(mine) == 0:
            paragraphs.append(f"Only one designer ran{where}: there is nothing to compare.")
            continue
        others = mine[mine["role"] == "exploratory"]
        if fewest < 2:
            paragraphs.append(_one_seed_words(where, max(1, len(others)), alpha))
        elif len(others):
            paragraphs.append(_verdict_words(others, where, alpha, fewest, primary is not None))
        tables.append(_pairwise_table(mine, env if len(envs) > 1 else "", alpha, metric))
    tables.append(_power_table(alpha, comparisons))
    when = "named in the experiment before the run" if named_before else "named for this report, after the run"
    named = (
        f"The primary comparison ({primary.a} against {primary.b}, {when}) is tested alone at its own level; "
        f"every other pair is exploratory: their p-values are corrected together for the number of pairs with Holm's "
        f"method. "
        if primary is not None
        else "No primary comparison was named before the run, so every pair is exploratory: p-values are corrected "
        "for the number of pairs with Holm's method. "
    )
    intro = (
        f"Per environment, pairs of designers are tested on the {METRIC_NAMES[metric]} of each run: Wilcoxon's "
        f"signed-rank test on the per-seed differences when the runs are paired (same run, same seed), resting on "
        f"the pairs whose two runs differ (non-tied), the Mann-Whitney U test otherwise; the effect size is "
        f"Vargha-Delaney's A12. " + named + f"Significance level {alpha:g}."
    )
    return Section("Which differences are significant", [], intro, paragraphs=paragraphs, tables=tables)


def _primary_words(primary: Primary, tests: pd.DataFrame, seeds: pd.Series, named_before: bool) -> str:
    rows = tests[tests["role"] == "primary"]
    needed = seeds_needed(primary.effect, alpha=primary.alpha, target_power=primary.power)
    plan = (
        f"Primary comparison: {primary.a} against {primary.b}, at {primary.alpha:g}, smallest effect of interest "
        f"A12 = {primary.effect:g}, for which the power analysis asks {needed or 'more than 1000'} seeds "
        f"({primary.power:.0%} power)"
    )
    if rows.empty:
        return plan + ": not tested (one of the two designers has no runs in this table)."
    r = rows.iloc[0]
    has = r.pairs or min(r.n_a, r.n_b)
    fewer = "planned" if named_before else "that"
    short = f"; this run has {has}, fewer than {fewer}" if needed and has < needed else ""
    return f"{plan}{short}. On the {METRIC_NAMES[r.metric]}: {r.verdict}."


def _one_seed_words(where: str, pairs: int, alpha: float) -> str:
    level = alpha / pairs
    large = seeds_needed(0.71, alpha=alpha, comparisons=pairs)
    return (
        f"Nothing can be concluded from this run about which designer is better{where}: it has one seed per designer, "
        f"and one run per "
        f"designer cannot tell a designer's merit from the luck of its seed, so no test is possible and none of the "
        f"differences above "
        f"is significant. A paired test needs at least {minimum_seeds(level)} seeds before any p-value can fall below "
        f"{alpha:g} after "
        f"Holm's correction over the {pairs} pair(s); to detect a large effect (A12 = 0.71) 80% of the time it needs "
        f"about {large} seeds "
        f"(table below; power estimate of the exact signed-rank test, see 'How the numbers are computed'). Repeat the "
        f"comparison with "
        f"e.g. --seeds 0..{max(large or 10, 10) - 1}."
    )


def _verdict_words(tests: pd.DataFrame, where: str, alpha: float, seeds: int, exploratory: bool) -> str:
    def pair(r) -> str:
        return f"{r.designer_a} vs {r.designer_b} (Holm p = {r.p_holm:.2g}, A12 = {r.a12:.2f})"

    significant = [r for r in tests.itertuples() if r.significant]
    other = [r for r in tests.itertuples() if not r.significant]
    what = "exploratory pair(s)" if exploratory else "pair(s)"
    parts = [
        f"With {seeds} seeds per designer{where}, at level {alpha:g} after Holm's correction over {len(tests)} {what}:"
    ]
    if significant:
        wins = [
            f"{(r.designer_a if r.a12 > 0.5 else r.designer_b)} beats "
            f"{(r.designer_b if r.a12 > 0.5 else r.designer_a)} (Holm p = {r.p_holm:.2g}, A12 = {r.a12:.2f}, "
            f"{r.magnitude})"
            for r in significant
        ]
        parts.append("significant: " + "; ".join(wins) + ".")
    if other:
        parts.append("not significant: " + "; ".join(pair(r) for r in other) + ".")
    fewest = minimum_seeds(alpha / max(1, len(tests)))
    if seeds < fewest:
        parts.append(f"No outcome of {seeds} seeds could have been significant here: Holm's first step tests at "
                     f"{alpha:g}/{len(tests)}, which needs at least {fewest} non-tied pairs.")  # fmt: skip
    return " ".join(parts)


def _test_cell(r) -> str:
    if not r.pairs:
        return f"{r.test} ({r.n_a} vs {r.n_b} runs)"
    pairs = f"{r.pairs} pair{'s' if r.pairs > 1 else ''}"
    return f"{r.test} ({pairs}" + (f", {r.untied} non-tied)" if r.untied != r.pairs else ", none tied)")


def _pairwise_table(tests: pd.DataFrame, env: str, alpha: float, metric: str) -> Table:
    headers = ["A", "B", "role", "test", "median A - B", "p", "Holm p", "A12", "verdict"]
    rows = [
        [
            r.designer_a,
            r.designer_b,
            r.role + ("" if r.metric == metric else f" ({METRIC_NAMES[r.metric]})"),
            _test_cell(r),
            number(r.difference),
            number(r.p, 2),
            "-" if r.role == "primary" else number(r.p_holm, 2),
            f"{r.a12:.2f}" + (f" ({r.magnitude})" if r.magnitude != "-" else ""),
            r.verdict,
        ]
        for r in tests.itertuples()
    ]
    title = f"Pairwise comparisons{f' on {env}' if env else ''}: {METRIC_NAMES[metric]}"
    return Table(
        title,
        headers,
        rows,
        f"Two-sided tests. The primary comparison (if any) is tested alone at its level; exploratory pairs are "
        f"significant when Holm p < {alpha:g} (Holm's correction over the exploratory pairs of this environment). "
        f"A12 > 0.5: A tends to score higher.",
    )


def _power_table(alpha: float, comparisons: int) -> Table:
    rows = []
    for a12, name in REFERENCE_EFFECTS:
        needed = seeds_needed(a12, alpha=alpha, comparisons=comparisons)
        rows.append([name, f"{a12:.2f}", str(needed) if needed is not None else "more than 1000"])
    caption = (
        f"Seeds (pairs of runs) for the paired signed-rank test to find an effect of that size {POWER:.0%} of the "
        f"time at {alpha:g} "
        f"with Holm's correction over {comparisons} pair(s). Assumes normal per-seed differences and no help from "
        f"pairing "
        f"(conservative when designers share their first generation)."
    )
    return Table("Seeds needed for a given effect", ["effect", "A12", "seeds needed"], rows, caption)


# -- fixed target / fixed budget -------------------------------------------------------------------
def _ert_table(ert: pd.DataFrame, env: str, designers: list[str], confidence: float) -> Table:
    mine = ert[ert["env"] == env]
    present = [d for d in designers if d in set(mine["designer"])]
    rows = []
    for target, g in mine.groupby("target", sort=True):
        cells = {
            r.designer: f"{_ert_cell(r.ert, r.ert_ci_low, r.ert_ci_high)} ({r.successes}/{r.runs})"
            for r in g.itertuples()
        }
        rows.append([number(target)] + [cells.get(d, "-") for d in present])
    return Table(
        f"ERT on {env}",
        ["target reward"] + present,
        rows,
        f"'not reached': no run got there (ERT infinite). Interval: {confidence:.0%} bootstrap over runs; an upper "
        f"bound 'inf' means some resamples held no run that got there.",
    )


def _ert_cell(ert: float, low: float, high: float) -> str:
    """ERT [interval], with infinite bounds written as such (an infinite ERT alone reads 'not reached')."""
    if math.isinf(ert):
        return number(ert)
    text = with_interval(ert, low, high, digits=5)
    return text.replace(NOT_REACHED, "inf")


def _budget_table(budget: pd.DataFrame, env: str, designers: list[str], confidence: float) -> Table:
    mine = budget[budget["env"] == env]
    present = [d for d in designers if d in set(mine["designer"])]
    rows = []
    for b, g in mine.groupby("budget", sort=True):
        cells = {
            r.designer: with_interval(r.median, r.ci_low, r.ci_high, level=r.ci_level, confidence=confidence)
            + (f" ({r.runs} runs)" if r.runs < g["runs"].max() else "")
            for r in g.itertuples()
        }
        rows.append([str(b)] + [cells.get(d, "-") for d in present])
    return Table(f"Best-so-far reward at fixed budgets on {env}", ["evaluations"] + present, rows)


# -- aggregate ---------------------------------------------------------------------------------------
def _aggregate(
    frame: pd.DataFrame,
    designers: list[str],
    envs: list[str],
    optima: Mapping[str, float] | None,
    confidence: float,
    tables: dict[str, tuple[pd.DataFrame, str]],
    metric: str,
    reevaluations: pd.DataFrame | None,
) -> Section:
    scores = normalised_scores(frame, metric, optima=optima, reevaluations=reevaluations)
    iqm, profiles, poi = aggregate_scores(scores, confidence=confidence)
    tables["normalised_scores.csv"] = (
        scores,
        f"{METRIC_NAMES[metric]} of every run, its score normalised per environment, and the scores that count 0 and 1",
    )
    tables["aggregate_iqm.csv"] = (
        iqm,
        "IQM of normalised scores over environments with its stratified-bootstrap interval",
    )
    tables["performance_profiles.csv"] = (profiles, "share of runs above each normalised score, with its interval")
    tables["improvement_probability.csv"] = (
        poi,
        "probability that a run of X beats a run of Y on the same environment, averaged over environments",
    )
    left_out = [d for d in designers if d not in set(iqm["designer"])]
    paragraphs = [f"Left out (not run on every environment): {', '.join(left_out)}."] if left_out else []
    iqm_table = Table(
        "Interquartile mean of normalised best rewards",
        ["designer", "environments", "runs", f"IQM [{confidence:.0%} CI]"],
        [
            [r.designer, str(r.envs), str(r.runs), with_interval(r.iqm, r.ci_low, r.ci_high, digits=3)]
            for r in iqm.itertuples()
        ],
    )
    poi_table = Table(
        "Probability of improvement",
        ["X", "Y", f"P(X > Y) [{confidence:.0%} CI]"],
        [
            [r.designer_x, r.designer_y, with_interval(r.probability, r.ci_low, r.ci_high, digits=3)]
            for r in poi.itertuples()
        ],
        "Probability that a run of X scores higher than a run of Y on the same environment (ties count half), "
        "averaged over environments.",
    )
    shown = [d for d in designers if d in set(iqm["designer"])]
    figures = [
        Figure(
            "aggregate_iqm.png",
            "IQM over environments",
            "Interquartile mean of the normalised best rewards of all runs on all environments; bar = "
            "stratified-bootstrap CI.",
            plots.png(stat_plots.iqm_figure(iqm, shown, confidence)),
        ),
        Figure(
            "performance_profiles.png",
            "Performance profiles",
            f"Share of runs (averaged over environments) whose normalised best reward exceeds tau, at "
            f"{PROFILE_POINTS} values of tau.",
            plots.png(stat_plots.profile_figure(profiles, shown, confidence)),
        ),
    ]
    intro = (
        f"Over the {len(envs)} environments ({', '.join(envs)}), with rliable's estimators. Each run's "
        f"{METRIC_NAMES[metric]} is normalised per environment as rliable normalises Atari scores: 0 = the median "
        f"of the random designer's runs there (where it ran; else the lowest run), 1 = the environment's optimum "
        f"(where known; else the best run): {normalisation_words(scores)}. Intervals resample runs within each "
        f"environment (stratified bootstrap)."
    )
    return Section("Aggregate over environments", figures, intro, paragraphs=paragraphs, tables=[iqm_table, poi_table])


def definitions(confidence: float, alpha: float) -> list[tuple[str, str]]:
    """What the statistics sections' numbers mean (added to the report's definitions)."""
    return [
        (
            "Primary and exploratory",
            "an experiment may name one comparison before it runs (its primary comparison: two designers, a metric, a "
            "level and the smallest effect of interest that set its seeds); it is tested alone at its level. Every "
            "other pair is exploratory and Holm-corrected: read those as leads for the next experiment, not findings.",
        ),
        (
            "Non-tied pairs",
            "a paired test rests only on the seeds where the two runs differ (two designers that found the same best "
            "body under one seed tie there and drop out); with n of them the exact signed-rank test's smallest "
            "two-sided p is 2/2^n, so 5 cannot go below 0.0625.",
        ),
        (
            "Paired and unpaired tests",
            "two designers' runs are paired when they come from the same run with the same seed (same seed: same "
            "evaluation noise; ga, gda and random even share their first generation). Paired: Wilcoxon signed-rank "
            "test on the per-seed differences; otherwise Mann-Whitney U. Two-sided.",
        ),
        (
            "Holm p",
            f"p-values corrected with Holm's step-down method over all pairs of designers of an environment: the "
            f"chance that any 'significant' in that table is false stays below {alpha:g}.",
        ),
        (
            "A12",
            "Vargha-Delaney effect size: probability that a run of A beats a run of B (ties count half); 0.5 = no "
            "effect; |A12 - 0.5| below 0.06 negligible, 0.14 small, 0.21 medium, above large.",
        ),
        (
            "Seeds needed (power)",
            f"smallest number of seeds with which the exact two-sided signed-rank test at {alpha:g} divided by the "
            f"number of pairs (Holm's first step) rejects {POWER:.0%} of the time, when the per-seed differences are "
            f"normal with standardised mean Phi^-1(A12) (the A12 of two independent normal runs); simulated with a "
            f"fixed seed. Pairing that makes runs alike only lowers the number.",
        ),
        (
            "ERT",
            "expected running time (COCO): the evaluations of all runs, a run that never reached the target counting "
            "all of its evaluations, divided by the number of runs that reached it; infinite ('not reached') when "
            "none did. Interval: bootstrap over runs.",
        ),
        (
            "Targets",
            "default targets of the ERT table: evenly spaced between the median over runs of their first generation's "
            "best reward and the best reward any run found (rounded to 3 digits), plus the environment's optimum when "
            "known and not reached; the ECDF uses 50 such targets.",
        ),
        (
            "Runtime ECDF",
            "share of (run, target) pairs whose target the run had reached after n evaluations (COCO's and "
            "IOHprofiler's fixed-target view aggregated over targets).",
        ),
        (
            "Fixed budget",
            f"each run's best-so-far reward after n evaluations; median over seeds with its order-statistic interval "
            f"(coverage at least {confidence:.0%}, or stated where the seeds are too few; a run that stopped at the "
            f"optimum keeps it).",
        ),
        (
            "Aggregate (several environments)",
            "rliable's interquartile mean (mean of the middle 50% of all normalised run scores), performance profiles "
            "(share of runs above a normalised score) and probability of improvement, with stratified-bootstrap "
            "intervals (runs resampled within each environment). Normalised score: (score - random's median) / "
            "(optimum - random's median) per environment, the lowest run standing in for random where it did not "
            "run and the best run for an unknown optimum.",
        ),
    ]
