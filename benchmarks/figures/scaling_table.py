"""Designers on larger bodies: the tables and plot of docs/benchmarks/scaling-bodies.md.

The thesis (section 6.4) expects diffusion to scale better with the number of voxels than a GA.
This script runs each designer on bodies of several shapes (5x5, 8x8 and 12x12 by default) over
the environments ``target`` (its default target is the 5x5 walker scaled to the shape) and
``nk[k=4]`` (optimum computed exactly at these three shapes), with a budget and a population that
grow with the voxel count: by default 40 evaluations and 1 body per voxel, so a run has the same
number of generations at every shape (40 for designers that evaluate a whole population each
generation): 25 x 40 = 1,000 evaluations at 5x5, 64 x 40 = 2,560 at 8x8, 144 x 40 = 5,760 at 12x12.

One suite run per (designer, shape), ``<root>/<HxW>/<designer>``, unless a complete one exists; an
interrupted run is resumed. Designers and shapes can be added later, and seeds too: the seeds no run
holds yet are added to the designer's run (``suite_runs.py``).  Then it prints, as markdown:

* the normalised gap to the optimum, ``(optimum - best) / optimum`` (0: optimum found), median and
  interquartile range over seeds, per environment, shape and designer;
* each designer against ``--baseline`` (the GA) at each shape: Wilcoxon's signed-rank test on the
  per-seed gaps, paired by seed (a seed fixes a run's first generation: ga, gda, gda-fast and
  random start from the same bodies), Holm-corrected over each designer's comparisons, and
  Vargha-Delaney's A12 = P(designer's gap < baseline's gap);
* whether the designer's lead over the baseline changes from the smallest shape to each larger one
  (Wilcoxon on the per-seed differences of gaps, the larger shape against the smallest);
* time per generation (designer time, and gda's training and sampling seconds) at each shape.

``--plot`` saves the gap against the number of voxels, one panel per environment; ``--csv``
saves the gap table.

    nice -n 10 python benchmarks/figures/scaling_table.py --designers ga,cppn,random
    nice -n 10 python benchmarks/figures/scaling_table.py --designers gda-fast --seeds 0..2
    python benchmarks/figures/scaling_table.py --designers ga,cppn,random,gda-fast --no-run --plot scaling.png

Each run is ``gdabench compare -d DESIGNER --env target,nk[k=4] --shape HxW --population P
--budget B --seeds 0..9 --out <root>/HxW/DESIGNER``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd
from suite_runs import ensure_runs, run_dirs, stopped

from gdabench import Experiment, PluginChoice, RunDirectory
from gdabench.body import parse_shape
from gdabench.errors import ConfigError, GdabenchError
from gdabench.execution.options import Execution
from gdabench.experiment.config import parse_seeds
from gdabench.experiment.plan import Plan, file_name
from gdabench.report.pairwise import a12, holm, magnitude, test_pair
from gdabench.stats.summary import per_run, thresholds

DEFAULT_ENVS = "target,nk[k=4]"
DEFAULT_SIZES = "5x5,8x8,12x12"


def shape_text(shape: tuple[int, int]) -> str:
    return f"{shape[0]}x{shape[1]}"


def scaled(shape: tuple[int, int], evals_per_voxel: int, bodies_per_voxel: float) -> tuple[int, int]:
    """(population, budget) for bodies of ``shape``: both proportional to the voxel count."""
    voxels = shape[0] * shape[1]
    population = max(2, round(voxels * bodies_per_voxel))
    return population, max(population, voxels * evals_per_voxel)


def optima(run: RunDirectory) -> dict[str, tuple[float | None, str]]:
    """Each environment's optimum as the run recorded it, else its upper bound when it has one:
    (value, 'optimum' | 'upper bound' | 'unknown')."""
    known = thresholds(run.meta)
    out: dict[str, tuple[float | None, str]] = {}
    missing = [label for label, value in known.items() if value is None]  # type: ignore[union-attr]
    bounds: dict[str, float | None] = {}
    if missing:
        plan = Plan.resolve(Experiment.from_json(run.meta["config"]), designers=False)
        for recipe in plan.envs:
            bounds[recipe.label] = getattr(plan.scorers(recipe.label)[0], "upper_bound", None)
    for label, value in known.items():  # type: ignore[union-attr]
        if value is not None:
            out[label] = (float(value), "optimum")
        elif bounds.get(label) is not None:
            out[label] = (float(bounds[label]), "upper bound")  # type: ignore[arg-type]
        else:
            out[label] = (None, "unknown")
    return out


def seed_rows(out: Path, shape: tuple[int, int]) -> pd.DataFrame:
    """One row per (env, designer, seed) of a run directory: best reward, gap, times per generation."""
    run = RunDirectory.open(out)
    evaluations = run.load_evaluations()
    if evaluations.empty:
        return pd.DataFrame()
    best = optima(run)
    rows = per_run(evaluations, None)
    timing = []
    for (env, designer, seed), g in evaluations.groupby(["env", "designer", "seed"], sort=False):
        gens = g.groupby("generation").first()
        later = gens[gens.index >= 1]  # generation 0 is the random sampler for most designers
        timing.append(
            {
                "env": env,
                "designer": designer,
                "seed": seed,
                "design_s_per_gen": float(later["design_seconds"].median())
                if "design_seconds" in later and len(later)
                else math.nan,
                "train_s_per_gen": float(later["train_seconds"].median())
                if "train_seconds" in later and later["train_seconds"].notna().any()
                else math.nan,
                "sample_s_per_gen": float(later["sample_seconds"].median())
                if "sample_seconds" in later and later["sample_seconds"].notna().any()
                else math.nan,
                "wall_s": float(g["elapsed_seconds"].max()),
                "generations": int(len(gens)),
                "finished": int(g["n_evals"].max()) >= int(run.meta["config"]["budget"]),
            }
        )
    rows = rows.merge(pd.DataFrame(timing), on=["env", "designer", "seed"], how="left")
    rows["optimum"] = rows["env"].map(lambda e: best.get(e, (None, "unknown"))[0])
    rows["optimum_kind"] = rows["env"].map(lambda e: best.get(e, (None, "unknown"))[1])
    rows["gap"] = (rows["optimum"].astype(float) - rows["best_reward"]) / rows["optimum"].astype(float)
    rows["shape"] = shape_text(shape)
    rows["voxels"] = shape[0] * shape[1]
    rows["population"] = run.meta["config"]["population"]
    rows["budget"] = run.meta["config"]["budget"]
    rows["status"] = run.meta.get("status")
    return rows


def collect(
    root: Path, designers: Sequence[PluginChoice], shapes: Sequence[tuple[int, int]], envs: Sequence[PluginChoice]
) -> pd.DataFrame:
    """Per-seed rows of every finished trial of the existing runs, environments in the order given."""
    frames = []
    for shape in shapes:
        for d in designers:
            frames.extend(seed_rows(out, shape) for out in run_dirs(root / shape_text(shape) / file_name(d.label)))
    frames = [f for f in frames if not f.empty]
    if not frames:
        return pd.DataFrame()
    rows = pd.concat(frames, ignore_index=True)
    unfinished = rows[~rows["finished"].astype(bool)]
    for _, r in unfinished.iterrows():  # a trial cut short would flatter nobody's gap: left out, said
        print(
            f"note: {r['designer']} at {r['shape']} on {r['env']} seed {r['seed']} is unfinished; left out",
            file=sys.stderr,
        )
    rows = rows[rows["finished"].astype(bool)]
    return rows[rows["env"].isin([e.label for e in envs])]


def fmt(value: float, digits: int = 3) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


def gap_table(rows: pd.DataFrame, envs: Sequence[PluginChoice], designers: Sequence[PluginChoice]) -> pd.DataFrame:
    """Median and quartiles of the gap per (env, shape, designer)."""
    out = []
    for env in [e.label for e in envs]:
        for (voxels, shape), by_shape in rows[rows["env"] == env].groupby(["voxels", "shape"], sort=True):
            for d in [d.label for d in designers]:
                g = by_shape[by_shape["designer"] == d]
                if g.empty:
                    continue
                q1, med, q3 = np.percentile(g["gap"], [25, 50, 75])
                out.append(
                    {
                        "env": env,
                        "shape": shape,
                        "voxels": voxels,
                        "population": int(g["population"].iloc[0]),
                        "budget": int(g["budget"].iloc[0]),
                        "optimum": float(g["optimum"].iloc[0]),
                        "optimum_kind": g["optimum_kind"].iloc[0],
                        "designer": d,
                        "seeds": len(g),
                        "seed_list": ",".join(str(s) for s in sorted(g["seed"])),
                        "gap_median": med,
                        "gap_q1": q1,
                        "gap_q3": q3,
                        "best_median": float(g["best_reward"].median()),
                        "wall_s_median": float(g["wall_s"].median()),
                        "status": "complete" if (g["status"] == "complete").all() else "incomplete",
                    }
                )
    return pd.DataFrame(out)


def gap_markdown(table: pd.DataFrame) -> str:
    lines = [
        "| env | shape (voxels) | population, budget | optimum | designer | seeds | gap: median (IQR) | best "
        "reward (median) | wall s per seed (median) |",
        "|---|---|---|---:|---|---:|---:|---:|---:|",
    ]
    for _, r in table.iterrows():
        bound = "" if r["optimum_kind"] == "optimum" else f" ({r['optimum_kind']})"
        note = "" if r["status"] == "complete" else " (incomplete)"
        lines.append(
            f"| {r['env']} | {r['shape']} ({r['voxels']}) | {r['population']}, {r['budget']:,} | "
            f"{r['optimum']:.2f}{bound} | "
            f"{r['designer']}{note} | {r['seeds']} | {fmt(r['gap_median'])} ({fmt(r['gap_q1'])}-{fmt(r['gap_q3'])}) | "
            f"{r['best_median']:.2f} | {r['wall_s_median']:.1f} |"
        )
    return "\n".join(lines)


def paired(rows: pd.DataFrame, env: str, shape: str, a: str, b: str) -> pd.DataFrame:
    """Per-seed gaps of designers ``a`` and ``b`` on the seeds both ran (columns a, b)."""
    sel = rows[(rows["env"] == env) & (rows["shape"] == shape)]
    wide = sel.pivot_table(index="seed", columns="designer", values="gap")
    if a not in wide or b not in wide:
        return pd.DataFrame(columns=[a, b])
    return wide[[a, b]].dropna()


def comparisons(
    rows: pd.DataFrame,
    envs: Sequence[PluginChoice],
    designers: Sequence[PluginChoice],
    baseline: str,
    alpha: float = 0.05,
) -> pd.DataFrame:
    """Each designer against the baseline per (env, shape), and the change of that difference
    from the smallest shape to each larger one; Holm over each designer's rows."""
    shapes = [s for _, s in sorted({(v, s) for v, s in zip(rows["voxels"], rows["shape"])})]
    out = []
    for env in [e.label for e in envs]:
        for d in [d.label for d in designers if d.label != baseline]:
            for shape in shapes:
                pair = paired(rows, env, shape, d, baseline)
                if len(pair) == 0:
                    continue
                name, stat, p = test_pair(pair[d], pair[baseline], paired=True)
                out.append(
                    {
                        "env": env,
                        "designer": d,
                        "what": shape,
                        "pairs": len(pair),
                        "test": name,
                        "difference": float((pair[d] - pair[baseline]).median()),
                        "p": p,
                        "a12": a12(-pair[d], -pair[baseline]),  # P(designer's gap < baseline's)
                    }
                )
            small = paired(rows, env, shapes[0], d, baseline)
            for shape in shapes[1:]:
                large = paired(rows, env, shape, d, baseline)
                common = small.index.intersection(large.index)
                if len(common):
                    lead_small = small.loc[common, d] - small.loc[common, baseline]
                    lead_large = large.loc[common, d] - large.loc[common, baseline]
                    name, stat, p = test_pair(lead_large, lead_small, paired=True)
                    out.append(
                        {
                            "env": env,
                            "designer": d,
                            "what": f"{shape} vs {shapes[0]}",
                            "pairs": len(common),
                            "test": name,
                            "difference": float((lead_large - lead_small).median()),
                            "p": p,
                            "a12": a12(-lead_large, -lead_small),  # P(the gap difference is smaller at the large shape)
                        }
                    )
    table = pd.DataFrame(out)
    if not table.empty:  # one family per designer: its rows answer "does it scale better than the baseline?"
        table["p_holm"] = table.groupby("designer", sort=False)["p"].transform(lambda p: holm(p.to_numpy()))
        table["magnitude"] = table["a12"].map(magnitude)
        table["significant"] = table["p_holm"] < alpha
    return table


