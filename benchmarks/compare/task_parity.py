"""Parity of the voxel engine with Evolution Gym 2.0 over whole episodes, per task: how the gap grows.

``tests/test_tasks.py`` holds every task to 1e-6 over the first 10 steps; this plays on to the task's step
limit (or the episode's end).  For every task and body (the parity fixtures' two, then ``--bodies`` of
Evolution Gym's sampler that the task can take, seeded by ``--seed``), both simulators play the fixtures'
gait (``evogym_record.gait``) side by side, step by step, with Evolution Gym's random set-up (drawn from
``random.seed(0)``, as the fixtures are) imposed on the voxel engine.  After every step it measures the
largest gap of the moving objects' point positions and of the observations, and the reward gap, and
whether both episodes end together.  Per task it reports the largest gap up to steps 10, 50, 100, 200, 500
and the limit (over bodies), and the first step where the gap of positions or observations exceeds 0,
1e-12, 1e-6 and 1e-3 (earliest over bodies); "parity steps" are the steps before the first over 1e-6.

Run it in the venv that has Evolution Gym and gdabench (resumable: finished tasks are read back from
``--rows``)::

    PYTHONPATH=. /work/venv-evogym/bin/python benchmarks/compare/task_parity.py \\
        --rows runs/parity.jsonl --out docs/benchmarks/output/task-parity.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any, Sequence

import numba
import numpy as np
from evogym_record import TASK_BODIES, gait
from evogym_twin import (
    NUDGE,
    EvogymEnv,
    NudgedEvogym,
    Rows,
    Twin,
    VoxelEnv,
    actuators,
    gait_actions,
    refuse_unknown,
    require_evogym,
    rounded,
)
from task_speed import task_bodies

import gdabench
from gdabench.envs.tasks import CATALOG, task as definition

CHECKPOINTS = (10, 50, 100, 200, 500)
#: the first step where the gap of positions or observations exceeds each of these is reported
THRESHOLDS = {"0": 0.0, "1e-12": 1e-12, "1e-6": 1e-6, "1e-3": 1e-3}


def start_gap(ours: Twin, theirs: Twin, names: Sequence[str]) -> float:
    """The largest gap at the start: first observations and every object's points."""
    gaps = [float(np.abs(ours.first() - theirs.first()).max())]
    gaps += [float(np.abs(ours.positions(name) - theirs.positions(name)).max()) for name in names]
    return max(gaps)


def compare(ours: Twin, theirs: Twin, actions: np.ndarray, names: Sequence[str]) -> dict[str, Any]:
    """Both environments stepped with ``actions`` until either ends: the gaps after every step."""
    start = start_gap(ours, theirs, names)
    pos, obs, reward, returns = [], [], [], [0.0, 0.0]
    end: dict[str, Any] = {"ours": None, "evogym": None}
    for t, action in enumerate(actions, start=1):
        o1, r1, d1, u1 = ours.step(action)
        o2, r2, d2, u2 = theirs.step(action)
        pos.append(max(float(np.abs(ours.positions(m) - theirs.positions(m)).max()) for m in ours.moving))
        obs.append(float(np.abs(o1 - o2).max()) if o1.shape == o2.shape else float("inf"))
        reward.append(abs(r1 - r2))
        returns[0] += r1
        returns[1] += r2
        for who, done, unstable in (("ours", d1, u1), ("evogym", d2, u2)):
            if done:
                end[who] = {"step": t, "unstable": unstable}
        if d1 or d2:
            break
    return {"start": start, "pos": pos, "obs": obs, "reward": reward, "end": end,
            "returns": returns}


def first_over(gaps: Sequence[float], start: float, threshold: float) -> int | None:
    """The first step whose gap exceeds ``threshold`` (0: at the start), or None."""
    if start > threshold:
        return 0
    over = np.flatnonzero(np.asarray(gaps) > threshold)
    return int(over[0]) + 1 if len(over) else None


