"""Stability of the voxel engine on every task: random valid bodies driven by random actions.

``walker_stability.py`` generalised to Evolution Gym's tasks, with its checks.  Per task: ``--bodies``
bodies of Evolution Gym's sampler (``gdabench.random_body``, seeded by ``--seed``) that the task can take,
each playing one episode of uniformly random actions in [0.6, 1.6] (seeded by the body) to the task's
step limit, on the voxel engine (all bodies of a task in one batch) and on Evolution Gym 2.0 with the same
actions (its random set-ups imposed on the voxel engine).  On the voxel engine it checks that nothing
slipped through undetected: no exception, no NaN, every observation (the first included) inside the
observation space [-100, 100], no stable step moving the robot's centre of mass implausibly far, and every
unstable step undone (every point where it was) and rewarded as the task says: the task's reward for a step
that moves nothing, plus Evolution Gym's penalty of -3, the episode ended.  It then sets the unstable
episodes beside Evolution Gym's on the same bodies and actions: in both, in ours only, in Evolution Gym's
only.

An episode unstable in one simulator only may be a rounding-sized chance: the trajectories of both part from
any rounding-sized change within a few hundred steps (``task_parity.py --control``).  ``--nudges N`` plays
each such episode N more times in both simulators, every action changed by a few rounding errors (+1e-14,
-1e-14, +2e-14, ...), and counts the unstable runs of each: an outcome that both simulators' own nudged runs
reach at similar rates is a chance of rounding, one that only one simulator reaches is a difference.

Evolution Gym's episodes are written to ``--rows`` (JSON lines) as each finishes, the voxel engine's per
task; a restart reads them back.  Run it in the venv that has both simulators::

    PYTHONPATH=. /work/venv-evogym/bin/python benchmarks/compare/task_stability.py --bodies 20 \\
        --rows runs/stability.jsonl --out docs/benchmarks/output/task-stability.json

``--no-evogym`` runs the voxel engine's checks alone (its venv needs no Evolution Gym).
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import time
from pathlib import Path
from typing import Any, Callable, Sequence

import numba
import numpy as np
from evogym_twin import (
    Episode,
    Rows,
    actuators,
    evogym_installed,
    nudged_episodes,
    play_batch,
    play_evogym,
    refuse_unknown,
    rounded,
)
from task_speed import task_bodies
from walker_fidelity import actions_for
from walker_stability import step_problems

import gdabench
from gdabench.envs.tasks import CATALOG
from gdabench.envs.voxel.batch import TaskBatch
from gdabench.envs.voxel.gym_env import OBS_BOUND

PROBLEMS = ("exception", "nan", "outside", "implausible", "bad_penalty", "not_undone")


class Checks:
    """The checks of every step of a batch (a :class:`evogym_twin.Watch`): which environments had which problem."""

    def __init__(self, n: int):
        self.found = {key: np.zeros(n, dtype=bool) for key in PROBLEMS}
        self.first_unstable = np.full(n, -1)
        self.t = 0

    def _com(self, batch: TaskBatch) -> np.ndarray:
        start = batch.tables.robot_start
        return np.array([batch.state.pos[i, start:start + batch.robot_points[i]].mean(axis=0)
                         for i in range(batch.num_envs)])

    def start(self, batch: TaskBatch, obs: np.ndarray) -> None:
        self.found["nan"] |= ~np.isfinite(obs).all(axis=1)
        self.found["outside"] |= ~(np.abs(obs) <= OBS_BOUND).all(axis=1)

    def before(self, batch: TaskBatch) -> None:
        self.frame, self.task, self.com = batch.frame(), copy.deepcopy(batch.task), self._com(batch)

    def after(self, batch: TaskBatch, obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray,
              unstable: np.ndarray, active: np.ndarray) -> None:
        self.t += 1
        still, _ = self.task.reward(self.frame, self.frame, np.zeros(batch.num_envs, dtype=bool))
        moved = np.linalg.norm(self._com(batch) - self.com, axis=1)
        for key, flags in step_problems(obs, reward, terminated, unstable, still, moved, OBS_BOUND).items():
            self.found[key] |= flags & active
        kept = (batch.state.pos == self.frame.pos).all(axis=(1, 2))
        self.found["not_undone"] |= unstable & ~kept
        self.first_unstable = np.where(unstable & (self.first_unstable < 0), self.t, self.first_unstable)


def check_bodies(task: str, bodies: Sequence[gdabench.Body], actions: Sequence[np.ndarray],
                 setups: Sequence[dict[str, Any]]) -> tuple[list[Episode], dict[str, np.ndarray]]:
    """The voxel engine's episodes and problems (per body); if the batch raises, each body alone, to find
    which do (their episodes are None)."""
    checks = Checks(len(bodies))
    try:
        return play_batch(task, bodies, actions, setups, watch=checks), checks.found
    except Exception:  # noqa: BLE001 - found per body below, counted and reported
        if len(bodies) == 1:
            found = {key: np.zeros(1, dtype=bool) for key in PROBLEMS}
            found["exception"][0] = True
            return [None], found  # type: ignore[list-item]
    episodes, found = [], {key: np.zeros(len(bodies), dtype=bool) for key in PROBLEMS}
    for i in range(len(bodies)):
        one, problems = check_bodies(task, bodies[i:i + 1], actions[i:i + 1], setups[i:i + 1])
        episodes += one
        for key in PROBLEMS:
            found[key][i] = problems[key][0]
    return episodes, found


def nudged_runs(task: str, body: gdabench.Body, actions: np.ndarray, setup_seed: int, runs: int,
                theirs_player: Callable[[str, gdabench.Body, np.ndarray, int], Episode]) -> dict[str, Any]:
    """:func:`evogym_twin.nudged_episodes`: how many of each simulator's runs became unstable, and at which
    steps."""
    ours, theirs = nudged_episodes(task, body, actions, setup_seed, runs, theirs_player)
    return {
        "body": body.text, "runs": runs,
        "voxel": sum(e["unstable"] for e in ours), "evogym": sum(t["unstable"] for t in theirs),
        "voxel_steps": [e["steps"] for e in ours if e["unstable"]],
        "evogym_steps": [t["steps"] for t in theirs if t["unstable"]],
    }


def episode_inputs(bodies: Sequence[gdabench.Body], seed: int, steps: int) -> tuple[list[int], list[np.ndarray]]:
    """Each body's set-up seed and random actions."""
    seeds = [seed * 1_000_003 + k for k in range(len(bodies))]
    return seeds, [actions_for("random", actuators(b), s, steps) for b, s in zip(bodies, seeds)]


