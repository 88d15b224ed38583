"""Controllers that learn many bodies at once against per-body PPO, on a real designer generation (issue 56).

For each task of ``--tasks`` and each per-body budget T of ``--budgets`` (timesteps per body):

1. a designer (``--designer``, default ``ga``) proposes generation 0 (``--population`` bodies), which
   ``ppo[init=parent]`` trains from scratch at T (so the policies children inherit are kept), and is told
   the rewards; it then proposes generation 1, naming each child's parents;
2. generation 1 is trained four ways, each child with the same env steps T:
   ``scratch``: per-body ``ppo`` (Evolution Gym's, the thesis's);
   ``parent``: ``ppo[init=parent]``, each child from its nearest parent's policy;
   ``modular``: ``modular-ppo``, one shared policy on ModularEvoGym's per-voxel observations, learnt by
   generation 0's bodies together and carried on to generation 1's;
   and ``scratch`` at 4T, the reference ranking;
3. prints per task and budget: each way's median child reward and the median paired difference against
   ``scratch``, with Wilcoxon's signed-rank p-value of the pairs; each way's Spearman rank correlation with
   ``scratch`` at 4T, and how many of the 4T top 5 its top 5 holds (the survivors a designer would keep); its
   env steps per second in this process's CPU time (one torch and one engine thread: what a core gives it,
   whatever else runs beside it).

Policies are saved under ``--out`` (one folder per task, budget and way): a rerun replays what is there, so
an interrupted measurement resumes.  One process, one torch thread: run it on a quiet machine, or beside a
known load and say so.  ``--json`` writes every row.

A measurement can be spread over processes, and over machines that share nothing but a small file: each
task and budget keeps a record (``--record DIR``: ``DIR/<task>-<budget>.json``; by default beside the
policies) of generation 0's rewards and of every finished way's rewards and env steps per second.
``--ways`` runs only some ways (each for the children no part has recorded, in one lockstep batch) and
``--part K/N`` only every N-th child from the K-th (not ``modular``, whose shared policy learns from all of
them); a way that needs generation 0 trained (``parent``) trains it again, and must find the recorded
rewards.  A row is printed once every way of every child is recorded.

``--codesign RUN,RUN,...`` instead reads finished ``gdabench compare`` runs of the same designers under
different controllers (the co-design half of the issue's item 3), writes their evaluations to ``--csv`` and
prints each designer's best reward per seed under each controller.

Usage::

    python benchmarks/figures/controllers_compare.py --out /tmp/controllers --budgets 12500,50000,200000
    python benchmarks/figures/controllers_compare.py --out /tmp/controllers --tasks Walker-v0,BridgeWalker-v0,Climber-v0
    python benchmarks/figures/controllers_compare.py --out /tmp/smoke --budgets 128 --population 3   # a smoke test
    python benchmarks/figures/controllers_compare.py --out /tmp/c --budgets 200000 --ways scratch4x --part 0/2 \
        --record docs/benchmarks/output/controllers-record   # half of one way, recorded where a commit keeps it
    python benchmarks/figures/controllers_compare.py --codesign runs/ppo,runs/parent,runs/modular --csv codesign.csv
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import statistics
import time
from pathlib import Path
from typing import Any, Iterator

import gdabench  # noqa: F401 - before torch: it pins torch's CPU kernels to AVX2 (gdabench.cpu)

WAYS = ("scratch", "parent", "modular")
#: every way a measurement trains: ``WAYS`` and the reference at 4T
TRAINED = (*WAYS, "scratch4x")
TOP = 5
#: the per-body budgets the issue asks for
BUDGETS = (12_500, 50_000, 200_000)


class Record:
    """What the measurement of one task and budget has finished, in a small JSON file: generation 0's rewards
    and, per way and part, each child's reward and the part's env steps per second.  Processes that share it
    each add their own parts: every change reads the file again and writes it under a lock (``.<name>.lock``
    beside it), so none loses what another added since it last read."""

    def __init__(self, path: Path):
        self.path = path
        self.data: dict[str, Any] = self._read()

    def _read(self) -> dict[str, Any]:
        return json.loads(self.path.read_text()) if self.path.exists() else {"ways": {}}

    def reload(self) -> None:
        self.data = self._read()

    @contextlib.contextmanager
    def _change(self) -> Iterator[dict[str, Any]]:
        from filelock import FileLock

        self.path.parent.mkdir(parents=True, exist_ok=True)
        with FileLock(self.path.with_name(f".{self.path.name}.lock")):
            self.reload()
            yield self.data
            tmp = self.path.with_suffix(".tmp")
            tmp.write_text(json.dumps(self.data, indent=1) + "\n")
            tmp.replace(self.path)

    def first(self, rewards: list[float]) -> list[float]:
        """Generation 0's recorded rewards: ``rewards`` where none are recorded yet."""
        with self._change() as data:
            return data.setdefault("first", rewards)

    def note_children(self, hashes: list[str]) -> None:
        """Name generation 1's children, so that a record some ways lack says how many are still to train."""
        if self.data.get("children") != hashes:
            with self._change() as data:
                data.setdefault("children", hashes)

    def add(self, way: str, part: str, hashes: list[str], rewards: list[float], speed: float) -> None:
        """Record children of a part (joining those the part recorded before, its speed weighted by children)."""
        with self._change() as data:
            parts = data["ways"].setdefault(way, {})
            old = parts.get(part, {"rewards": {}, "steps_per_second": 0.0})
            n, m = len(old["rewards"]), len(hashes)
            parts[part] = {
                "rewards": {**old["rewards"], **dict(zip(hashes, rewards))},
                "steps_per_second": (old["steps_per_second"] * n + speed * m) / (n + m),
            }

    def rewards(self, way: str, hashes: list[str]) -> list[float] | None:
        """The way's rewards of ``hashes`` in that order; None while a child is missing."""
        found = self._recorded(way)
        return [found[h] for h in hashes] if all(h in found for h in hashes) else None

    def speed(self, way: str) -> float:
        """The way's env steps per second, its parts weighted by their children."""
        parts = list(self.data["ways"].get(way, {}).values())
        n = sum(len(p["rewards"]) for p in parts)
        return sum(p["steps_per_second"] * len(p["rewards"]) for p in parts) / n if n else float("nan")

    def _recorded(self, way: str) -> dict[str, float]:
        """The way's reward per child, over all its parts."""
        return {h: r for part in self.data["ways"].get(way, {}).values() for h, r in part["rewards"].items()}

    def done(self) -> dict[str, int]:
        """How many children each way has recorded."""
        return {way: len(self._recorded(way)) for way in TRAINED}

    def children(self) -> list[str]:
        """Generation 1's children: named by the process that proposed them (records older than that name them
        in the ways that finished)."""
        recorded = {h for way in self.data["ways"].values() for part in way.values() for h in part["rewards"]}
        return self.data.get("children", sorted(recorded))


