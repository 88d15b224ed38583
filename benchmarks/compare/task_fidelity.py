"""Fidelity of the voxel engine to Evolution Gym 2.0 on every task: same bodies, same actions, same returns?

``walker_fidelity.py`` (Walker-v0, either walker engine) generalised to Evolution Gym's tasks on the voxel
engine, with its gaits, actions and statistics.  Per task: ``--bodies`` bodies of Evolution Gym's sampler
(``gdabench.random_body``, a port of ``sample_robot``, seeded by ``--seed``) that the task can take
(:func:`~gdabench.envs.tasks.base.checked_body`); body ``k`` belongs to the calibration part when ``k`` is
even and to the held-out part when it is odd.  Every body plays every gait of ``--gaits`` (walker_fidelity's
open-loop sinusoids, and ``random``: uniform actions seeded by the body) for the task's step limit, on both
simulators; Evolution Gym's random set-ups (Catcher-v0, BidirectionalWalker-v0) are drawn per episode and
imposed on the voxel engine.

Per task and part: Spearman and Pearson correlation of the episode returns, sign agreement, the median RMS
gap of the robot's centre-of-mass x trajectories (voxels), and the unstable episodes of each simulator and
those unstable in one only.  The goal on the held-out part: Spearman >= 0.95, sign agreement >= 95%, no
episode unstable in one simulator only.  ``--control`` sets Evolution Gym against itself instead, every action
changed by 1e-14 (about a rounding error): how well any simulator that is not bit-identical can agree.

A held-out episode on which the two simulators disagree (the returns' signs differ, or the episodes end
differently) may be a chance of rounding: ``--nudges N --nudged OUT`` plays each such episode N more times in
both simulators, every action changed by a few rounding errors (+1e-14, -1e-14, +2e-14, ...), and writes to
OUT how often each simulator's nudged runs end with a positive return, end early and become unstable, with
Fisher's exact p of each pair of rates: an outcome both simulators reach at similar rates is a chance of
rounding, one that only one simulator reaches is a difference between them.

Evolution Gym's episodes are written to ``--rows`` (JSON lines) as each finishes, the voxel engine's per task
(one batch of all its episodes); a restart reads them back and plays only what is missing.  Run it in the
venv that has both simulators::

    PYTHONPATH=. /work/venv-evogym/bin/python benchmarks/compare/task_fidelity.py --bodies 8 \\
        --rows runs/fidelity.jsonl --out docs/benchmarks/output/task-fidelity.json
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from pathlib import Path
from typing import Any, Callable, Sequence

import numba
import numpy as np
from evogym_twin import (
    NUDGE,
    Episode,
    NudgedEvogym,
    Rows,
    actuators,
    nudged_episodes,
    play,
    play_batch,
    play_evogym,
    refuse_unknown,
    require_evogym,
    rounded,
)
from task_speed import task_bodies
from walker_fidelity import GAITS, actions_for, table

import gdabench
from gdabench.envs.tasks import CATALOG

PARTS = ("calibration", "held-out")
DEFAULT_GAITS = "wave20,back20-inphase,pulse12,random"
#: the goal on the held-out part
GOAL_SPEARMAN, GOAL_SIGN = 0.95, 0.95


def cases(task: str, n_bodies: int, seed: int, gaits: Sequence[str]) -> list[dict[str, Any]]:
    """The task's episodes: body, part, gait, the seed of its random actions and of its set-up."""
    out = []
    for k, body in enumerate(task_bodies(task, n_bodies, seed)):
        body_seed = seed * 1_000_003 + k
        for g, gait in enumerate(gaits):
            out.append({"body": body.text, "part": PARTS[k % 2], "gait": gait, "seed": body_seed,
                        "setup_seed": body_seed * len(GAITS) + g})
    return out


def episode_actions(case: dict[str, Any], steps: int) -> np.ndarray:
    body = gdabench.Body.from_text(case["body"])
    return actions_for(case["gait"], actuators(body), case["seed"], steps)