def nudged_mismatches(task: str, bodies: Sequence[gdabench.Body], seed: int, steps: int, result: dict[str, Any],
                      runs: int, theirs_player: Callable[[str, gdabench.Body, np.ndarray, int], Episode] | None = None,
                      ) -> list[dict[str, Any]]:
    """:func:`nudged_runs` of every episode of ``result`` (:func:`run_task`'s) unstable in one simulator only."""
    theirs_player = theirs_player or play_evogym
    seeds, actions = episode_inputs(bodies, seed, steps)
    one_only = set(result["unstable_bodies_voxel"]) ^ set(result["unstable_bodies_evogym"])
    return [nudged_runs(task, b, actions[k], seeds[k], runs, theirs_player)
            for k, b in enumerate(bodies) if b.text in one_only]


def run_task(task: str, bodies: Sequence[gdabench.Body], seed: int, steps: int, rows: Rows | None,
             theirs_player: Callable[[str, gdabench.Body, np.ndarray, int], Episode] | None = play_evogym,
             ) -> dict[str, Any]:
    """Every body of ``task`` on the voxel engine, checked, and (unless ``theirs_player`` is None) on Evolution Gym."""
    seeds, actions = episode_inputs(bodies, seed, steps)
    theirs: list[Episode | None] = []
    for body, s, a in zip(bodies, seeds, actions):
        if theirs_player is None:
            theirs.append(None)
            continue
        key = f"{task}|{body.text}|{s}|{steps}"
        row = rows.find(kind="evogym", key=key) if rows is not None else None
        if row is None:
            try:
                result = theirs_player(task, body, a, s)
            except Exception as exc:  # noqa: BLE001 - Evolution Gym's own failure, reported
                result = {"exception": f"{type(exc).__name__}: {exc}"}
            row = {"kind": "evogym", "key": key, "result": result}
            if rows is not None:
                rows.add(row)
        theirs.append(row["result"])
    setups = [t.get("setup", {}) if t else {} for t in theirs]
    start = time.perf_counter()
    ours, found = check_bodies(task, bodies, actions, setups)
    seconds = time.perf_counter() - start
    u_ours = np.array([bool(o and o["unstable"]) for o in ours])
    result: dict[str, Any] = {
        "task": task, "difficulty": CATALOG[task].difficulty, "bodies": len(bodies), "steps": steps,
        "env_steps": int(sum(o["steps"] for o in ours if o)), "voxel_seconds": seconds,
        "problems": {key: int(found[key].sum()) for key in PROBLEMS},
        "examples": {key: bodies[int(np.flatnonzero(found[key])[0])].text for key in PROBLEMS if found[key].any()},
        "unstable_voxel": int(u_ours.sum()),
        "unstable_bodies_voxel": [b.text for b, u in zip(bodies, u_ours) if u],
    }
    if theirs_player is not None:
        u_theirs = np.array([bool(t.get("unstable")) for t in theirs])
        result |= {
            "evogym_exceptions": sum("exception" in t for t in theirs),
            "unstable_evogym": int(u_theirs.sum()),
            "unstable_both": int((u_ours & u_theirs).sum()),
            "unstable_voxel_only": int((u_ours & ~u_theirs).sum()),
            "unstable_evogym_only": int((u_theirs & ~u_ours).sum()),
            "unstable_bodies_evogym": [b.text for b, u in zip(bodies, u_theirs) if u],
        }
    return result


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", default="", help="comma-separated task ids (default: every task)")
    parser.add_argument("--bodies", type=int, default=20, help="sampler bodies per task")
    parser.add_argument("--seed", type=int, default=1, help="seed of the bodies and their actions")
    parser.add_argument("--steps", type=int, default=None, help="at most this many steps (default: the task's limit)")
    parser.add_argument("--no-evogym", action="store_true", help="the voxel engine's checks alone")
    parser.add_argument("--nudges", type=int, default=0,
                        help="play each episode unstable in one simulator only this many times more in both, nudged")
    parser.add_argument("--rows", type=Path, help="JSON lines of finished episodes and tasks, reused on a restart")
    parser.add_argument("--out", type=Path, help="write every task's figures here (JSON)")
    args = parser.parse_args(argv)
    tasks = [t for t in args.tasks.split(",") if t] or list(CATALOG)
    refuse_unknown("task", tasks, CATALOG)
    if not args.no_evogym and not evogym_installed():
        print("error: Evolution Gym is not installed; run this in the venv that has it (/work/venv-evogym), "
              "or pass --no-evogym", file=sys.stderr)
        raise SystemExit(2)
    numba.set_num_threads(1)
    rows = Rows(args.rows)
    settings = {"bodies": args.bodies, "seed": args.seed, "steps": args.steps, "evogym": not args.no_evogym}
    print(f"voxel engine, random actions; {args.bodies} bodies per task, seed {args.seed}")
    print("| task | grade | env steps | problems | unstable ours / Evolution Gym (ours only / Evolution Gym only) |")
    print("|---|---|--:|---|---|")
    results = []
    for task in tasks:
        steps = min(args.steps or CATALOG[task].max_episode_steps, CATALOG[task].max_episode_steps)
        row = rows.find(kind="stability", task=task, settings=settings)
        if row is None:
            bodies = task_bodies(task, args.bodies, args.seed)
            row = {"kind": "stability", "task": task, "settings": settings,
                   "result": run_task(task, bodies, args.seed, steps, rows, None if args.no_evogym else play_evogym)}
            rows.add(row)
        r = dict(row["result"])
        if args.nudges and r.get("unstable_voxel_only", 0) + r.get("unstable_evogym_only", 0):
            nudged = rows.find(kind="nudged", task=task, settings=settings, runs=args.nudges)
            if nudged is None:
                bodies = task_bodies(task, args.bodies, args.seed)
                nudged = {"kind": "nudged", "task": task, "settings": settings, "runs": args.nudges,
                          "result": nudged_mismatches(task, bodies, args.seed, steps, r, args.nudges)}
                rows.add(nudged)
            r["nudged"] = nudged["result"]
        results.append(r)
        problems = ", ".join(f"{k} {v}" for k, v in r["problems"].items() if v) or "none"
        theirs = (f"{r['unstable_evogym']} ({r['unstable_voxel_only']} / {r['unstable_evogym_only']})"
                  if "unstable_evogym" in r else "not run")
        print(f"| {task} | {r['difficulty']} | {r['env_steps']} | {problems} | {r['unstable_voxel']} / {theirs} |",
              flush=True)
        for n in r.get("nudged", []):
            print(f"|   {n['body']} nudged {n['runs']} times | | | | unstable runs: {n['voxel']} / {n['evogym']} |")
    if args.out:
        lines = ",\n".join(json.dumps(rounded(r, 4), separators=(",", ":")) for r in results)
        args.out.write_text('{"command":"benchmarks/compare/task_stability.py","settings":%s,"tasks":[\n%s\n]}\n'
                            % (json.dumps(settings), lines))


if __name__ == "__main__":
    main()
