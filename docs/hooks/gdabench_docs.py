"""MkDocs hooks: the parts of the documentation that are generated from the repository.

Generated so that they cannot drift from the code or the committed data:

* ``<!-- gdabench:columns -->`` in a page becomes the table of result columns,
  :data:`gdabench.results.COLUMNS` (the schema the runner writes);
* ``<!-- gdabench:reference-summary -->`` becomes the per-designer table of the committed reference
  run, taken from ``results/reference/simple/report/summary.md`` (the README shows the same table;
  ``tests/test_docs.py`` checks that); ``<!-- gdabench:reference-summary walker -->`` the same of
  ``results/reference/walker/``;
* ``<!-- gdabench:thesis-walker -->`` becomes the walker reference run's reward per generation beside
  the thesis's (its chapter 5.1), from ``results/reference/walker/report/generations.csv``;
* ``<!-- gdabench:walker-bodies -->`` becomes what the walker reference run's best bodies are made of (the
  thesis's figure 5.2 describes its best robots so), from ``results/reference/walker/evaluations.parquet``;
* ``<!-- gdabench:walker-claims -->`` becomes the thesis's statements about its figure 5.1, each checked on every
  seed of the walker reference run;
* ``<!-- gdabench:walker-claims RUN -->`` the same with the thesis's own variants of the run in
  ``results/reference/RUN/`` in the places of their designers, and ``<!-- gdabench:walker-variants RUN -->``
  each variant's best reward per seed beside its designer's;
* ``<!-- gdabench:walker-transfer -->`` becomes the transfer check of that run's best bodies in Evolution
  Gym, from its ``transfer.csv``, summarised by ``benchmarks/compare/walker_transfer.py``'s own functions;
* ``<!-- gdabench:walker-reevaluated -->``, ``<!-- gdabench:walker-measures -->`` and ``<!-- gdabench:walker-tests -->``
  become the walker run's raw against re-evaluated scores (``reevaluations.parquet``), its measures that do not
  saturate (evaluations to a reward, mean best-so-far) and its primary and exploratory tests (``pairwise.csv``);
* ``<!-- gdabench:thesis-budget -->`` and ``<!-- gdabench:thesis-budget-bodies -->`` become the thesis's budget
  against its author's numbers, from ``docs/benchmarks/output/thesis-budget.csv`` (benchmarks/figures/thesis_budget.py);
* ``<!-- gdabench:evogym-task-summary -->``, ``<!-- gdabench:evogym-task-misses -->``,
  ``<!-- gdabench:evogym-task-parity -->`` and ``<!-- gdabench:evogym-task-control -->`` become the voxel engine
  against Evolution Gym on its 32 tasks (parity steps, fidelity, stability, speed, the goals missed and Evolution
  Gym against itself), from the ``task-*.json`` and ``task-fidelity*.csv`` outputs in ``docs/benchmarks/output/``
  (``benchmarks/compare/task_parity.py``, ``task_fidelity.py``, ``task_stability.py``, ``task_speed.py``);
* ``<!-- gdabench:controllers-compare -->``, ``<!-- gdabench:controllers-generations -->``,
  ``<!-- gdabench:controllers-speed -->``, ``<!-- gdabench:controllers-record -->`` and
  ``<!-- gdabench:controllers-codesign -->`` become the controllers that learn many bodies against per-body PPO
  (reward per body; whether it holds on a second generation; env steps per second; what each task and budget's
  record has finished; short co-design runs), from
  ``docs/benchmarks/output/controllers-compare-<budget>[-unpinned].json``, ``controllers-record/`` and
  ``controllers-codesign.csv`` (``benchmarks/figures/controllers_compare.py``, whose
  own tables they are);
* ``<!-- gdabench:extras -->`` becomes the table of the optional extras in ``pyproject.toml``.

Files outside ``docs/`` that pages show or link to (the committed reference runs under
``results/reference/``) are published with the site under the same path, so a page links to
``../results/reference/simple/report/best_so_far.png`` and ``mkdocs build --strict`` checks the link
like any other.

Pages that other branches are still writing are listed under ``extra.pending_pages`` in
``mkdocs.yml``: their nav entries are left out while the file is missing, and once it exists the
build warns (so fails in strict mode) until the entry is removed from that list.
"""

from __future__ import annotations

import csv
import json
import re
import tomllib
from pathlib import Path
from typing import Any

from mkdocs.exceptions import PluginError
from mkdocs.plugins import get_plugin_logger
from mkdocs.structure.files import File, Files

log = get_plugin_logger("gdabench")

#: committed results published with the site (Markdown files there are not pages)
PUBLISHED = "results/reference"
#: the thesis author's published Walker-v0 bodies and rewards (JohnStewardson/evolving_robots_diffusion, runs of
#: 26 August, 13 September and 27 September 2024; benchmarks/ops/thesis_walker_bodies.py): the thesis's figure 5.1
THESIS_BODIES = "docs/benchmarks/output/thesis-walker-bodies.csv"
#: what benchmarks/figures/thesis_budget.py trained of them, row by row
THESIS_BUDGET = "docs/benchmarks/output/thesis-budget.csv"
#: benchmarks/figures/controllers_compare.py's rows (reward per body) and the co-design runs' evaluations
CONTROLLERS_COMPARE = (
    "docs/benchmarks/output/controllers-compare-12500.json",
    "docs/benchmarks/output/controllers-compare-50000.json",
)
#: the same measurement's first runs, whose torch ran the CPU's own kernels: other generations (see the page)
CONTROLLERS_UNPINNED = (
    "docs/benchmarks/output/controllers-compare-12500-unpinned.json",
    "docs/benchmarks/output/controllers-compare-50000-unpinned.json",
)
CONTROLLERS_CODESIGN = "docs/benchmarks/output/controllers-codesign.csv"
#: each task and budget's record of what that measurement has finished (``--record``), the rows' source
CONTROLLERS_RECORD = "docs/benchmarks/output/controllers-record"
#: the outputs of the task benchmarks (benchmarks/compare/task_*.py); the controls may be missing (not run yet)
TASK_OUTPUT = "docs/benchmarks/output"
#: issue 53's speed goal: env steps/s of a batch of 64 on one core against Evolution Gym's, on every task
TASK_SPEED_GOAL = 10.0
#: rewards the walker page counts evaluations to (the runs' generation-0 bests lie between 3.3 and 5.3)
WALKER_THRESHOLDS = (5.0, 6.0)