def spearman(a: list[float], b: list[float]) -> float:
    from scipy.stats import spearmanr

    return float(spearmanr(a, b).statistic) if len(a) > 2 else float("nan")


def paired_p(a: list[float], b: list[float]) -> float:
    """Wilcoxon's signed-rank p-value of the paired differences (two-sided); nan where there are none."""
    from scipy.stats import wilcoxon

    if len(a) < 2 or all(x == y for x, y in zip(a, b)):
        return float("nan")
    return float(wilcoxon(a, b).pvalue)


def top_overlap(a: list[float], b: list[float], k: int = TOP) -> int:
    def best(r: list[float]) -> set[int]:
        return set(sorted(range(len(r)), key=lambda i: -r[i])[:k])

    return len(best(a) & best(b))


def evaluate_rewards(
    controller: Any, env: Any, bodies: list, seeds: list[int], workdirs: list[Path], parents: list | None = None
) -> tuple[list[float], float]:
    """Rewards of ``bodies`` under ``controller`` (saved policies replayed) and the env steps per second."""
    batch = env.bodies(bodies)
    if parents is not None:
        batch = dataclasses.replace(batch, parents=parents)
    start = time.process_time()
    results = controller.evaluate_bodies(batch, seeds=seeds, workdirs=workdirs)
    seconds = time.process_time() - start
    for r in results:
        if isinstance(r, BaseException):
            raise r
    steps = sum(r.info.get("env_steps", 0) for r in results)
    # a rerun replays the policies (modular-ppo's with their training's columns): keep this call's first speed
    speed_file = workdirs[0].parent / f"speed-{bodies[0].hash}.json"
    if steps and not speed_file.exists():
        speed_file.write_text(json.dumps({"steps_per_second": steps / seconds}))
    speed = json.loads(speed_file.read_text())["steps_per_second"] if speed_file.exists() else float("nan")
    return [r.reward for r in results], speed


