"""Build the report of a run directory from its tidy tables and write it next to them.

``write_report(run_dir)`` reads ``run.json`` and ``evaluations.parquet`` only, and writes into
``<run>/report/`` (or ``out``):

* ``report.html``: everything in one self-contained file; ``summary.md``: table and figures;
* figures: ``best_so_far.png``, ``rewards_per_generation.png``, ``best_bodies.png``,
  ``bodies_per_generation_<designer>.png``, ``diversity.png``, ``novelty.png`` and, for
  environments that can show a body acting, ``animation_<designer>.gif``;
* tables: ``summary.csv``, ``runs.csv``, ``generations.csv``, ``best_so_far.csv``,
  ``diversity.csv``.

A run that is still in progress, failed or was interrupted is reported as far as it got, with
a note saying so; a directory that is not a run, or whose files cannot be read, raises a
:class:`~gdabench.errors.RunDirectoryError` with one line.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Mapping, cast

import numpy as np
import pandas as pd

from ..body import Body
from ..errors import ConfigError, GdabenchError, RunDirectoryError
from ..experiment.config import Experiment, Primary
from ..experiment.plan import Plan
from ..names import file_name
from ..plugins import Registry, registry
from ..results import RunDirectory, is_file, load_reevaluations
from ..stats.core import (
    CONFIDENCE,
    best_so_far_curve,
    fewest_for,
    generation_rewards,
    median_band,
    order_statistic_ranks,
)
from ..stats.summary import failure_counts, per_run, summarize, thresholds
from ..statuses import COUNTED, OK
from . import plots
from .animation import animate
from .bodies import bodies_figure
from .content import Figure, Report, Section, Table
from .diversity import NEAR_COPY, SURVIVORS, diversity
from .html import render_html
from .markdown import render_markdown
from .reevaluated import section as reevaluated_section, which_bodies
from .staging import staged_folder
from .stat_pages import statistics_sections
from .tables import summary_cells

#: columns the report needs; everything else in the table is optional
BEST_BODIES = 8
#: a designer's best-so-far curve: evaluations, median over seeds, and its band (low, high)
Curve = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
GENERATION_COLUMNS = 10
REPORT_DIR = "report"


def load_run(run_dir: str | Path) -> tuple[RunDirectory, dict[str, Any], pd.DataFrame, list[str]]:
    """Open a run directory and its evaluations table; notes say what is incomplete about it."""
    run = RunDirectory.open(run_dir)
    meta = run.meta
    status = meta.get("status")
    frame = run.load_evaluations()  # finished runs and the generations of unfinished ones
    if frame.empty:
        raise RunDirectoryError(f"{run.path} has no evaluations yet (run status {status!r}): nothing to report")
    notes = []
    if status != "complete":
        counted = int(frame["status"].isin(COUNTED).sum())
        why = {
            "running": "it is still in progress (or was killed before it could say so)",
            "failed": f"it failed: {meta.get('error') or 'no error recorded'}",
            "interrupted": "it was interrupted",
        }.get(str(status), "its state is unknown")
        notes.append(f"run status is {status!r}: {why}; this report covers the {counted} evaluations written so far")
    return run, meta, frame, notes


def _experiment(meta: dict[str, Any], notes: list[str]) -> Experiment | None:
    try:
        return Experiment.from_json(meta["config"])
    except (KeyError, TypeError, ValueError, GdabenchError):
        notes.append("run.json has no readable configuration; budget and seeds are taken from the table")
        return None


def _budget(experiment: Experiment | None, frame: pd.DataFrame) -> int:
    if experiment is not None:
        return int(experiment.budget)
    if "budget" in frame.columns and frame["budget"].notna().any():
        return int(frame["budget"].max())
    return int(frame["n_evals"].max())


def _coverage_words(frame: pd.DataFrame, confidence: float) -> str:
    """The coverage of the median intervals of a table's designers, in words (from their numbers of seeds)."""
    seeds = sorted(set(frame.groupby("designer")["seed"].nunique()))
    levels = sorted({order_statistic_ranks(int(n), confidence)[1] for n in seeds})
    text = " to ".join(f"{levels[i]:.2%}" for i in sorted({0, len(levels) - 1}))
    if levels[0] < confidence:
        return f"coverage {text}: too few seeds for {confidence:.0%}"
    return f"coverage {text}"