def theirs_key(task: str, case: dict[str, Any], steps: int) -> str:
    return f"{task}|{case['body']}|{case['gait']}|{case['seed']}|{case['setup_seed']}|{steps}"


def play_theirs(task: str, case: dict[str, Any], steps: int) -> Episode:
    """Evolution Gym's episode of ``case``."""
    return play_evogym(task, gdabench.Body.from_text(case["body"]), episode_actions(case, steps), case["setup_seed"])


def play_ours(task: str, todo: list[dict[str, Any]], theirs: list[Episode], steps: int) -> list[Episode]:
    """The voxel engine's episodes of ``todo``, one batch, each with Evolution Gym's set-up of that episode."""
    bodies = [gdabench.Body.from_text(c["body"]) for c in todo]
    return play_batch(task, bodies, [episode_actions(c, steps) for c in todo], [t["setup"] for t in theirs])


def play_control(task: str, todo: list[dict[str, Any]], theirs: list[Episode], steps: int) -> list[Episode]:
    """``--control``: Evolution Gym with its actions nudged (:class:`evogym_twin.NudgedEvogym`) in the voxel
    engine's place, episode by episode: how well Evolution Gym agrees with itself."""
    out = []
    for case in todo:
        env = NudgedEvogym(task, gdabench.Body.from_text(case["body"]), case["setup_seed"])
        try:
            out.append(play(env, episode_actions(case, steps)))
        finally:
            env.close()
    return out