def body_summary(body: str, gaps: dict[str, Any], limit: int) -> dict[str, Any]:
    """One body's figures: gaps up to each checkpoint, first steps over each threshold, how it ended."""
    both = np.maximum(gaps["pos"], gaps["obs"]) if gaps["pos"] else np.zeros(0)
    steps = len(both)
    at = {}
    for name in ("pos", "obs", "reward"):
        series = np.asarray(gaps[name])
        at[name] = {str(c): float(series[: c].max()) if steps else 0.0 for c in (*CHECKPOINTS, limit) if c <= limit}
    ends = gaps["end"]
    ours_end, theirs_end = (ends[w]["step"] if ends[w] else None for w in ("ours", "evogym"))
    return {
        "body": body, "steps": steps, "start_gap": gaps["start"], "gap_up_to": at,
        "first_over": {k: first_over(both, gaps["start"], v) for k, v in THRESHOLDS.items()},
        "ends_agree": ours_end == theirs_end,
        "end": ends, "returns": gaps["returns"],
    }


def task_summary(task: str, bodies: list[dict[str, Any]]) -> dict[str, Any]:
    """Over a task's bodies: the largest gaps, the earliest steps over each threshold, the parity steps."""
    limit = CATALOG[task].max_episode_steps
    firsts = {k: [b["first_over"][k] for b in bodies if b["first_over"][k] is not None] for k in THRESHOLDS}
    first_6 = min(firsts["1e-6"]) if firsts["1e-6"] else None
    compared = min(b["steps"] for b in bodies)
    return {
        "task": task, "difficulty": CATALOG[task].difficulty, "limit": limit, "bodies": len(bodies),
        "parity_steps": max(first_6 - 1, 0) if first_6 is not None else compared,
        "parity_all_steps": first_6 is None,
        "first_over": {k: (min(v) if v else None) for k, v in firsts.items()},
        "gap_up_to": {name: {c: max(b["gap_up_to"][name][c] for b in bodies) for c in bodies[0]["gap_up_to"][name]}
                      for name in ("pos", "obs", "reward")},
        "ends_agree": all(b["ends_agree"] for b in bodies),
        "per_body": bodies,
    }


def run_task(task: str, bodies: Sequence[gdabench.Body], steps: int | None = None,
             make_theirs: Any = EvogymEnv, make_ours: Any = VoxelEnv) -> dict[str, Any]:
    """Every body of ``task`` in both simulators (``make_theirs(task, body, 0)`` is Evolution Gym unless a
    test says otherwise; the voxel engine is given its set-up)."""
    limit = CATALOG[task].max_episode_steps if steps is None else min(steps, CATALOG[task].max_episode_steps)
    names = ["robot", *definition(task).objects()]
    out = []
    for body in bodies:
        theirs = make_theirs(task, body, 0)
        ours = make_ours(task, body, setup=theirs.setup)
        gaps = compare(ours, theirs, gait_actions(gait, len(actuators(body)), limit), names)
        theirs.close()
        ours.close()
        out.append(body_summary(body.text, gaps, limit))
    return task_summary(task, out)


def parity_bodies(task: str, n_sampled: int, seed: int) -> list[gdabench.Body]:
    """The fixtures' two bodies, then ``n_sampled`` of the sampler's that ``task`` can take."""
    fixed = [gdabench.Body.from_text(text) for text in TASK_BODIES]
    return fixed + task_bodies(task, n_sampled, seed)


def fmt(step: int | None, steps: str) -> str:
    return f"none in {steps}" if step is None else str(step)