#: what each optional extra of pyproject.toml is for; an extra missing here fails the build
EXTRAS = {
    "test": "the test suite (`python -m pytest`) and the timed benchmarks under `tests/benchmarks/`",
    "nevergrad": "the `nevergrad` designer: nevergrad's optimizers (NGOpt, DiscreteOnePlusOne, ...) on the voxel codes ([Designers from other ecosystems](designers/ecosystem.md))",
    "bo": "the `bo` designer: Bayesian optimisation on BoTorch (uses the torch already installed)",
    "ribs": "the `ribs-map-elites` and `ribs-cma-me` designers: pyribs' archive, emitters and scheduler",
    "gpu": "the voxel engine on an NVIDIA GPU: `gdabench.envs.voxel.gpu` ([On a GPU](environments/voxel-engine.md#on-a-gpu))",
    "ray": "`--executor ray`: run trials (and their evaluation workers) on a local Ray instance or an existing Ray cluster",
    "tensorboard": "`--log tensorboard`: each generation's figures as TensorBoard event files",
    "bench": "`benchmarks/compare/ppo_vs_sb3.py`, which compares the `ppo` controller with stable-baselines3's PPO",
    "docs": "building this site: `mkdocs build --strict`",
    "lint": "`ruff check gdabench tests benchmarks plugins` and `mypy`, as CI runs them ([Development](development.md#lint-and-types))",
}

#: ``<!-- gdabench:NAME -->`` or ``<!-- gdabench:NAME ARGUMENT -->``
PLACEHOLDER = re.compile(r"<!-- gdabench:([a-z-]+)(?: ([a-z0-9_-]+))? -->")


def _root(config: Any) -> Path:
    return Path(config["config_file_path"]).resolve().parent


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|")


def columns_table() -> str:
    from gdabench.results import COLUMNS

    rows = [f"| `{name}` | {_cell(meaning)} |" for name, meaning in COLUMNS.items()]
    return "\n".join(["| column | meaning |", "|---|---|", *rows])


def reference_summary(root: Path, run: str = "simple") -> str:
    """The table under "Summary per designer" of the reference run's summary.md."""
    path = root / PUBLISHED / run / "report" / "summary.md"
    try:
        lines = path.read_text().splitlines()
    except OSError as exc:
        raise PluginError(f"cannot read the reference run's summary {path}: {exc}") from exc
    start = next((i for i, line in enumerate(lines) if line.strip() == "## Summary per designer"), None)
    if start is None:
        raise PluginError(f"{path} has no '## Summary per designer' section")
    table = []
    for line in lines[start + 1 :]:
        if line.startswith("|"):
            table.append(line)
        elif table:
            break
    if not table:
        raise PluginError(f"{path}: no table under '## Summary per designer'")
    return "\n".join(table)


def _read_walker(name: str, root: Path, reader: Any, run: str = "walker", **kwargs: Any) -> Any:
    """A file of a committed walker reference run, read with ``reader``; a build error names it if it cannot be."""
    path = root / PUBLISHED / run / name
    try:
        return reader(path, **kwargs)
    except OSError as exc:
        raise PluginError(f"cannot read the reference run {run}'s {name} ({path}): {exc}") from exc


def thesis_walker_best(root: Path) -> dict[str, dict[int, float]]:
    """The best reward of each generation of the thesis author's Walker-v0 runs (one run per designer, PPO with
    1e6 timesteps per body, scored without the final step's reward), from their published data."""
    import pandas as pd

    try:
        bodies = pd.read_csv(root / THESIS_BODIES, comment="#")
    except OSError as exc:
        raise PluginError(f"cannot read the thesis author's bodies {THESIS_BODIES}: {exc}") from exc
    best = bodies.groupby(["designer", "generation"])["reward"].max()
    return {str(d): {int(g): float(v) for (dd, g), v in best.items() if dd == d} for d in best.index.levels[0]}


def thesis_walker(root: Path) -> str:
    """Per designer and generation of the walker reference run: the population's best, mean and worst reward
    (medians over seeds; the best also its range), beside the best of the thesis author's run."""
    import pandas as pd

    frame = _read_walker("report/generations.csv", root, pd.read_csv)
    author = thesis_walker_best(root)
    rows = ["| designer | generation | seeds | best: median [range] | mean | worst | thesis (author's data): best |",
            "|---|--:|--:|--:|--:|--:|--:|"]
    for (designer, generation), group in frame.groupby(["designer", "generation"], sort=False):
        thesis = author.get(str(designer), {}).get(int(generation))
        rows.append(
            f"| {designer} | {generation} | {len(group)} | {group['max'].median():.2f} "
            f"[{group['max'].min():.2f}, {group['max'].max():.2f}] | {group['mean'].median():.2f} "
            f"| {group['min'].median():.2f} | {'' if thesis is None else f'{thesis:.2f}'} |"
        )
    return "\n".join(rows)


def _rises(values: Any) -> float:
    """Spearman's correlation of a run's per-generation figure with the generation (positive: it rises)."""
    from scipy.stats import spearmanr

    values = list(values)
    if len(set(values)) < 2:
        return 0.0  # a flat figure does not rise
    return float(spearmanr(range(len(values)), values).statistic)