def comparison_markdown(table: pd.DataFrame, baseline: str) -> str:
    lines = [
        f"| env | designer | shape | seeds paired | gap difference to {baseline} (median) | Wilcoxon p | "
        "Holm p | A12 | |",
        "|---|---|---|---:|---:|---:|---:|---:|---|",
    ]
    for _, r in table.iterrows():
        lines.append(
            f"| {r['env']} | {r['designer']} | {r['what']} | {r['pairs']} | {r['difference']:+.3f} | "
            f"{fmt(r['p'])} | {fmt(r['p_holm'])} | "
            f"{fmt(r['a12'], 2)} | {r['magnitude']}{', significant' if r['significant'] else ''} |"
        )
    return "\n".join(lines)


def time_table(rows: pd.DataFrame, designers: Sequence[PluginChoice]) -> pd.DataFrame:
    out = []
    for (voxels, shape), g in rows.groupby(["voxels", "shape"], sort=True):
        for d in [d.label for d in designers]:
            sel = g[g["designer"] == d]
            if sel.empty:
                continue
            out.append(
                {
                    "designer": d,
                    "shape": shape,
                    "voxels": voxels,
                    "trials": len(sel),
                    "design_s_per_gen": float(sel["design_s_per_gen"].median()),
                    "train_s_per_gen": float(sel["train_s_per_gen"].median()),
                    "sample_s_per_gen": float(sel["sample_s_per_gen"].median()),
                    "wall_s": float(sel["wall_s"].median()),
                    "generations": float(sel["generations"].median()),
                }
            )
    return pd.DataFrame(out).sort_values(
        ["designer", "voxels"],
        kind="stable",
        key=lambda c: c.map({d.label: i for i, d in enumerate(designers)}) if c.name == "designer" else c,
    )