def part_tables(rows: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """walker_fidelity's figures per part, with whether the held-out goal is met."""
    out = {}
    for part in PARTS:
        part_rows = [r for r in rows if r["part"] == part]
        if not part_rows:
            continue
        t: dict[str, Any] = dict(table(part_rows))
        t["per_gait_spearman"] = {g: table([r for r in part_rows if r["gait"] == g])["spearman"]
                                  for g in dict.fromkeys(r["gait"] for r in part_rows)}
        t["goal_met"] = bool(t["spearman"] >= GOAL_SPEARMAN and t["sign_agreement"] >= GOAL_SIGN
                             and t["unstable_ours_only"] == 0 and t["unstable_evogym_only"] == 0)
        out[part] = t
    return out


def run_task(task: str, todo: list[dict[str, Any]], steps: int, rows: Rows,
             theirs_player: Callable[[str, dict[str, Any], int], Episode] = play_theirs,
             ours_player: Callable[[str, list[dict[str, Any]], list[Episode], int], list[Episode]] = play_ours,
             ) -> dict[str, Any]:
    """Every episode of ``task`` in both simulators (Evolution Gym's read back from ``rows`` where there)."""
    theirs = []
    for case in todo:
        key = theirs_key(task, case, steps)
        row = rows.find(kind="evogym", key=key)
        if row is None:
            row = {"kind": "evogym", "key": key, "result": theirs_player(task, case, steps)}
            rows.add(row)
        theirs.append(row["result"])
    start = time.perf_counter()
    try:
        ours = ours_player(task, todo, theirs, steps)
    except Exception as exc:  # noqa: BLE001 - reported in the task's row; task_stability finds the body
        return {"task": task, "difficulty": CATALOG[task].difficulty, "steps": steps, "parts": {},
                "error": f"{type(exc).__name__}: {exc}", "episodes": []}
    seconds = time.perf_counter() - start
    episodes = [{**case, "ours": o, "evogym": t} for case, o, t in zip(todo, ours, theirs)]
    return {"task": task, "difficulty": CATALOG[task].difficulty, "steps": steps,
            "parts": part_tables(episodes), "voxel_seconds": seconds, "episodes": episodes}


def disagree(episode: dict[str, Any], steps: int) -> bool:
    """Do the two simulators' returns differ in sign, or does one episode end before ``steps`` (or become
    unstable) and the other not?"""
    ours, theirs = episode["ours"], episode["evogym"]
    return bool(np.sign(ours["return"]) != np.sign(theirs["return"])
                or (ours["steps"] < steps) != (theirs["steps"] < steps) or ours["unstable"] != theirs["unstable"])


def outcomes(runs: list[Episode], steps: int) -> dict[str, Any]:
    """How a simulator's nudged runs of one episode ended."""
    returns = [r["return"] for r in runs]
    return {"positive": sum(r > 0 for r in returns), "ended_early": sum(r["steps"] < steps for r in runs),
            "unstable": sum(r["unstable"] for r in runs), "return_median": float(np.median(returns)),
            "return_range": [min(returns), max(returns)], "steps": [r["steps"] for r in runs]}


def fisher_p(a: int, b: int, n: int) -> float:
    """Fisher's exact p (two-sided) that rates a/n and b/n are the same; 1 where they are equal."""
    from scipy.stats import fisher_exact

    return 1.0 if a == b else float(fisher_exact([[a, n - a], [b, n - b]]).pvalue)


def nudged_disagreements(task: str, result: dict[str, Any], steps: int, runs: int,
                         theirs_player: Callable[[str, gdabench.Body, np.ndarray, int], Episode] = play_evogym,
                         ) -> list[dict[str, Any]]:
    """Every held-out episode of ``result`` (:func:`run_task`'s) on which the simulators disagree, played ``runs``
    times more in each, nudged (:func:`evogym_twin.nudged_episodes`)."""
    out = []
    for e in result["episodes"]:
        if e["part"] != "held-out" or not disagree(e, steps):
            continue
        actions = episode_actions(e, steps)
        ours, theirs = nudged_episodes(task, gdabench.Body.from_text(e["body"]), actions, e["setup_seed"], runs,
                                       theirs_player)
        voxel, evogym = outcomes(ours, len(actions)), outcomes(theirs, len(actions))
        out.append({"task": task, "body": e["body"], "gait": e["gait"], "runs": runs, "voxel": voxel,
                    "evogym": evogym, **{f"p_{k}": fisher_p(voxel[k], evogym[k], runs)
                                         for k in ("positive", "ended_early", "unstable")}})
    return out


def write_outputs(out: Path, results: list[dict[str, Any]], settings: dict[str, Any]) -> None:
    """The per-task tables (JSON) and every episode's returns (CSV beside it)."""
    lines = ",\n".join(json.dumps({k: rounded(r[k], 4) for k in ("task", "difficulty", "steps", "parts", "error")
                                   if k in r},
                                  separators=(",", ":")) for r in results)
    out.write_text('{"command":"benchmarks/compare/task_fidelity.py","settings":%s,"goal":%s,"tasks":[\n%s\n]}\n' % (
        json.dumps(settings), json.dumps({"spearman": GOAL_SPEARMAN, "sign_agreement": GOAL_SIGN}), lines))
    with out.with_suffix(".csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["task", "body", "part", "gait", "return_voxel", "return_evogym", "unstable_voxel",
                         "unstable_evogym", "steps_voxel", "steps_evogym"])
        for r in results:
            for e in r["episodes"]:
                o, t = e["ours"], e["evogym"]
                writer.writerow([r["task"], e["body"], e["part"], e["gait"], f"{o['return']:.6g}",
                                 f"{t['return']:.6g}", int(o["unstable"]), int(t["unstable"]), o["steps"],
                                 t["steps"]])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", default="", help="comma-separated task ids (default: every task)")
    parser.add_argument("--bodies", type=int, default=8, help="sampler bodies per task (half of them held out)")
    parser.add_argument("--gaits", default=DEFAULT_GAITS, help="comma-separated names from: " + ", ".join(GAITS))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--steps", type=int, default=None, help="at most this many steps (default: the task's limit)")
    parser.add_argument("--part", choices=("all", *PARTS), default="all", help="play only this part's bodies")
    parser.add_argument("--control", action="store_true",
                        help=f"compare Evolution Gym with itself, its actions changed by {NUDGE:g}, instead")
    parser.add_argument("--nudges", type=int, default=0,
                        help="play each held-out episode the simulators disagree on this many times more in both, "
                             "nudged (needs --nudged)")
    parser.add_argument("--nudged", type=Path, help="with --nudges: write the nudged runs' outcomes here (JSON)")
    parser.add_argument("--rows", type=Path, help="JSON lines of finished episodes and tasks, reused on a restart")
    parser.add_argument("--out", type=Path,
                        help="write the per-task tables here (JSON) and the episodes beside it (CSV)")
    args = parser.parse_args(argv)
    tasks = [t for t in args.tasks.split(",") if t] or list(CATALOG)
    gaits = args.gaits.split(",")
    refuse_unknown("task", tasks, CATALOG)
    refuse_unknown("gait", gaits, GAITS)
    if bool(args.nudges) != bool(args.nudged):
        parser.error("--nudges and --nudged go together")
    require_evogym()
    numba.set_num_threads(1)
    rows = Rows(args.rows)
    settings: dict[str, Any] = {"bodies": args.bodies, "gaits": gaits, "seed": args.seed, "steps": args.steps}
    settings |= {"part": args.part} if args.part != "all" else {}
    settings |= {"control": NUDGE} if args.control else {}
    print(f"voxel engine against Evolution Gym 2.0; {args.bodies} bodies per task, gaits {', '.join(gaits)}, "
          f"seed {args.seed}")
    print("| task | grade | part | episodes | Spearman | sign agreement | unstable ours / Evolution Gym (one only) "
          "| goal |")
    print("|---|---|---|--:|--:|--:|---|---|")
    results, nudged = [], []
    for task in tasks:
        steps = min(args.steps or CATALOG[task].max_episode_steps, CATALOG[task].max_episode_steps)
        row = rows.find(kind="fidelity", task=task, settings=settings)
        if row is None:
            todo = [c for c in cases(task, args.bodies, args.seed, gaits) if args.part in ("all", c["part"])]
            row = {"kind": "fidelity", "task": task, "settings": settings,
                   "result": run_task(task, todo, steps, rows, ours_player=play_control if args.control else play_ours)}
            rows.add(row)
        r = row["result"]
        results.append(r)
        if "error" in r:
            print(f"| {task} | {r['difficulty']} | all | - | - | - | voxel engine failed: {r['error']} | MISSED |")
        for part, t in r["parts"].items():
            print(f"| {task} | {r['difficulty']} | {part} | {t['episodes']} | {t['spearman']:.3f} "
                  f"| {100 * t['sign_agreement']:.0f}% | {round(t['unstable_ours'] * t['episodes'])} / "
                  f"{round(t['unstable_evogym'] * t['episodes'])} ({round(t['unstable_ours_only'] * t['episodes'])}"
                  f" / {round(t['unstable_evogym_only'] * t['episodes'])}) | {'met' if t['goal_met'] else 'MISSED'} |",
                  flush=True)
        if args.nudges and "error" not in r:
            found = rows.find(kind="nudged", task=task, settings=settings, runs=args.nudges)
            if found is None:
                found = {"kind": "nudged", "task": task, "settings": settings, "runs": args.nudges,
                         "result": nudged_disagreements(task, r, steps, args.nudges)}
                rows.add(found)
            nudged += found["result"]
            for n in found["result"]:
                v, t = n["voxel"], n["evogym"]
                print(f"|   {n['body']} {n['gait']} nudged {n['runs']} times: positive {v['positive']} / "
                      f"{t['positive']}, ended early {v['ended_early']} / {t['ended_early']}, unstable "
                      f"{v['unstable']} / {t['unstable']} (voxel engine / Evolution Gym) |", flush=True)
    if args.out:
        write_outputs(args.out, results, settings)
    if args.nudged:
        args.nudged.write_text(json.dumps({"command": "benchmarks/compare/task_fidelity.py", "settings": settings,
                                           "nudges": args.nudges, "episodes": rounded(nudged, 6)}, indent=1) + "\n")


if __name__ == "__main__":
    main()