def thesis_claims(evaluations: Any) -> list[dict[str, Any]]:
    """The thesis's statements about figure 5.1 (chapter 5.1), each checked on every seed of ``evaluations``.

    One dict per statement: its words, the thesis's own figures, the check made here, the seeds where it
    holds, the seeds checked and each seed's figures.  A statement about one designer needs that designer's
    seed; one that compares designers needs all of them on that seed.  A generation's figures are those of
    the bodies evaluated in it (a GA's survivors are not evaluated again, so they are not in it).
    """
    from gdabench.stats.core import generation_rewards

    gens = {key: g.set_index("generation") for key, g in generation_rewards(evaluations).groupby(["designer", "seed"])}
    seeds = sorted({seed for _, seed in gens})
    ok = evaluations[evaluations["status"] == "ok"]
    #: each trial's best of its first 75 evaluations (the GDA's generations 0-2)
    early = ok[ok["n_evals"] <= 75].groupby(["designer", "seed"])["reward"].max()

    def check(designers: tuple[str, ...], test: Any) -> tuple[list[int], list[str]]:
        held, details = [], []
        for seed in seeds:
            if all((d, seed) in gens for d in designers):
                holds, detail = test(*(gens[(d, seed)] for d in designers), seed)
                if holds:
                    held.append(seed)
                details.append(f"{seed}: {detail}")
        return held, details

    def all_rise(g: Any) -> bool:
        return min(_rises(g[c]) for c in ("min", "mean", "max")) > 0

    claims = [
        ("The GDA completes the task in only two generations", "best 6.22, 7.88, 9.55",
         "gda's best rises from generation 0 to 2", ("gda",),
         lambda g, s: (g["max"][2] > g["max"][0], f"{g['max'][0]:.2f} to {g['max'][2]:.2f}")),
        ("After the second generation, the maximum reward decreases again slightly", "9.55, then 8.90, 8.28",
         "gda's best of generations 3 and 4 below generation 2's", ("gda",),
         lambda g, s: (max(g["max"][3], g["max"][4]) < g["max"][2],
                       f"{g['max'][2]:.2f}, then {g['max'][3]:.2f}, {g['max'][4]:.2f}")),
        ("The lowest rewards of the GDA do increase", "figure only",
         "gda's worst rises with the generation (Spearman > 0)", ("gda",),
         lambda g, s: (_rises(g["min"]) > 0, f"{_rises(g['min']):+.2f}")),
        ("Only in the GA do the minimum, maximum and average rewards steadily increase",
         "best 8.89 to 9.53 by generation 4",
         "ga's worst, mean and best all rise (Spearman > 0)", ("ga",),
         lambda g, s: (all_rise(g), ", ".join(f"{_rises(g[c]):+.2f}" for c in ("min", "mean", "max")))),
        ("... and not in the others", "figure only", "cppn's and gda's do not all rise", ("cppn", "gda"),
         lambda c, g, s: (not all_rise(c) and not all_rise(g),
                          ", ".join(f"{d} {'all rise' if all_rise(x) else 'not all'}"
                                    for d, x in (("cppn", c), ("gda", g))))),
        ("By chance, CPPN-NEAT even achieved walking in the first generation", "9.56 against 8.89 and 6.22",
         "cppn's generation-0 best above ga's and gda's", ("cppn", "ga", "gda"),
         lambda c, a, g, s: (c["max"][0] > max(a["max"][0], g["max"][0]),
                             f"{c['max'][0]:.2f} against {a['max'][0]:.2f}, {g['max'][0]:.2f}")),
        ("The GDA achieved walking faster than the GA", "9.55 in generation 2, the GA 9.53 in generation 4",
         "gda's best of its first 75 evaluations above ga's", ("gda", "ga"),
         lambda g, a, s: (early["gda", s] > early["ga", s], f"{early['gda', s]:.2f} against {early['ga', s]:.2f}")),
    ]
    out = []
    for words, thesis, here, designers, test in claims:
        held, details = check(designers, test)
        out.append({"claim": words, "thesis": thesis, "check": here, "holds": held, "seeds": len(details),
                    "figures": "; ".join(details)})
    trio = ("ga", "cppn", "gda")
    winners = {seed: max(trio, key=lambda d: gens[(d, seed)]["max"].max())
               for seed in seeds if all((d, seed) in gens for d in trio)}
    out.append({"claim": "Running this experiment multiple times is expected to lead to different outcomes",
                "thesis": "one run per designer", "check": "which of ga, cppn, gda ends best differs between seeds",
                "holds": list(winners) if len(set(winners.values())) > 1 else [], "seeds": len(winners),
                "figures": "; ".join(f"{seed}: {d}" for seed, d in winners.items())})
    return out


def with_variants(main: Any, variants: Any) -> Any:
    """``main``'s rows with each designer that ``variants`` runs a variant of (``ga[survivors=5]`` of ``ga``)
    replaced by the variant, under the designer's own name: the thesis's statements read on its variants."""
    import pandas as pd

    variants = variants.assign(designer=variants["designer_name"])
    return pd.concat([main[~main["designer"].isin(set(variants["designer"]))], variants], ignore_index=True)


def variants_table(main: Any, variants: Any) -> str:
    """Per seed, each variant's best reward beside its designer's in ``main`` (the same seed), then the medians."""
    import pandas as pd

    best = pd.concat([main, variants]).groupby(["designer", "seed"])["reward"].max().unstack("designer")
    pairs = variants[["designer_name", "designer"]].drop_duplicates().itertuples(index=False)
    columns = [c for name, label in pairs for c in (name, label)]
    best = best.reindex(index=sorted(set(variants["seed"])), columns=columns)
    # each pair's medians over the seeds where both have run
    medians = [best[list(pair)].dropna()[c].median() for pair in zip(columns[::2], columns[1::2]) for c in pair]
    lines = ["| seed | " + " | ".join(columns) + " |", "|--:" + "|--:" * len(columns) + "|"]

    def cell(value: float) -> str:
        return "" if pd.isna(value) else f"{value:.2f}"

    lines += [f"| {seed} | " + " | ".join(cell(v) for v in row) + " |" for seed, row in best.iterrows()]
    lines.append("| median | " + " | ".join(cell(v) for v in medians) + " |")
    return "\n".join(lines)


def finished(rows: Any) -> Any:
    """The rows of trials that have spent their budget (a run committed while it goes on has others)."""
    spent = rows.groupby(["designer", "seed"])["n_evals"].transform("max") >= rows["budget"]
    return rows[spent]


def _rows(root: Path, run: str = "walker") -> Any:
    """The committed rows of a walker reference run; of a variants run, only its finished trials'."""
    from gdabench.results import read_parquet

    rows = _read_walker("evaluations.parquet", root, read_parquet, run)
    return rows if run == "walker" else finished(rows)


def walker_variants(root: Path, run: str) -> str:
    """:func:`variants_table` of the committed run ``run`` against the walker run."""
    return variants_table(_rows(root), _rows(root, run))