def time_markdown(table: pd.DataFrame) -> str:
    lines = [
        "| designer | shape | trials | generations | designer s per generation | gda: training s | gda: "
        "sampling s | wall s per trial |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for _, r in table.iterrows():
        lines.append(
            f"| {r['designer']} | {r['shape']} | {r['trials']} | {r['generations']:.0f} | "
            f"{fmt(r['design_s_per_gen'], 3)} | {fmt(r['train_s_per_gen'], 2)} | "
            f"{fmt(r['sample_s_per_gen'], 2)} | {r['wall_s']:.1f} |"
        )
    return "\n".join(lines)


def plot(
    table: pd.DataFrame,
    envs: Sequence[PluginChoice],
    designers: Sequence[PluginChoice],
    path: Path,
    evals_per_voxel: int,
) -> None:
    """Gap against voxels per designer (median with the interquartile range), a panel per env."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [e.label for e in envs if e.label in set(table["env"])]
    fig, axes = plt.subplots(1, len(labels), figsize=(5.2 * len(labels), 4.2), squeeze=False)
    for ax, env in zip(axes[0], labels):
        sel = table[table["env"] == env]
        for d in [d.label for d in designers]:
            g = sel[sel["designer"] == d].sort_values("voxels")
            if g.empty:
                continue
            seeds = g["seeds"].tolist()  # per shape, smallest first: "seeds 10, 10, 1" reads as what ran where
            name = d if set(seeds) == {10} else f"{d} (seeds {', '.join(str(s) for s in seeds)})"
            line = ax.plot(g["voxels"], g["gap_median"], marker="o", label=name)[0]
            ax.fill_between(g["voxels"], g["gap_q1"], g["gap_q3"], color=line.get_color(), alpha=0.15)
        ax.set_xscale("log")
        ticks = sorted(set(sel["voxels"]))
        ax.set_xticks(ticks, [f"{s} ({v})" for v, s in sorted(set(zip(sel["voxels"], sel["shape"])))])
        ax.minorticks_off()
        ax.set_xlabel("body shape (voxels)")
        ax.set_ylabel("gap to the optimum, (optimum - best) / optimum")
        ax.set_ylim(bottom=0)
        ax.set_title(env)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(
        f"Median gap over seeds (band: interquartile range); budget {evals_per_voxel} evaluations per voxel",
        fontsize=10,
    )
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--designers", default="ga,cppn,random,gda-fast", help="comma-separated designers (labels may carry [params])"
    )
    parser.add_argument("--envs", default=DEFAULT_ENVS, help=f"comma-separated environments (default {DEFAULT_ENVS})")
    parser.add_argument(
        "--shapes", default=DEFAULT_SIZES, help=f"comma-separated body shapes HxW (default {DEFAULT_SIZES})"
    )
    parser.add_argument("--seeds", default="0..9")
    parser.add_argument("--evals-per-voxel", type=int, default=40, help="budget = voxels x this (default 40)")
    parser.add_argument(
        "--bodies-per-voxel", type=float, default=1.0, help="population = voxels x this (default 1: 40 generations)"
    )
    parser.add_argument("--baseline", default="ga", help="designer the others are tested against (default ga)")
    parser.add_argument("--jobs", type=int, default=None, help="trials at once (default: the harness's, one per core)")
    parser.add_argument("--root", type=Path, default=Path("results/scaling"), help="where the run directories live")
    parser.add_argument("--plot", type=Path, default=None, help="save the gap-against-voxels plot here (PNG)")
    parser.add_argument("--csv", type=Path, default=None, help="save the gap table here")
    parser.add_argument("--no-run", action="store_true", help="only read existing runs and print the tables")
    args = parser.parse_args(argv)
    try:
        designers = PluginChoice.parse_list(args.designers)
        envs = PluginChoice.parse_list(args.envs)
        shapes = [parse_shape(s.strip()) for s in args.shapes.split(",") if s.strip()]
        if not shapes:
            raise ConfigError("no shape given")
        if args.evals_per_voxel < 1 or not args.bodies_per_voxel > 0:
            raise ConfigError("--evals-per-voxel and --bodies-per-voxel must be positive")
        seeds = tuple(parse_seeds(args.seeds))
        if not args.no_run:
            execution = Execution(jobs=args.jobs)
            runs = []
            for shape in shapes:
                population, budget = scaled(shape, args.evals_per_voxel, args.bodies_per_voxel)
                for d in designers:
                    experiment = Experiment(
                        (d,), tuple(envs), shape=shape, population=population, budget=budget, seeds=seeds
                    )
                    Plan.resolve(experiment)  # check every name and parameter before spending time on runs
                    runs.append((args.root / shape_text(shape) / file_name(d.label), experiment))
            for out, experiment in runs:
                ensure_runs(
                    out, experiment, execution, f"{experiment.designers[0].label} at {shape_text(experiment.shape)}"
                )
        rows = collect(args.root, designers, shapes, envs)
    except (GdabenchError, KeyboardInterrupt) as exc:
        return stopped(exc)
    if rows.empty:
        print(f"error: no runs under {args.root} for these designers and shapes", file=sys.stderr)
        return 2
    table = gap_table(rows, envs, designers)
    print("### Gap to the optimum\n")
    print(gap_markdown(table))
    if args.baseline in set(rows["designer"]):
        tests = comparisons(rows, envs, designers, args.baseline)
        if not tests.empty:
            print(f"\n### Against {args.baseline}, paired by seed\n")
            print(
                f"Difference: designer's gap minus {args.baseline}'s (negative: closer to the optimum). A12: "
                "the chance that the "
                "designer's gap is the smaller (0.5: no effect); on the 'large vs small' rows, that its "
                f"difference to {args.baseline} "
                "is smaller at the large shape. Holm over each designer's rows.\n"
            )
            print(comparison_markdown(tests, args.baseline))
    print("\n### Time per generation\n")
    print(time_markdown(time_table(rows, designers)))
    if args.csv:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        table.drop(columns=["status"]).to_csv(args.csv, index=False, float_format="%.6g")
    if args.plot:
        plot(table, envs, designers, args.plot, args.evals_per_voxel)
    return 0


if __name__ == "__main__":
    sys.exit(main())