def _spread(generations: pd.DataFrame) -> str:
    """How the reward plot draws the spread over seeds: one generation is points with error bars, not a band."""
    return "error bars" if generations["generation"].nunique() == 1 else "band"


def _slug(label: str, taken: set[str]) -> str:
    base = file_name(label).strip("_") or "designer"
    slug, i = base, 1
    while slug in taken:
        i += 1
        slug = f"{base}-{i}"
    taken.add(slug)
    return slug


def _facts(
    run: RunDirectory, meta: dict[str, Any], experiment: Experiment | None, threshold: str, primary: Primary | None
) -> list[tuple[str, str]]:
    facts = [("run", f"{meta.get('run_id', '?')} ({run.path})"), ("status", str(meta.get("status")))]
    if meta.get("command"):
        facts.append(("command", " ".join(map(str, meta["command"]))))
    if experiment is not None:

        def label(choice) -> str:
            params = f" {json.dumps(dict(choice.params), sort_keys=True)}" if choice.params else ""
            return f"{choice.label or choice.name}{params}"

        facts += [
            ("designers", ", ".join(d.label or d.name for d in experiment.designers)),
            (
                "environment",
                ", ".join(map(label, experiment.envs))
                + (f" / controller {label(experiment.controller)}" if experiment.controller else ""),
            ),
            (
                "budget",
                f"{experiment.budget} evaluations per run, population {experiment.population}, shape "
                f"{experiment.shape[0]}x{experiment.shape[1]}",
            ),
            ("seeds", ", ".join(map(str, experiment.seeds))),
        ]
    done = meta.get("reevaluated") or {}
    if done:
        facts.append(("re-evaluation", f"the {which_bodies(int(done.get('top', 0)))} of each trial, "
                                       f"{done.get('seeds')} further training seeds each "
                                       f"({done.get('wall_seconds', 0):.0f} s)"))  # fmt: skip
    if primary is not None:
        when = "named before the run" if experiment is not None and experiment.primary == primary else (
            "named for this report, after the run")  # fmt: skip
        metric = primary.metric if primary.metric != "auto" else ("reevaluated_best" if done else "best_reward")
        facts.append(("primary comparison", f"{primary.a} against {primary.b} on {metric}, at "
                                            f"{primary.alpha:g}, smallest effect of interest A12 = {primary.effect:g} "
                                            f"({when})"))  # fmt: skip
    facts.append(("threshold", threshold))
    for key in ("created", "finished"):
        if meta.get(key):
            facts.append((key, str(meta[key])))
    parts = meta.get("wall_seconds_by_part") or []
    if any(p is not None for p in parts):  # the run's own wall time, summed over the first run and its resumes
        text = f"{meta.get('wall_seconds', 0.0):.1f} s"
        if len(parts) > 1:
            text += f" over the first run and {len(parts) - 1} resume{'s' if len(parts) > 2 else ''}"
        untimed = sum(p is None for p in parts)
        if untimed:
            text += f" ({untimed} of the {len(parts)} parts recorded no time: killed with kill -9, or still going)"
        facts.append(("wall time", text))
    versions = meta.get("versions") or {}
    if versions:
        core = ", ".join(f"{k} {v}" for k, v in versions.items() if k != "plugins" and v)
        plugins = ", ".join(f"{k} {v}" for k, v in (versions.get("plugins") or {}).items())
        facts.append(("versions", core + (f"; plugins: {plugins}" if plugins else "")))
    platform = meta.get("platform") or {}
    if platform:
        facts.append(("platform", ", ".join(f"{k} {v}" for k, v in platform.items())))
    return facts