def ppo_rewards(
    env: Any, bodies: list, seeds: list[int], workdirs: list[Path], parents: list | None = None, **params: Any
) -> tuple[list[float], float]:
    """Rewards of ``bodies`` under ``ppo[**params]`` and its env steps per second."""
    from gdabench.controllers.ppo import PPO

    return evaluate_rewards(PPO(**params), env, bodies, seeds, workdirs, parents)


def modular_rewards(
    env: Any, generations: list[list], seeds: list[list[int]], timesteps: int, folder: Path
) -> tuple[list[float], float]:
    """The last generation's rewards under ``modular-ppo``: one shared policy learnt by each generation in turn
    (carried on in ``folder``, as in a trial's folder), and the last generation's env steps per second."""
    from gdabench.controllers.modular.controller import ModularPPO

    controller = ModularPPO(timesteps=timesteps)
    out: tuple[list[float], float] = ([], float("nan"))
    for bodies, body_seeds in zip(generations, seeds):
        out = evaluate_rewards(controller, env, bodies, body_seeds, [folder / b.hash for b in bodies])
    return out


def measure(task: str, budget: int, args: argparse.Namespace) -> dict[str, Any] | None:
    """Train what ``args.ways`` and ``args.part`` ask of this task and budget that is not recorded yet; the row
    once every way of every child is recorded, else None."""
    from gdabench import make_designer, seeding
    from gdabench.envs.voxel.env import VoxelTask

    env = VoxelTask(task=task)
    out = args.out / task / str(budget)
    record = Record(args.record / f"{task}-{budget}.json" if args.record else out / "record.json")
    part, (k, n) = args.part, args.every
    designer = make_designer(
        args.designer, seed=args.seed, shape=(5, 5), population=args.population, budget=2 * args.population
    )
    first = designer.ask()
    first_seeds = [seeding.evaluation_seed(args.seed, b.hash) for b in first]
    first_dirs = [out / "parent" / b.hash for b in first]

    def train_first() -> None:
        """Generation 0 trained (its policies are what ``parent``'s children start from), checked against the
        record's rewards, or recorded where there are none yet."""
        got, _ = ppo_rewards(env, first, first_seeds, first_dirs, timesteps=budget, init="parent")
        if record.first(got) != got:
            raise SystemExit(f"error: {task} at {budget}: generation 0 trained to other rewards than {record.path}")

    trained_first = "first" not in record.data
    if trained_first:
        train_first()
    designer.tell(first, record.data["first"])
    children = designer.ask()
    record.note_children([b.hash for b in children])
    told = {b.hash for b in first}
    parents = [
        tuple(out / "parent" / p.hash for p in ps if p.hash in told)
        for ps in (designer.proposal_parents() or [()] * len(children))
    ]
    seeds = [seeding.evaluation_seed(args.seed, b.hash) for b in children]
    # a way trains only the children of this part that no part has recorded: what a cut or split measurement
    # left trains as one lockstep batch (a batch of 5 trained at about half the env steps/s of one of 17)
    mine = range(k, len(children), n)
    todo = {
        way: [i for i in (range(len(children)) if way == "modular" else mine)
              if record.rewards(way, [children[i].hash]) is None]
        for way in TRAINED if way in args.ways
    }  # fmt: skip
    todo = {way: lacking for way, lacking in todo.items() if lacking}
    if "parent" in todo and not trained_first:
        train_first()
    for way, lacking in todo.items():
        if way == "modular":
            lacking = list(range(len(children)))  # the shared policy learns from every child
            got, speed = modular_rewards(env, [first, children], [first_seeds, seeds], budget, out / "modular")
        else:
            init = {"init": "parent"} if way == "parent" else {}
            got, speed = ppo_rewards(
                env, [children[i] for i in lacking], [seeds[i] for i in lacking],
                [out / way / children[i].hash for i in lacking],
                [parents[i] for i in lacking] if way == "parent" else None,
                timesteps=4 * budget if way == "scratch4x" else budget, **init,
            )  # fmt: skip
        record.add(way, part, [children[i].hash for i in lacking], got, speed)
    record.reload()  # with what processes beside this one added
    hashes = [b.hash for b in children]
    found = {way: record.rewards(way, hashes) for way in TRAINED}
    missing = [way for way, r in found.items() if r is None]
    if missing:
        print(f"{task} at {budget}: recorded in {record.path}; not yet every child of: {', '.join(missing)}")
        return None
    rewards = {way: r for way, r in found.items() if r is not None}
    reference = rewards["scratch4x"]
    row: dict[str, Any] = {"task": task, "budget": budget, "designer": args.designer, "children": len(children)}
    row["with_parent"] = sum(1 for p in parents if p)
    for way in WAYS:
        r = rewards[way]
        row[f"{way}_median"] = statistics.median(r)
        row[f"{way}_minus_scratch"] = statistics.median(a - b for a, b in zip(r, rewards["scratch"]))
        row[f"{way}_wilcoxon_p"] = paired_p(r, rewards["scratch"])
        row[f"{way}_spearman_4x"] = spearman(r, reference)
        row[f"{way}_top{TOP}_of_4x"] = top_overlap(r, reference)
    for way in TRAINED:
        row[f"{way}_steps_per_s"] = record.speed(way)
    row["rewards"] = rewards
    return row