def trace(task: str, body: gdabench.Body, steps: int | None, make_ours: Any = VoxelEnv) -> None:
    """Print how the gap of one body grows, step by step, from its first step over 1e-12 to its first over 1e-3."""
    limit = min(steps or CATALOG[task].max_episode_steps, CATALOG[task].max_episode_steps)
    theirs = EvogymEnv(task, body, 0)
    gaps = compare(make_ours(task, body, setup=theirs.setup), theirs,
                   gait_actions(gait, len(actuators(body)), limit), ["robot", *definition(task).objects()])
    both = np.maximum(gaps["pos"], gaps["obs"])
    start = first_over(both, gaps["start"], 1e-12) or 1
    end = first_over(both, gaps["start"], 1e-3) or len(both)
    print(f"{task} {body.text}: {len(both)} steps, ended {gaps['end']}; gaps from step {start}")
    print("step  positions  observations  reward")
    for t in range(max(start, 1), min(end + 5, len(both)) + 1):
        print(f"{t:4d}  {gaps['pos'][t - 1]:9.1e}  {gaps['obs'][t - 1]:12.1e}  {gaps['reward'][t - 1]:6.1e}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", default="", help="comma-separated task ids (default: every task)")
    parser.add_argument("--bodies", type=int, default=2, help="sampler bodies per task besides the fixtures' two")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sampler bodies")
    parser.add_argument("--steps", type=int, default=None, help="at most this many steps (default: the task's limit)")
    parser.add_argument("--rows", type=Path, help="JSON lines of finished tasks: read back and skipped on a restart")
    parser.add_argument("--out", type=Path, help="write every task's figures here (JSON)")
    parser.add_argument("--control", action="store_true",
                        help=f"compare Evolution Gym with itself, its actions changed by {NUDGE:g}, instead")
    parser.add_argument("--trace", metavar="BODY", help="print one body's gaps step by step (with one --tasks id)")
    args = parser.parse_args(argv)
    tasks = [t for t in args.tasks.split(",") if t] or list(CATALOG)
    refuse_unknown("task", tasks, CATALOG)
    require_evogym()
    numba.set_num_threads(1)
    if args.trace:
        trace(tasks[0], gdabench.Body.from_text(args.trace), args.steps, NudgedEvogym if args.control else VoxelEnv)
        return
    rows = Rows(args.rows)
    settings: dict[str, Any] = {"bodies": args.bodies, "seed": args.seed, "steps": args.steps}
    if args.control:
        settings["control"] = NUDGE
    print("| task | grade | steps | parity steps (<= 1e-6) | first > 0 | first > 1e-3 | gap pos @100 | gap pos @limit "
          "| ends agree |")
    print("|---|---|--:|--:|--:|--:|--:|--:|---|")
    results = []
    for task in tasks:
        row = rows.find(kind="parity", task=task, settings=settings)
        if row is None:
            start = time.perf_counter()
            result = run_task(task, parity_bodies(task, args.bodies, args.seed), args.steps,
                              make_ours=NudgedEvogym if args.control else VoxelEnv)
            row = {"kind": "parity", "task": task, "settings": settings, "seconds": time.perf_counter() - start,
                   "result": result}
            rows.add(row)
        r = row["result"]
        gaps = r["gap_up_to"]["pos"]
        lengths = sorted({b["steps"] for b in r["per_body"]})
        steps = f"{lengths[0]}" + (f"-{lengths[-1]}" if len(lengths) > 1 else "")
        within = "all" if r["parity_all_steps"] else r["parity_steps"]
        print(f"| {task} | {r['difficulty']} | {steps} | {within} | {fmt(r['first_over']['0'], steps)} "
              f"| {fmt(r['first_over']['1e-3'], steps)} | {gaps.get('100', float('nan')):.1e} "
              f"| {max(gaps.values()):.1e} | {'yes' if r['ends_agree'] else 'NO'} |", flush=True)
        results.append(row)
    if args.out:
        lines = ",\n".join(json.dumps(rounded(r["result"], 3), separators=(",", ":")) for r in results)
        args.out.write_text('{"command":"benchmarks/compare/task_parity.py","settings":%s,"checkpoints":%s,"tasks":[\n%s\n]}\n'
                            % (json.dumps(settings), json.dumps(list(CHECKPOINTS)), lines))


if __name__ == "__main__":
    main()