def _incomplete_runs(frame: pd.DataFrame, experiment: Experiment | None, budget: int) -> list[str]:
    notes = []
    counted = frame[frame["status"].isin(COUNTED)].groupby(["designer", "seed"], sort=False).size()
    for (designer, seed), n in counted.items():
        if n < budget:
            notes.append(f"{designer} seed {seed}: {n} of {budget} evaluations")
    if experiment is not None:
        present = set(counted.index)
        for seed in experiment.seeds:
            for d in experiment.designers:
                if (d.label or d.name, seed) not in present:
                    notes.append(f"{d.label or d.name} seed {seed}: not started")
    return notes


def _best_bodies(frame: pd.DataFrame, designer: str, k: int) -> pd.DataFrame:
    """The ``k`` best distinct bodies a designer found over all seeds (ties: lower seed, sooner)."""
    ok = frame[(frame["designer"] == designer) & (frame["status"] == OK)]
    ranked = ok.sort_values(["reward", "seed", "n_evals"], ascending=[False, True, True], kind="stable")
    return ranked.drop_duplicates("body_hash").head(k)


def _representative_seed(runs: pd.DataFrame, designer: str) -> int:
    """The seed whose best reward is the (lower) median of the designer's runs."""
    mine = runs[runs["designer"] == designer].sort_values(["best_reward", "seed"], kind="stable")
    return int(mine["seed"].iloc[(len(mine) - 1) // 2])


def _generation_bests(frame: pd.DataFrame, designer: str, seed: int) -> list[tuple[int, pd.Series | None]]:
    run = frame[(frame["designer"] == designer) & (frame["seed"] == seed)]
    out = []
    for g in sorted(run["generation"].unique()):
        ok = run[(run["generation"] == g) & (run["status"] == OK)]
        out.append((int(g), ok.loc[ok["reward"].idxmax()] if len(ok) else None))
    return out


def _body(text: str) -> Body | None:
    try:
        return Body.from_text(text)
    except GdabenchError:
        return None


def _threshold(threshold: float | None, meta: dict[str, Any], envs: list[str]) -> tuple[dict[str, float | None], str]:
    """The threshold of each environment, and how the report describes them."""
    if threshold is not None:
        if not math.isfinite(threshold):
            raise ConfigError(f"--threshold must be a finite number, got {threshold}")
        return dict.fromkeys(envs, float(threshold)), f"{threshold:g} (chosen with --threshold)"
    known = thresholds(meta)
    targets = {env: (known.get(env) if isinstance(known, Mapping) else known) for env in envs}
    if len(envs) > 1:
        words = ", ".join(f"{env} {'unknown' if t is None else f'{t:g}'}" for env, t in targets.items())
        return targets, f"each environment's optimum ({words}); pass --threshold to count evaluations to one reward"
    optimum = targets[envs[0]]
    if optimum is not None:
        return targets, f"{float(optimum):g} (the environment's optimum)"
    return targets, "none: the environment has no known optimum; pass --threshold to count evaluations to a reward"


def definitions(confidence: float, survivors: int, near_copy: int) -> list[tuple[str, str]]:
    """What every number of the report means (printed in the HTML and markdown)."""
    ci = f"{confidence:.0%}"
    return [
        (
            "Re-evaluated best",
            "where the run re-evaluated its trials: the trial's best bodies (by their reward in the trial) trained "
            "again under further seeds of their own; the re-evaluated best is the highest of those bodies' means over "
            "the further seeds, the training that selected each body left out. Tests and aggregates then use it "
            "instead of the raw best reward.",
        ),
        (
            "Evaluation noise",
            "the standard deviation of one body's rewards over the further training seeds (ddof 1); pooled over a "
            "designer's bodies in the table.",
        ),
        ("Evaluation", "one evaluated unique valid body; invalid and duplicate proposals use none."),
        (
            "Best reward",
            f"best reward a run found; the table gives the median over seeds and its exact order-statistic interval "
            f"(distribution-free: the l-th lowest and l-th highest seed, l as large as keeps the coverage at least "
            f"{ci}). With fewer than {fewest_for(confidence)} seeds no such interval reaches {ci}: the seeds' range "
            f"is given with its own coverage in brackets after it (5 seeds: 93.75%).",
        ),
        (
            "Evaluations to the threshold",
            "evaluations a run used until its first body scored at least the threshold. Runs that never got there are "
            "censored (counted as +inf, 'not reached'), never dropped: a median that reads 'not reached' means half "
            "the seeds or more did not get there.",
        ),
        (
            "Mean best-so-far",
            "area under the best-so-far curve divided by the number of evaluations (the mean best reward over the "
            "run): higher means good bodies were found sooner.",
        ),
        (
            "Best-so-far band",
            "order-statistic interval of the median over seeds at each evaluation count (as for the best reward; its "
            "coverage is the ci_level column of best_so_far.csv).",
        ),
        (
            "Reward per generation",
            "min / mean / max reward of the bodies evaluated in that generation (duplicates and invalid bodies "
            "excluded); median over seeds with the inter-quartile range.",
        ),
        (
            "Wall time",
            "elapsed time of a run when its last generation was written, carried across resumes; a generation cut "
            "short by a kill is run again and only that second time counts (the machine may have been shared).",
        ),
        (
            "Survivors (diversity)",
            f"the {survivors} best bodies a run had evaluated before the generation (the GDA's and the thesis GA's "
            f"rule, applied to every designer so that they are comparable).",
        ),
        (
            "Proposal categories",
            f"by Hamming distance to the nearest survivor: copy (0), near-copy (1-{near_copy} voxels differ), new "
            f"materials (same occupied voxels as a survivor, other types), novel shape (the rest).",
        ),
        (
            "Representative run",
            "bodies per generation are shown for the seed whose best reward is the median of the designer's seeds.",
        ),
    ]


def _best_so_far(
    frame: pd.DataFrame, designers: list[str], budget: int, confidence: float
) -> tuple[dict[str, Curve], dict[str, int], pd.DataFrame]:
    """Per designer: median best-so-far curve over seeds with its order-statistic band, and as a table."""
    x = np.arange(1, budget + 1)
    curves: dict[str, Curve] = {}
    seeds, parts = {}, []
    for d in designers:
        mine = frame[frame["designer"] == d]
        matrix = np.array([best_so_far_curve(g, budget) for _, g in mine.groupby("seed", sort=True)])
        median, low, high, level = median_band(matrix, confidence=confidence)
        curves[d], seeds[d] = (x, median, low, high), len(matrix)
        runs = (~np.isnan(matrix)).sum(axis=0)
        parts.append(
            pd.DataFrame({"designer": d, "evaluations": x, "median": median, "ci_low": low, "ci_high": high,
                          "ci_level": level, "runs": runs})  # fmt: skip
        )
    return curves, seeds, pd.concat(parts, ignore_index=True)


def _body_figures(
    frame: pd.DataFrame, runs: pd.DataFrame, designers: list[str], slugs: dict[str, str]
) -> tuple[list[Figure], dict[str, tuple[Body, int]]]:
    """The best bodies of each designer, and the best body of every generation of a representative run.

    Also returns each designer's best body and its seed (what an animation shows).
    """
    cells, captions, best_of = [], [], {}
    for d in designers:
        top = _best_bodies(frame, d, BEST_BODIES)
        row = [
            (_body(r["body"]), f"{r['reward']:.4g}\nseed {r['seed']}, #{r['n_evals']}", int(r["seed"]))
            for _, r in top.iterrows()
        ]
        row = [c for c in row if c[0] is not None]
        if row:
            best_of[d] = (cast(Body, row[0][0]), row[0][2])  # None was filtered out above
        row += [(None, "", -1)] * (BEST_BODIES - len(row))
        cells += [c[0] for c in row]
        captions += [c[1] for c in row]
    figures = [
        Figure(
            "best_bodies.png",
            "Best bodies per designer",
            f"The {BEST_BODIES} best distinct bodies each designer found over all seeds: reward (seed, evaluation "
            f"number).",
            plots.png(bodies_figure(cells, captions, ncols=BEST_BODIES, row_labels=designers)),
        )
    ]
    for d in designers:
        seed = _representative_seed(runs, d)
        bests = _generation_bests(frame, d, seed)
        fig = bodies_figure(
            [_body(r["body"]) if r is not None else None for _, r in bests],
            [f"gen {g}: {r['reward']:.4g}" if r is not None else f"gen {g}: -" for g, r in bests],
            ncols=GENERATION_COLUMNS,
            title=f"{d}, seed {seed}: best body of each generation",
        )
        figures.append(
            Figure(
                f"bodies_per_generation_{slugs[d]}.png",
                f"Best body per generation: {d}",
                f"Representative run (seed {seed}, the median of the designer's best rewards), as in the thesis's "
                f"figures 5.8-5.11.",
                plots.png(fig),
            )
        )
    return figures, best_of


def write_report(
    run_dir: str | Path,
    out: str | Path | None = None,
    *,
    threshold: float | None = None,
    survivors: int = SURVIVORS,
    near_copy: int = NEAR_COPY,
    animations: bool = True,
    confidence: float = CONFIDENCE,
    primary: Primary | None = None,
    reg: Registry | None = None,
) -> Report:
    """Compute and write the report of ``run_dir``; returns what was written.

    ``primary`` names the primary comparison when the run's experiment does not (the report then says it
    was named after the run); the run's re-evaluations (``reevaluations.parquet``) are used where present.
    """
    if survivors < 1:
        raise ConfigError(f"--survivors must be at least 1, got {survivors}")
    if near_copy < 0:
        raise ConfigError(f"--near-copy must be at least 0, got {near_copy}")
    if not 0.0 < confidence < 1.0:
        raise ConfigError(f"confidence must be between 0 and 1, got {confidence}")
    run, meta, frame, notes = load_run(run_dir)
    out = Path(out) if out is not None else run.path / REPORT_DIR
    experiment = _experiment(meta, notes)
    budget = _budget(experiment, frame)
    envs = [str(e) for e in pd.unique(frame["env"])]
    target, target_text = _threshold(threshold, meta, envs)
    notes += _incomplete_runs(frame, experiment, budget)
    notes += [f"{row.designer} on {row.env}: {row.line}" for row in failure_counts(frame).itertuples()]
    designers = list(pd.unique(frame["designer"]))
    taken: set[str] = set()
    slugs = {d: _slug(d, taken) for d in designers}

    reevaluations = load_reevaluations(run.path)
    summary = summarize(frame, target, confidence=confidence, reevaluations=reevaluations)
    runs = per_run(frame, target)
    headers, rows = summary_cells(summary, confidence)
    generations = generation_rewards(frame)
    tables: dict[str, tuple[pd.DataFrame, str]] = {
        "summary.csv": (summary, "the per-designer table with all its columns"),
        "runs.csv": (
            runs,
            "one row per designer and seed: best reward, evaluations, evaluations to the threshold, mean best-so-far, "
            "wall time",
        ),
        "generations.csv": (generations, "reward per generation (min, mean, max) of every run"),
    }

    performance, curve_tables = [], []
    for env in envs:
        part = frame[frame["env"] == env]
        mine = [d for d in designers if d in set(part["designer"])]
        curves, seeds, curve_table = _best_so_far(part, mine, budget, confidence)
        curve_tables.append(curve_table.assign(env=env))
        suffix, where = ("", "") if len(envs) == 1 else (f"_{_slug(env, set())}", f" on {env}")
        performance.append(
            Section(
                f"Performance{where}",
                [
                    Figure(
                        f"best_so_far{suffix}.png",
                        f"Best-so-far reward against evaluations{where}",
                        "All designers; line = median over seeds, band = order-statistic interval of the median "
                        f"({_coverage_words(frame, confidence)}).",
                        plots.png(
                            plots.best_so_far_figure(curves, seeds=seeds, threshold=target[env], confidence=confidence)
                        ),
                    ),
                    Figure(
                        f"rewards_per_generation{suffix}.png",
                        f"Reward per generation{where}",
                        "Min / mean / max reward of the bodies evaluated in each generation (as in the thesis's "
                        f"figures 5.1-5.7); median over seeds, {_spread(generations[generations['env'] == env])} = "
                        "inter-quartile range.",
                        plots.png(plots.generation_rewards_figure(generations[generations["env"] == env], mine)),
                    ),
                ],
            )
        )
    tables["best_so_far.csv"] = (
        pd.concat(curve_tables, ignore_index=True),
        "median best-so-far reward over seeds at every evaluation count, per environment and designer, with its "
        "order-statistic interval and that interval's coverage",
    )

    body_sections: list[Section] = []
    best_of: dict[str, tuple[Body, int]] = {}
    if len(envs) > 1:
        performance.insert(0, _ranks_section(summary, designers, envs, tables))
        notes.append(
            "several environments: bodies, animations and diversity are left out; report a run of one environment to "
            "see them"
        )
    else:
        div = diversity(frame, survivors, near_copy)
        tables["diversity.csv"] = (div, "diversity of the proposals of every generation of every run")
        body_figures, best_of = _body_figures(frame, runs, designers, slugs)
        body_sections.append(
            Section(
                "Bodies",
                body_figures,
                "Colours as in Evolution Gym: rigid black, soft grey, horizontal actuator orange, vertical actuator "
                "blue, empty white.",
            )
        )
        if animations and experiment is not None:
            gifs = _animations(run, experiment, best_of, slugs, notes, reg)
            if gifs:
                body_sections.append(
                    Section(
                        "Animations",
                        gifs,
                        "The best body of each designer acting in the environment, replayed with the seed and "
                        "artifacts of its evaluation.",
                    )
                )
        body_sections.append(
            Section(
                "Diversity of proposals",
                [
                    Figure(
                        "diversity.png",
                        "Diversity per generation",
                        "Share of unique proposals, mean pairwise Hamming distance, and mean distance to the nearest "
                        "survivor of the previous generation (thesis section 4.5).",
                        plots.png(plots.diversity_figure(div, designers)),
                    ),
                    Figure(
                        "novelty.png",
                        "Near-copies versus novel shapes",
                        "Share of each generation's proposals by distance to the nearest survivor.",
                        plots.png(plots.novelty_figure(div, designers, near_copy)),
                    ),
                ],
            )
        )
    reevaluated: list[Section] = []
    if len(reevaluations):
        part, more = reevaluated_section(frame, reevaluations, designers, confidence)
        reevaluated.append(part)
        tables.update(more)
    primary = _primary(primary, experiment, designers, envs, reevaluations, meta, notes)
    stat = statistics_sections(
        frame, optima={env: t for env, t in target.items() if t is not None} or None, confidence=confidence,
        primary=primary, named_before=experiment is not None and experiment.primary == primary,
        reevaluations=reevaluations if len(reevaluations) else None,
    )  # fmt: skip
    tables.update(stat.tables)
    significance, *statistics = stat.sections
    # what is significant first, then where the scores come from, then the curves
    sections = [significance, *reevaluated, *performance, *statistics, *body_sections]

    env_name = (
        ", ".join(e.label for e in experiment.envs)
        if experiment is not None
        else ", ".join(map(str, frame["env"].unique()))
    )
    report = Report(
        run_path=run.path,
        out=out,
        title=f"gdabench report: {', '.join(designers)} on {env_name}",
        facts=_facts(run, meta, experiment, target_text, primary),
        notes=notes,
        summary=summary,
        headers=headers,
        rows=rows,
        sections=sections,
        tables=[(name, what) for name, (_, what) in tables.items()],
        definitions=definitions(confidence, survivors, near_copy) + stat.definitions,
    )
    _write(report, tables)
    return report


def _primary(
    given: Primary | None,
    experiment: Experiment | None,
    designers: list[str],
    envs: list[str],
    reevaluations: pd.DataFrame,
    meta: dict[str, Any],
    notes: list[str],
) -> Primary | None:
    """The primary comparison: the experiment's (named before the run), else one given for the report."""
    recorded = experiment.primary if experiment is not None else None
    if given is None or given == recorded:
        return recorded
    if recorded is not None:
        raise ConfigError(f"the run names its primary comparison ({recorded.a} against {recorded.b}) before it ran; "
                          "a report cannot replace it")  # fmt: skip
    given.check()
    for name in (given.a, given.b):
        if name not in designers:
            raise ConfigError(f"--primary: designer {name!r} is not in this run ({', '.join(designers)})")
    if given.env is None and len(envs) > 1:
        raise ConfigError(f"--primary: name the environment (env = one of {', '.join(envs)})")
    if given.metric == "reevaluated_best" and not len(reevaluations):
        raise ConfigError("--primary: this run has no re-evaluations (gdabench reevaluate RUN_DIR)")
    notes.append(f"the primary comparison ({given.a} against {given.b}) was named for this report, after the run "
                 f"(created {meta.get('created', '?')}): it is tested alone as planned comparisons are, but it was "
                 "not pre-registered")  # fmt: skip
    return given


def _ranks_section(
    summary: pd.DataFrame, designers: list[str], envs: list[str], tables: dict[str, tuple[pd.DataFrame, str]]
) -> Section:
    """Across environments: each designer's rank by median best reward on every environment, and the mean."""
    best = summary.pivot_table(index="designer", columns="env", values="best_median", sort=False).reindex(
        index=designers, columns=envs
    )
    ranks = best.rank(axis=0, ascending=False, method="average")
    ranks["mean rank"] = ranks.mean(axis=1, skipna=False)
    tables["ranks.csv"] = (
        ranks.reset_index(),
        "rank of each designer by median best reward on every environment (1 = best, ties share), and the mean rank",
    )
    rows = [
        [d, *(("-" if pd.isna(v) else f"{v:g}") for v in ranks.loc[d])] for d in ranks.sort_values("mean rank").index
    ]
    table = Table(
        "Rank by median best reward",
        ["designer", *envs, "mean rank"],
        rows,
        "1 = the best median best reward on that environment; a designer missing from an environment has no mean rank.",
    )
    return Section(
        "Across environments",
        [],
        "How the designers order on each environment of the suite; the aggregate statistics below pool normalised "
        "scores.",
        tables=[table],
    )


def _animations(
    run: RunDirectory,
    experiment: Experiment,
    best_of: dict[str, tuple[Body, int]],
    slugs: dict[str, str],
    notes: list[str],
    reg: Registry | None,
) -> list[Figure]:
    """A GIF of each designer's best body, when the environment can render one."""
    try:
        plan = Plan.resolve(experiment, reg or registry(), designers=False)
        env, controller = plan.scorers()
    except GdabenchError as exc:
        notes.append(f"no animations: cannot rebuild the environment ({exc})")
        return []
    gifs: list[Figure] = []
    for designer, (body, seed) in best_of.items():
        try:
            workdir = plan.workdir(run.path, plan.envs[0].label, designer, seed, body.hash)
            gif = animate(env, controller, body, seed=seed, workdir=workdir)
        except Exception as exc:  # noqa: BLE001 - a broken renderer must not cost the rest of the report
            notes.append(f"no animation for {designer}: {type(exc).__name__}: {exc}")
            continue
        if gif is None:
            return gifs  # the environment has nothing to show, for any body
        gifs.append(
            Figure(
                f"animation_{slugs[designer]}.gif",
                f"{designer}: best body acting",
                f"Seed {seed}, body {body.text}.",
                gif,
                "image/gif",
            )
        )
    return gifs


def _write(report: Report, tables: dict[str, tuple[pd.DataFrame, str]]) -> None:
    files = {fig.filename: fig.data for fig in report.figures}
    files.update({name: table.to_csv(index=False).encode() for name, (table, _) in tables.items()})
    files["summary.md"] = render_markdown(report).encode()
    files["report.html"] = render_html(report).encode()
    if is_file(report.out):
        raise ConfigError(f"cannot write the report to {report.out}: it is a file")
    with staged_folder(report.out, whole=False, last="report.html") as staging:
        for name, data in files.items():
            (staging / name).write_bytes(data)
            os.chmod(staging / name, 0o644)  # a report is for sharing