def show(rows: list[dict[str, Any]]) -> None:
    print(
        f"{'task':<18}{'T':>8}  {'way':<8}{'median':>8}{'- scratch':>10}{'p':>8}{'rho 4x':>8}{f'top{TOP}':>6}"
        f"{'steps/s':>9}"
    )
    for row in rows:
        for way in WAYS:
            print(
                f"{row['task']:<18}{row['budget']:>8}  {way:<8}{row[f'{way}_median']:>8.3f}"
                f"{row[f'{way}_minus_scratch']:>10.3f}{row[f'{way}_wilcoxon_p']:>8.2g}{row[f'{way}_spearman_4x']:>8.2f}"
                f"{row[f'{way}_top{TOP}_of_4x']:>6}{row[f'{way}_steps_per_s']:>9.0f}"
            )


def speed_markdown(rows: list[dict[str, Any]]) -> str:
    """Each way's env steps per second, per task and budget, and its ratio to ``scratch``'s."""
    lines = ["| task | T | `scratch` | `parent` | `modular` | `scratch` at 4T |", "|---|--:|--:|--:|--:|--:|"]
    for row in rows:
        base = row["scratch_steps_per_s"]
        cells = [f"{base:,.0f}"] + [
            f"{row[f'{way}_steps_per_s']:,.0f} ({row[f'{way}_steps_per_s'] / base:.2f}x)" for way in TRAINED[1:]
        ]
        lines.append(f"| {row['task']} | {row['budget']:,} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def versus(rewards: list[float], scratch: list[float]) -> str:
    """How many children end higher than from scratch, with Wilcoxon's p of the pairs ("worse" where fewer than
    half do, at p < 0.05)."""
    better, p = sum(a > b for a, b in zip(rewards, scratch)), paired_p(rewards, scratch)
    worse = ", worse" if 2 * better < len(rewards) and p < 0.05 else ""
    return f"{better} / {len(rewards)} (p {p:.2g}{worse})"


def generations_markdown(generations: dict[str, list[dict[str, Any]]]) -> str:
    """Per task and budget, how many children each way ends higher than ``scratch`` (and Wilcoxon's p of the
    pairs) in each of several measurements' generations (``{label: rows}``): whether a finding holds beyond
    one generation's draw."""
    labels = list(generations)
    found = {label: {(r["task"], r["budget"]): r for r in rows} for label, rows in generations.items()}
    keys = list(dict.fromkeys(k for rows in found.values() for k in rows))
    ways = [w for w in WAYS if w != "scratch"]
    head = " | ".join(f"`{way}` better than `scratch`: {', '.join(labels)}" for way in ways)
    lines = [f"| task, T | {head} |", "|---" * (len(ways) + 1) + "|"]
    for task, budget in keys:
        cells = []
        for way in ways:
            said = []
            for label in labels:
                row = found[label].get((task, budget))
                if row is None:
                    said.append("not run")
                    continue
                said.append(versus(row["rewards"][way], row["rewards"]["scratch"]))
            cells.append(", ".join(said))
        lines.append(f"| {task}, {budget:,} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def progress_markdown(folder: Path, tasks: list[str], budgets: tuple[int, ...] = BUDGETS) -> str:
    """What the records in ``folder`` have finished, per task and budget: whether generation 0 is trained and
    how many children each way has recorded (the state of a measurement that runs in pieces), and, until the
    row is printed, how a way with every child recorded compares with ``scratch``."""
    head = " | ".join(f"`{w}`" for w in WAYS) + " | `scratch` at 4T | " + " | ".join(
        f"`{w}` better than `scratch`" for w in WAYS[1:]
    )
    lines = [f"| task | T | generation 0 | {head} |", "|---|--:|---|" + "--:|" * len(TRAINED) + "---|" * 2]
    for budget in budgets:
        for task in tasks:
            record = Record(folder / f"{task}-{budget}.json")
            children, done = record.children(), record.done()
            first = f"trained ({len(record.data['first'])})" if "first" in record.data else "not yet"
            cells = [f"{done[w]} / {len(children)}" if done[w] else "not yet" for w in TRAINED]
            scratch = record.rewards("scratch", children)
            complete = children and all(done[w] == len(children) for w in TRAINED)
            for way in WAYS[1:]:
                if complete:
                    cells.append("(its row)")  # the tables of printed rows say it: one figure, one place
                    continue
                rewards = record.rewards(way, children)
                cells.append(versus(rewards, scratch) if rewards and scratch else "")
            lines.append(f"| {task} | {budget:,} | {first} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def markdown(rows: list[dict[str, Any]]) -> str:
    """The rows as the documentation's table: per task, each way and the reference at 4T."""
    head = (
        "| task | way | median reward | paired difference to `scratch`, median | children better than `scratch` "
        f"| Wilcoxon p | Spearman with `scratch` at 4T | top {TOP} of 4T kept |"
    )
    lines = [head, "|---|---|--:|--:|--:|--:|--:|--:|"]
    for row in rows:
        rewards = row["rewards"]
        n = len(rewards["scratch"])
        task = f"{row['task']}, T = {row['budget']:,}"
        for way in WAYS:
            better = sum(a > b for a, b in zip(rewards[way], rewards["scratch"]))
            cells = ["", "", "", ""] if way == "scratch" else [
                f"{row[f'{way}_minus_scratch']:+.3f}", f"{better} / {n}", f"{row[f'{way}_wilcoxon_p']:.2g}"
            ]  # fmt: skip
            lines.append(
                f"| {task} | `{way}` | {row[f'{way}_median']:.3f} | {cells[0]} | {cells[1]} | {cells[2]} "
                f"| {row[f'{way}_spearman_4x']:.2f} | {row[f'{way}_top{TOP}_of_4x']} |"
            )
            task = ""
        lines.append(f"| | `scratch` at 4T | {statistics.median(rewards['scratch4x']):.3f} | | | | 1 | {TOP} |")
    return "\n".join(lines)


CODESIGN_COLUMNS = ["controller", "designer", "seed", "generation", "body", "reward", "status"]


def codesign_rows(runs: list[Path]) -> Any:
    """The evaluations of finished co-design runs, one row per evaluated body, with each run's controller."""
    import pandas as pd

    from gdabench.results import RunDirectory

    frames = [RunDirectory.open(run).load_evaluations() for run in runs]
    return pd.concat([f[CODESIGN_COLUMNS] for f in frames], ignore_index=True)


def codesign_table(rows: Any) -> str:
    """Each designer's best reward per seed under each controller, and the designers' difference seed by seed
    (seeds a run has not finished are left out)."""
    best = rows.groupby(["controller", "designer", "seed"], sort=False)["reward"].max().unstack("designer")
    designers = list(dict.fromkeys(rows["designer"]))
    head = " | ".join(f"{d}, best per seed" for d in designers)
    rule = "|---" * (len(designers) + 2) + "|"
    lines = [f"| controller | {head} | {' - '.join(designers)}, per seed |", rule]
    for controller in dict.fromkeys(rows["controller"]):
        per = best.loc[controller]  # seeds x designers, NaN where a trial is missing
        cells = [", ".join(f"{v:.2f}" for v in per[d].dropna()) + f" (median {per[d].median():.2f})" for d in designers]
        if len(designers) == 2:
            cells.append(", ".join(f"{d:+.2f}" for d in (per[designers[0]] - per[designers[1]]).dropna()))
        lines.append(f"| `{controller}` | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, help="where policies and results are kept (resumable)")
    parser.add_argument("--tasks", default="Walker-v0", help="Evolution Gym tasks on the voxel engine, comma-separated")
    parser.add_argument("--budgets", default=",".join(map(str, BUDGETS)), help="timesteps per body, comma-separated")
    parser.add_argument("--designer", default="ga", help="the designer whose generations are trained")
    parser.add_argument("--population", type=int, default=25)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, help="write every row (with each body's rewards) here")
    parser.add_argument("--ways", default=",".join(TRAINED), help="the ways to train, comma-separated")
    parser.add_argument("--part", default="0/1", help="K/N: train only every N-th child from the K-th")
    parser.add_argument("--record", type=Path, help="keep each task and budget's record here (default: under --out)")
    parser.add_argument("--codesign", help="finished compare runs to read instead, comma-separated")
    parser.add_argument("--csv", type=Path, help="with --codesign: write their evaluations here")
    args = parser.parse_args(argv)
    if args.codesign:
        rows = codesign_rows([Path(run) for run in args.codesign.split(",")])
        if args.csv:
            rows.to_csv(args.csv, index=False)
        print(codesign_table(rows))
        return
    if args.out is None:
        parser.error("--out is required (or --codesign)")
    args.ways = args.ways.split(",")
    if not set(args.ways) <= set(TRAINED):
        parser.error(f"--ways: unknown {', '.join(sorted(set(args.ways) - set(TRAINED)))} (ways: {', '.join(TRAINED)})")
    k, _, n = args.part.partition("/")
    if not (k.isdigit() and n.isdigit() and int(k) < int(n)):
        parser.error(f"--part {args.part}: give K/N with 0 <= K < N")
    args.every = (int(k), int(n))
    if args.part != "0/1" and "modular" in args.ways:
        parser.error("--part: modular-ppo's shared policy learns from every child; leave modular out of --ways")
    import torch

    torch.set_num_threads(1)
    measured = [measure(task, int(float(b)), args) for task in args.tasks.split(",") for b in args.budgets.split(",")]
    rows = [row for row in measured if row is not None]
    if rows:
        show(rows)
    if args.json and rows:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