def walker_claims(root: Path, run: str = "walker") -> str:
    """:func:`thesis_claims` of the committed walker run's finished trials (or with ``run``'s variants), as a table."""
    rows = _rows(root) if run == "walker" else with_variants(_rows(root), _rows(root, run))
    lines = ["| the thesis (chapter 5.1) | its figures | checked here as | holds on | per seed |",
             "|---|---|---|---|---|"]
    for c in thesis_claims(rows):
        lines.append(f"| {c['claim']} | {c['thesis']} | {c['check']} | {len(c['holds'])} of {c['seeds']} seeds "
                     f"| {c['figures']} |")
    return "\n".join(lines)


def body_character(text: str) -> dict[str, float]:
    """A body's materials as shares of its voxels, and how often two adjacent voxels are of one material.

    The last is the share of edge-sharing pairs of non-empty voxels with the same material: about 1/4
    for Evolution Gym's random bodies, 1 for a body of one material.
    """
    from gdabench.body import VOXEL_NAMES, Body

    voxels = Body.from_text(text).voxels
    filled = voxels > 0
    shares = {name: float((voxels == code).sum() / filled.sum()) for code, name in enumerate(VOXEL_NAMES) if code}
    same = pairs = 0
    for a, b in ((voxels[:, 1:], voxels[:, :-1]), (voxels[1:, :], voxels[:-1, :])):
        both = (a > 0) & (b > 0)
        pairs += int(both.sum())
        same += int((both & (a == b)).sum())
    same_share = same / pairs if pairs else float("nan")
    return {"voxels": float(filled.sum()), **shares, "same-material neighbours": same_share}


def walker_bodies(root: Path) -> str:
    """Per designer, what the best body of each of its seeds is made of: means over seeds."""
    import pandas as pd

    from gdabench.results import read_parquet

    rows = _read_walker("evaluations.parquet", root, read_parquet, columns=["designer", "seed", "body", "reward"])
    rows = rows.dropna(subset=["reward"])
    best = rows.loc[rows.groupby(["designer", "seed"], sort=False)["reward"].idxmax()]
    character = pd.DataFrame([body_character(text) for text in best["body"]], index=best.index)
    means = pd.concat([best[["designer"]], character], axis=1).groupby("designer", sort=False)
    header = ["designer", "seeds", *character.columns]
    lines = ["| " + " | ".join(header) + " |", "|---" + "|--:" * (len(header) - 1) + "|"]
    for designer, group in means:
        cells = [f"{group['voxels'].mean():.1f}", *(f"{group[c].mean():.2f}" for c in character.columns[1:])]
        lines.append(f"| {designer} | {len(group)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _benchmark(root: Path, script: str) -> Any:
    """A script of ``benchmarks/`` (``folder/name``) as a module, for the page that shows what it measured."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(Path(script).name, root / "benchmarks" / f"{script}.py")
    if spec is None or spec.loader is None:
        raise PluginError(f"cannot load benchmarks/{script}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def walker_transfer(root: Path) -> str:
    """The designer ranking in both simulators, the per-body agreement, and every body's two rewards."""
    transfer = _benchmark(root, "compare/walker_transfer")
    table = _read_walker("transfer.csv", root, transfer.read_transfer)
    lines = ["| designer | seeds | walker: mean best | Evolution Gym: mean | rank on walker | rank in Evolution Gym |",
             "|---|--:|--:|--:|--:|--:|"]
    for designer, row in transfer.ranking(table).iterrows():
        lines.append(f"| {designer} | {int(row['seeds'])} | {row['walker']:.2f} | {row['evogym']:.2f} "
                     f"| {int(row['rank walker'])} | {int(row['rank evogym'])} |")
    rho, alike = transfer.agreement(table)
    lines += ["", f"Per body ({len(table)} bodies): Spearman {rho:.2f}, pairs ordered alike {alike:.0%}.", "",
              "| designer | seed | body | walker | Evolution Gym |", "|---|--:|---|--:|--:|"]
    lines += [f"| {r.designer} | {r.seed} | `{r.body}` | {r.walker:.2f} | {r.evogym:.2f} |" for r in table.itertuples()]
    return "\n".join(lines)


def evogym_tasks() -> str:
    """Evolution Gym's 32 tasks on the voxel engine: grade, step limit, where the robot starts, what moves."""
    from gdabench.envs.tasks import ENTRIES, task

    rows = ["| task | grade | steps | robot at (voxel) | observation (robot of n points) | moving objects | "
            "what it asks |", "|---|---|--:|---|---|---|---|"]
    for entry in ENTRIES:
        defined = task(entry.id)
        objects = defined.objects()
        moving = [name for name, (grid, _) in objects.items() if (grid[grid != 0] != 5).any() or name in defined.moving]
        extra = defined.obs_size(0)
        size = f"2n + {extra}" if extra else "2n"
        shown = ", ".join(moving[:3]) + (f" and {len(moving) - 3} more" if len(moving) > 3 else "") or "none"
        rows.append(f"| `voxel/{entry.id}` | {entry.difficulty} | {entry.max_episode_steps} | {defined.robot_at} "
                    f"| {size} | {shown} | {entry.summary} |")
    return "\n".join(rows)


def _task_output(root: Path, name: str, required: bool = True) -> Any:
    """One task benchmark's JSON output; None for a missing optional one (a control not run)."""
    path = root / TASK_OUTPUT / name
    if not required and not path.exists():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise PluginError(f"cannot read {TASK_OUTPUT}/{name}: {exc}") from exc


def _task_episodes(root: Path, name: str) -> dict[tuple[str, str, str], dict[str, str]]:
    """task_fidelity's episodes (its CSV) by (task, body, gait); empty if the control was not run."""
    path = root / TASK_OUTPUT / name
    if not path.exists():
        return {}
    with path.open(newline="") as f:
        return {(r["task"], r["body"], r["gait"]): r for r in csv.DictReader(f)}


def task_evidence(root: Path) -> dict[str, Any]:
    """Every task benchmark's output, per task: parity, fidelity, stability, speed and the two controls."""
    by_task = lambda out, key="tasks": {r["task"]: r for r in out[key]} if out else {}  # noqa: E731
    fidelity = _task_output(root, "task-fidelity.json")
    speed = _task_output(root, "task-speed.json")
    return {
        "parity": by_task(_task_output(root, "task-parity.json")),
        "parity_control": by_task(_task_output(root, "task-parity-control.json", required=False)),
        "fidelity": by_task(fidelity),
        "fidelity_control": by_task(_task_output(root, "task-fidelity-control.json", required=False)),
        "stability": by_task(_task_output(root, "task-stability.json", required=False)),
        "speed": by_task(speed, "rows"),
        "speed_settings": {k: v for k, v in speed.items() if k != "rows"},
        "goal": fidelity["goal"],
    }


#: issue 53's goals, as ``task_goals`` names them
TASK_GOALS = {
    "parity over 10 steps": "positions and observations within 1e-6 over the first 10 steps",
    "Spearman": "held-out Spearman >= {spearman}",
    "sign agreement": "held-out sign agreement >= {sign_agreement:.0%}",
    "unstable in one simulator only": "no held-out episode unstable in one simulator only",
    "stability checks": "random actions: no NaN, observations inside their space, unstable steps undone and penalised",
    "unstable rate": "random actions: as many unstable bodies as Evolution Gym has, or, for each body unstable in one "
                     "simulator only, unstable rates over nudged runs that do not differ (Fisher's exact p >= 0.05)",
    "10x speed": "at least {speed:.0f}x Evolution Gym's env steps/s",
}


#: below this p (Fisher's exact test), two simulators' unstable rates over nudged runs of an episode differ
NUDGED_ALPHA = 0.05


def nudged_rates_agree(stability: dict[str, Any]) -> bool:
    """Whether every body unstable in one simulator only became unstable at rates that do not differ over its
    nudged runs (``task_stability.py --nudges``): then the one draw that differed was a chance of rounding."""
    from scipy.stats import fisher_exact

    one_only = set(stability["unstable_bodies_voxel"]) ^ set(stability["unstable_bodies_evogym"])
    nudged = {n["body"]: n for n in stability.get("nudged", [])}
    if not one_only <= set(nudged):
        return False
    return all(fisher_exact([[n["voxel"], n["runs"] - n["voxel"]], [n["evogym"], n["runs"] - n["evogym"]]]).pvalue
               >= NUDGED_ALPHA for n in (nudged[b] for b in one_only))


def _unstable_cell(stability: dict[str, Any]) -> str:
    """Unstable bodies on each simulator, and the nudged runs' unstable counts where they were played."""
    cell = f"{stability['unstable_voxel']} / {stability['unstable_evogym']}"
    for n in stability.get("nudged", []):
        cell += f" (nudged {n['runs']} times: {n['voxel']} / {n['evogym']})"
    return cell


def task_goals(evidence: dict[str, Any], task: str) -> dict[str, bool | None]:
    """Whether ``task`` meets each of issue 53's goals (:data:`TASK_GOALS`); None where it was not measured."""
    goal = evidence["goal"]
    parity, stability, speed = (evidence[k].get(task) for k in ("parity", "stability", "speed"))
    held = evidence["fidelity"].get(task, {}).get("parts", {}).get("held-out")
    met = lambda measured, test: bool(test()) if measured else None  # noqa: E731
    return {
        "parity over 10 steps": met(parity, lambda: (parity["first_over"]["1e-6"] or 11) > 10),
        "Spearman": met(held, lambda: held["spearman"] >= goal["spearman"]),
        "sign agreement": met(held, lambda: held["sign_agreement"] >= goal["sign_agreement"]),
        "unstable in one simulator only": met(
            held, lambda: held["unstable_ours_only"] + held["unstable_evogym_only"] == 0),
        "stability checks": met(stability, lambda: not any(stability["problems"].values())),
        "unstable rate": met(stability, lambda: stability.get("unstable_voxel") == stability.get("unstable_evogym")
                             or nudged_rates_agree(stability)),
        "10x speed": met(speed, lambda: speed["ratio"] >= TASK_SPEED_GOAL),
    }


def _steps(parity: dict[str, Any]) -> str:
    return "all" if parity["parity_all_steps"] else str(parity["parity_steps"])


def _share(value: float) -> str:
    return f"{100 * value:.1f}%"


def evogym_task_summary(root: Path) -> str:
    """Per task: parity steps, held-out Spearman and sign agreement, unstable bodies, speed, the goals missed."""
    from gdabench.envs.tasks import ENTRIES

    ev = task_evidence(root)
    goal = ev["goal"]
    lines = ["| task | grade | parity steps (gap <= 1e-6) | held-out Spearman | held-out sign agreement "
             "| unstable bodies: voxel / Evolution Gym | voxel env steps/s | Evolution Gym env steps/s | speed ratio "
             "| KB per env | goals missed |", "|---|---|--:|--:|--:|--:|--:|--:|--:|--:|---|"]
    for entry in ENTRIES:
        task = entry.id
        parity, stability, speed = (ev[k].get(task) for k in ("parity", "stability", "speed"))
        held = ev["fidelity"].get(task, {}).get("parts", {}).get("held-out")
        goals = task_goals(ev, task)
        bold = lambda text, miss: f"**{text}**" if miss else text  # noqa: E731
        cells = [f"`{task}`", entry.difficulty, _steps(parity) if parity else "not run"]
        cells += [bold(f"{held['spearman']:.3f}", held["spearman"] < goal["spearman"]),
                  bold(_share(held["sign_agreement"]), held["sign_agreement"] < goal["sign_agreement"])] \
            if held else ["not run"] * 2
        cells.append(bold(_unstable_cell(stability), goals["unstable rate"] is False) if stability
                     else "not run")
        cells += [f"{speed['voxel']:,.0f}", f"{speed['evogym']:,.0f}",
                  bold(f"{speed['ratio']:.1f}x", speed["ratio"] < TASK_SPEED_GOAL),
                  f"{speed['bytes_per_env'] / 1e3:.0f}"] if speed else ["not run"] * 4
        unmeasured = [name for name, met in goals.items() if met is None]
        cells.append((", ".join(name for name, met in goals.items() if met is False) or "none")
                     + (f" (not measured: {', '.join(unmeasured)})" if unmeasured else ""))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def evogym_task_misses(root: Path) -> str:
    """Which tasks miss which goal; the held-out episodes where the simulators part, beside Evolution Gym nudged."""
    from gdabench.envs.tasks import ENTRIES

    ev = task_evidence(root)
    goals = {entry.id: task_goals(ev, entry.id) for entry in ENTRIES}
    lines = []
    for key, text in TASK_GOALS.items():
        text = text.format(speed=TASK_SPEED_GOAL, **ev["goal"])
        missed = [t for t, g in goals.items() if g[key] is False]
        unmeasured = [t for t, g in goals.items() if g[key] is None]
        said = f"**{len(missed)} of {len(goals)} tasks miss it**: " + ", ".join(f"`{t}`" for t in missed) if missed \
            else f"every task {'measured ' if unmeasured else ''}meets it"
        if len(unmeasured) == len(goals):
            said = "not measured"
        elif unmeasured:
            said += f"; not measured on {len(unmeasured)}: " + ", ".join(f"`{t}`" for t in unmeasured)
        lines.append(f"* {text}: {said}")
    missed = {t: [k for k, v in g.items() if v is False] for t, g in goals.items()}
    fidelity_keys = {"Spearman", "sign agreement", "unstable in one simulator only"}
    parted = [t for t, m in missed.items() if fidelity_keys & set(m)]
    if not parted:
        return "\n".join(lines)
    ours, nudged = _task_episodes(root, "task-fidelity.csv"), _task_episodes(root, "task-fidelity-control.csv")
    runs = _task_output(root, "task-fidelity-nudged.json", required=False)
    many = {(n["task"], n["body"], n["gait"]): n for n in runs["episodes"]} if runs else {}
    show = lambda r, who: f"{float(r['return_' + who]):.4g}" + (  # noqa: E731
        f" (ended at {r['steps_' + who]}{', unstable' if r['unstable_' + who] == '1' else ''})"
        if r["steps_voxel"] != r["steps_evogym"] or r["unstable_voxel"] != r["unstable_evogym"] else "")
    lines += ["", "Held-out episodes of these tasks whose returns differ in sign, or whose episodes end differently:",
              "", "| task | body | gait | voxel engine | Evolution Gym | Evolution Gym, actions + 1e-14 "
              "| nudged runs, voxel engine / Evolution Gym: return > 0, ended early, unstable (Fisher's p) |",
              "|---|---|---|--:|--:|--:|---|"]
    shown: list[dict[str, Any] | None] = []
    for key, r in ours.items():
        if key[0] not in parted or r["part"] != "held-out":
            continue
        a, b = float(r["return_voxel"]), float(r["return_evogym"])
        ends = (r["steps_voxel"], r["unstable_voxel"]) != (r["steps_evogym"], r["unstable_evogym"])
        if (a > 0) - (a < 0) != (b > 0) - (b < 0) or ends:  # np.sign, as task_fidelity's sign agreement
            c, n = nudged.get(key), many.get(key)
            lines.append(f"| `{key[0]}` | `{key[1]}` | {key[2]} | {show(r, 'voxel')} | {show(r, 'evogym')} "
                         f"| {show(c, 'voxel') if c else 'not run'} | {_nudged_cell(n) if n else 'not run'} |")
            shown.append(n)
    played = [n for n in shown if n]
    if played:
        chance = sum(all(n[f"p_{k}"] >= NUDGED_ALPHA for k in ("positive", "ended_early", "unstable")) for n in played)
        lines += ["", f"Played {played[0]['runs']} more times in each simulator, nudged ({len(played)} of these "
                  f"{len(shown)} episodes): in {chance} of them both simulators' runs end each way (return above zero, "
                  "ended early, unstable) at rates that do not differ (Fisher's exact p >= 0.05)."]
    return "\n".join(lines)


def _nudged_cell(n: dict[str, Any]) -> str:
    """One episode's nudged runs (``task_fidelity.py --nudges``): how often each simulator's runs ended how."""
    v, e, runs = n["voxel"], n["evogym"], n["runs"]
    return (f"of {runs}: {v['positive']} / {e['positive']} (p {n['p_positive']:.2g}), "
            f"{v['ended_early']} / {e['ended_early']} (p {n['p_ended_early']:.2g}), "
            f"{v['unstable']} / {e['unstable']} (p {n['p_unstable']:.2g})")


def evogym_task_parity(root: Path) -> str:
    """Per task: where the voxel engine's trajectories part from Evolution Gym's, beside Evolution Gym nudged."""
    from gdabench.envs.tasks import ENTRIES

    ev = task_evidence(root)
    step = lambda v: "-" if v is None else str(v)  # noqa: E731
    lines = ["| task | steps played | first step with a gap > 0 | > 1e-12 | > 1e-6 | > 1e-3 "
             "| largest position gap, steps 1-100 | to the end | ends agree "
             "| Evolution Gym nudged: > 1e-12 | > 1e-6 | > 1e-3 |", "|---|--:|--:|--:|--:|--:|--:|--:|---|--:|--:|--:|"]
    for entry in ENTRIES:
        p, c = ev["parity"].get(entry.id), ev["parity_control"].get(entry.id)
        if p is None:
            continue
        lengths = sorted({b["steps"] for b in p["per_body"]})
        played = f"{lengths[0]}" + (f"-{lengths[-1]}" if len(lengths) > 1 else "")
        first, gap = p["first_over"], p["gap_up_to"]["pos"]
        control = [step(c["first_over"][k]) for k in ("1e-12", "1e-6", "1e-3")] if c else ["not run"] * 3
        lines.append(f"| `{entry.id}` | {played} | {step(first['0'])} | {step(first['1e-12'])} | {step(first['1e-6'])} "
                     f"| {step(first['1e-3'])} | {gap.get('100', 0.0):.0e} | {max(gap.values()):.0e} "
                     f"| {'yes' if p['ends_agree'] else '**no**'} | " + " | ".join(control) + " |")
    return "\n".join(lines)


def evogym_task_control(root: Path) -> str:
    """The held-out figures of the voxel engine against Evolution Gym beside Evolution Gym against itself, nudged."""
    ev = task_evidence(root)
    if not ev["fidelity_control"]:
        return "*Not run yet: `task-fidelity-control.json` is not committed.*"
    lines = ["| task | episodes | voxel vs Evolution Gym: Spearman | sign agreement | unstable in one only "
             "| median trajectory gap (voxels) | Evolution Gym vs nudged: Spearman | sign agreement "
             "| unstable in one only | median trajectory gap (voxels) |", "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|"]
    for task, control in ev["fidelity_control"].items():
        cells = []
        for result in (ev["fidelity"][task], control):
            held = result["parts"]["held-out"]
            only = round((held["unstable_ours_only"] + held["unstable_evogym_only"]) * held["episodes"])
            cells += [f"{held['spearman']:.3f}", _share(held["sign_agreement"]), str(only),
                      f"{held['trajectory_gap_voxels']:.0e}"]
        lines.append(f"| `{task}` | {control['parts']['held-out']['episodes']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def thesis_budget(root: Path) -> str:
    """The agreement of each budget's rewards with the thesis author's, from benchmarks/figures/thesis_budget.py's rows."""
    import pandas as pd

    budget = _benchmark(root, "figures/thesis_budget")
    try:
        rows = pd.read_csv(root / THESIS_BUDGET)
    except OSError as exc:
        raise PluginError(f"cannot read {THESIS_BUDGET}: {exc}") from exc
    return budget.markdown(budget.table(rows))


def controllers_compare_rows(root: Path, names: tuple[str, ...] = CONTROLLERS_COMPARE) -> list[dict[str, Any]]:
    """The script's rows of every committed budget, in the order of ``names``."""
    rows: list[dict[str, Any]] = []
    for name in names:
        try:
            rows += json.loads((root / name).read_text())
        except OSError as exc:
            raise PluginError(f"cannot read {name}: {exc}") from exc
    return rows


def controllers_compare(root: Path) -> str:
    """Reward per body under each controller against per-body PPO, from the script's own rows."""
    return _benchmark(root, "figures/controllers_compare").markdown(controllers_compare_rows(root))


def controllers_generations(root: Path) -> str:
    """Whether each way's gain holds on both generations measured: the pinned rows and the unpinned ones."""
    rows = {"pinned": controllers_compare_rows(root), "unpinned": controllers_compare_rows(root, CONTROLLERS_UNPINNED)}
    return _benchmark(root, "figures/controllers_compare").generations_markdown(rows)


def controllers_speed(root: Path) -> str:
    """Each way's env steps per second, from the same rows."""
    return _benchmark(root, "figures/controllers_compare").speed_markdown(controllers_compare_rows(root))


def controllers_record(root: Path) -> str:
    """What each task's record has finished at each budget the script measures, for the tasks of the rows."""
    tasks = list(dict.fromkeys(row["task"] for row in controllers_compare_rows(root)))
    return _benchmark(root, "figures/controllers_compare").progress_markdown(root / CONTROLLERS_RECORD, tasks)


def controllers_codesign(root: Path) -> str:
    """The designers' best rewards per seed under each controller, from the co-design runs' evaluations."""
    import pandas as pd

    try:
        rows = pd.read_csv(root / CONTROLLERS_CODESIGN)
    except OSError as exc:
        raise PluginError(f"cannot read {CONTROLLERS_CODESIGN}: {exc}") from exc
    return _benchmark(root, "figures/controllers_compare").codesign_table(rows)


def thesis_budget_bodies(root: Path) -> str:
    """Every body of the sample: the author's reward and each budget's (mean over its training seeds)."""
    import pandas as pd

    rows = pd.read_csv(root / THESIS_BUDGET)
    wide = rows.pivot_table(index=["body", "author", "author_designer"], columns="budget", values="reward", aggfunc="mean")
    wide = wide.sort_index(level="author", ascending=False)
    budgets = list(wide.columns)
    lines = ["| body | designer (author) | author, 1e6 | " + " | ".join(f"{b:,}" for b in budgets) + " |",
             "|---|---|--:" + "|--:" * len(budgets) + "|"]
    for (body, author, designer), values in wide.iterrows():
        cells = " | ".join("" if pd.isna(v) else f"{v:.2f}" for v in values)
        lines.append(f"| `{body}` | {designer} | {author:.2f} | {cells} |")
    return "\n".join(lines)


def _reevaluations(root: Path) -> Any:
    from gdabench.results import load_reevaluations

    return load_reevaluations(root / PUBLISHED / "walker")


def walker_reevaluated(root: Path) -> str:
    """Per designer of the walker run: raw best against re-evaluated best, the drop and the noise per body."""
    from gdabench.stats.reevaluated import body_noise, pooled_sd, trial_scores

    again = _reevaluations(root)
    if again.empty:
        return "*(the walker run's re-evaluation is not committed yet)*"
    rows = _rows(root)
    trials = trial_scores(rows, again)
    bodies = body_noise(again)
    lines = ["| designer | trials | raw best: median | re-evaluated best: median | drop: median [min, max] "
             "| noise SD per body: pooled [min, max] | best body changed |", "|---|--:|--:|--:|--:|--:|--:|"]
    for designer, g in trials.groupby("designer", sort=False):
        mine = bodies[bodies["designer"] == designer]
        lines.append(
            f"| {designer} | {len(g)} | {g['raw_best'].median():.2f} | {g['reevaluated_best'].median():.2f} "
            f"| {g['drop'].median():+.2f} [{g['drop'].min():+.2f}, {g['drop'].max():+.2f}] "
            f"| {pooled_sd(mine):.2f} [{mine['sd'].min():.2f}, {mine['sd'].max():.2f}] "
            f"| {int((g['raw_body'] != g['reevaluated_body']).sum())}/{len(g)} |"
        )
    ranks = trials.groupby("designer", sort=False)[["raw_best", "reevaluated_best"]].mean()
    order = lambda c: ", ".join(ranks[c].sort_values(ascending=False).index)  # noqa: E731
    lines += ["", f"Ranking by the mean over seeds: raw {order('raw_best')}; re-evaluated {order('reevaluated_best')}. "
              f"All {len(bodies)} re-evaluated bodies: noise SD pooled {pooled_sd(bodies):.2f}, median drop of a "
              f"trial {trials['drop'].median():+.2f}."]
    return "\n".join(lines)


def walker_measures(root: Path) -> str:
    """Measures that do not saturate: evaluations to a reward (censored) and the mean best-so-far reward."""
    from gdabench.stats.core import median_interval
    from gdabench.stats.summary import per_run
    from gdabench.report.tables import number, with_interval

    rows = _rows(root)
    runs = per_run(rows)
    to = {t: per_run(rows, t).set_index(["designer", "seed"])["evals_to_threshold"] for t in WALKER_THRESHOLDS}
    header = ["designer", "seeds", "mean best-so-far: median [interval]"]
    header += [f"reached {t:g}: seeds, median evaluations [interval]" for t in WALKER_THRESHOLDS]
    lines = ["| " + " | ".join(header) + " |", "|---" + "|--:" * (len(header) - 1) + "|"]
    for designer, g in runs.groupby("designer", sort=False):
        auc = median_interval(g["mean_best_so_far"])
        cells = [designer, str(len(g)), with_interval(auc.median, auc.low, auc.high, level=auc.level)]
        for t in WALKER_THRESHOLDS:
            mine = to[t].loc[designer]
            reached = median_interval(mine.fillna(float("inf")))
            cells.append(f"{int(mine.notna().sum())}/{len(mine)}, "
                         + with_interval(reached.median, reached.low, reached.high, digits=4, level=reached.level))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines).replace(" inf", " not reached").replace("[not reached", "[" + number(float("inf")))


def walker_tests(root: Path) -> str:
    """The walker run's primary comparison and its exploratory pairs, on the re-evaluated best where the run has
    it, as the report tests them (its pairwise.csv)."""
    import pandas as pd

    tests = _read_walker("report/pairwise.csv", root, pd.read_csv)
    lines = ["| A | B | role | metric | pairs (non-tied) | median A - B | p | Holm p | A12 |",
             "|---|---|---|---|--:|--:|--:|--:|--:|"]
    for r in tests.itertuples():
        holm = "" if r.role == "primary" else f"{r.p_holm:.2g}"
        lines.append(f"| {r.designer_a} | {r.designer_b} | {r.role} | {r.metric} | {r.pairs} ({r.untied}) "
                     f"| {r.difference:+.2f} | {r.p:.2g} | {holm} | {r.a12:.2f} |")
    return "\n".join(lines)


def extras_table(root: Path) -> str:
    with open(root / "pyproject.toml", "rb") as fh:
        extras: dict[str, list[str]] = tomllib.load(fh)["project"].get("optional-dependencies", {})
    missing = sorted(set(extras) - set(EXTRAS))
    if missing:
        raise PluginError(f"pyproject.toml has extras the docs do not describe: {', '.join(missing)} (add them to EXTRAS in docs/hooks/gdabench_docs.py)")
    rows = [f"| `{name}` | {', '.join(f'`{_cell(r)}`' for r in reqs)} | {EXTRAS[name]} |" for name, reqs in extras.items()]
    return "\n".join(["| extra | installs | for |", "|---|---|---|", *rows])


def _prune(nav: list[Any], pending: set[str], docs_dir: Path) -> list[Any]:
    """Drop nav entries that point to a pending page not written yet (and sections left empty)."""
    kept: list[Any] = []
    for item in nav:
        value = next(iter(item.values())) if isinstance(item, dict) and len(item) == 1 else item
        if isinstance(value, list):
            value = _prune(value, pending, docs_dir)
            if not value:
                continue
            item = {next(iter(item)): value}
        elif isinstance(value, str) and value in pending and not (docs_dir / value).exists():
            continue
        kept.append(item)
    return kept


def on_config(config: Any) -> Any:
    pending = set(config["extra"].get("pending_pages", []))
    docs_dir = Path(config["docs_dir"])
    for page in sorted(pending):
        if (docs_dir / page).exists():
            log.warning(f"pending page {page} exists now: remove it from extra.pending_pages in mkdocs.yml")
    if config["nav"]:
        config["nav"] = _prune(config["nav"], pending, docs_dir)
    return config


def on_files(files: Files, config: Any) -> Files:
    root = _root(config)
    published = root / PUBLISHED
    if not published.is_dir():
        raise PluginError(f"{published} is missing: the docs show the committed reference runs")
    for path in sorted(published.rglob("*")):
        if path.is_file() and path.suffix != ".md":
            files.append(File.generated(config, path.relative_to(root).as_posix(), abs_src_path=str(path)))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Files) -> str:
    root = _root(config)
    generators: dict[str, Any] = {
        "columns": columns_table,
        "reference-summary": lambda run=None: reference_summary(root, run or "simple"),
        "thesis-walker": lambda: thesis_walker(root),
        "walker-bodies": lambda: walker_bodies(root),
        "walker-transfer": lambda: walker_transfer(root),
        "walker-claims": lambda run="walker": walker_claims(root, run),
        "walker-variants": lambda run="walker-thesis": walker_variants(root, run),
        "walker-reevaluated": lambda: walker_reevaluated(root),
        "walker-measures": lambda: walker_measures(root),
        "walker-tests": lambda: walker_tests(root),
        "thesis-budget": lambda: thesis_budget(root),
        "thesis-budget-bodies": lambda: thesis_budget_bodies(root),
        "controllers-compare": lambda: controllers_compare(root),
        "controllers-speed": lambda: controllers_speed(root),
        "controllers-record": lambda: controllers_record(root),
        "controllers-generations": lambda: controllers_generations(root),
        "controllers-codesign": lambda: controllers_codesign(root),
        "extras": lambda: extras_table(root),
        "evogym-tasks": evogym_tasks,
        "evogym-task-summary": lambda: evogym_task_summary(root),
        "evogym-task-misses": lambda: evogym_task_misses(root),
        "evogym-task-parity": lambda: evogym_task_parity(root),
        "evogym-task-control": lambda: evogym_task_control(root),
    }
    with_argument = {"reference-summary", "walker-claims", "walker-variants"}

    def expand(match: re.Match[str]) -> str:
        name, argument = match.groups()
        if name not in generators:
            raise PluginError(f"{page.file.src_uri}: unknown placeholder <!-- gdabench:{name} -->")
        if argument is None:
            return generators[name]()
        if name not in with_argument:
            raise PluginError(f"{page.file.src_uri}: <!-- gdabench:{name} --> takes no argument ({argument!r} given)")
        return generators[name](argument)

    return PLACEHOLDER.sub(expand, markdown)
