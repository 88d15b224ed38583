"""Fidelity of gdabench's walker engines to Evolution Gym 2.0's Walker-v0: same bodies, same actions.

``--engine voxel`` (the default) checks ``gdabench/Walker-v2`` (the batched voxel engine),
``--engine pymunk`` ``gdabench/Walker-v1`` (the pymunk simulator; ``--physics`` overrides its
constants).

Run it in the Evolution Gym plugin's venv (``bash plugins/gdabench-evogym/install.sh``), which
has both simulators.  The body set is reproducible from ``--seed``: ``--random-bodies`` bodies
from Evolution Gym's own sampler (body ``i`` drawn with Python's and numpy's global generators
seeded ``seed * 1_000_003 + i``) plus the hand-made bodies of :data:`STRUCTURED` (solid blocks of
each actuator with rigid or soft parts, legged bodies, worms).  Random body ``i`` belongs to the
calibration part when ``i`` is even and to the held-out part when it is odd; hand-made bodies
alternate the same way.  Every body plays every gait of :data:`GAITS` (open-loop sinusoids with
different periods, phases per column and per row, vertical actuators in and out of phase with
horizontal ones) and one episode of random actions seeded by the body, on both simulators.

Per part it prints, over all (body, gait) episodes: Spearman and Pearson correlation of the
episode returns, sign agreement, the share of positive returns in each simulator, the median RMS
gap between the two centre-of-mass x trajectories (in voxels), and the unstable episodes of each
simulator (and those unstable in one only).  The last lines give both simulators' env steps per
second, timed side by side in this run (episodes interleaved), and their ratio.

    python benchmarks/compare/walker_fidelity.py                           # the full benchmark
    python benchmarks/compare/walker_fidelity.py --engine pymunk           # the pymunk walker (~30 min)
    python benchmarks/compare/walker_fidelity.py --random-bodies 20 --gaits wave20,random
    python benchmarks/compare/walker_fidelity.py --evogym-cache /tmp/evo.jsonl --part calibration --physics friction=2.0

``--evogym-cache FILE`` stores Evolution Gym's episodes (JSON lines) and reuses them on later
runs, for calibration sweeps; speeds are printed only for episodes simulated in this run.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import random
import sys
import time
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, Callable

import gymnasium
import numpy as np

import gdabench
from gdabench.controllers.open_loop import Pattern
from gdabench.envs.walker.env import ENGINES
from gdabench.envs.walker.sim import WalkerPhysics
from gdabench.errors import ConfigError

STEPS = 500
VOXEL = 0.1
#: centre-of-mass x is recorded every this many steps
TRACE_EVERY = 10

#: open-loop gaits: (period, amplitude, center, phase per column, phase per row, vertical phase)
GAITS: dict[str, Pattern | None] = {
    "wave20": Pattern(20.0, 0.5, 1.1, 1.0, 0.0, math.pi / 2),
    "wave40": Pattern(40.0, 0.5, 1.1, 1.0, 0.0, math.pi / 2),
    "back20-inphase": Pattern(20.0, 0.5, 1.1, -1.0, 0.0, 0.0),
    "rows30-antiphase": Pattern(30.0, 0.5, 1.1, 0.0, 1.0, math.pi),
    "pulse12": Pattern(12.0, 0.4, 1.0, 0.0, 0.0, math.pi),
    "random": None,  # uniform actions in [0.6, 1.6], seeded by the body
}

#: hand-made bodies, rows top to bottom
STRUCTURED = [
    "33333/33333/33333/33333/33333",  # solid blocks of each actuator
    "44444/44444/44444/44444/44444",
    "11111/11111/33333/11111/11111",  # rigid blocks with a band of muscle
    "11111/11111/44444/11111/11111",
    "22222/22222/33333/22222/22222",  # soft blocks with a band of muscle
    "22222/22222/44444/22222/22222",
    "34343/43434/34343/43434/34343",  # checkerboard of actuators
    "33333/40004/40004",  # bridge on two legs
    "33333/44444/40004/40004/40004",
    "11111/13331/40004/40004/40004",
    "33333/31113/31013/31013/31013",
    "00000/33333/44344/40004/40004",
    "11111/44444/40404/40404/40404",  # three legs
    "22222/33333/30003/40004/40004",
    "00000/00000/00000/33333/33333",  # worms
    "00000/00000/00000/00000/33333",
    "00000/00000/00000/00000/44444",
    "00000/00000/00000/00000/34343",
    "00000/00000/00000/44444/33333",
    "11111/22222/33333/44444/00000",  # rigid and soft parts
    "10001/13331/13331/14441/10001",
    "22222/20002/34443/20002/22222",
    "40000/44000/44400/44440/44444",  # wedges
    "00004/00044/00444/04444/44444",
]


@dataclass(frozen=True)
class Case:
    """One body of the set: its text, the part it belongs to and the seed of its random actions."""

    body: str
    part: str
    seed: int


def body_set(seed: int, n_random: int) -> list[Case]:
    """The reproducible body set (see the module docstring)."""
    with contextlib.redirect_stdout(io.StringIO()):
        from evogym import sample_robot
    cases = []
    for i in range(n_random):
        body_seed = seed * 1_000_003 + i
        random.seed(body_seed)
        np.random.seed(body_seed % 2**32)
        voxels, _ = sample_robot((5, 5))
        cases.append(
            Case(gdabench.Body(voxels.astype(int)).text, "calibration" if i % 2 == 0 else "held-out", body_seed)
        )
    for i, text in enumerate(STRUCTURED):
        cases.append(Case(text, "calibration" if i % 2 == 0 else "held-out", seed * 1_000_003 + 500_000 + i))
    return cases


def actions_for(gait: str, actuators: np.ndarray, seed: int, steps: int) -> np.ndarray:
    """The (steps, n_actuators) actions of ``gait`` for a body with these actuator voxels."""
    pattern = GAITS[gait]
    if pattern is None:
        return np.random.default_rng(seed).uniform(0.6, 1.6, size=(steps, len(actuators)))
    phases = pattern.phases(actuators)
    return np.clip([pattern.action(phases, t) for t in range(steps)], 0.6, 1.6)


def play(env: gymnasium.Env, actions: np.ndarray, com_x: Callable[[], float]) -> dict[str, Any]:
    """One episode; returns its return, whether it ended unstable, the CoM x trace and its time."""
    env.reset(seed=0)
    trace, total, unstable = [com_x()], 0.0, False
    start = time.perf_counter()
    steps = 0
    for t, action in enumerate(actions):
        _, reward, terminated, _, info = env.step(action)
        total += float(reward)
        steps = t + 1
        if steps % TRACE_EVERY == 0:
            trace.append(com_x())
        if terminated:
            unstable = bool("unstable" in info or reward < -1.0)
            break
    seconds = time.perf_counter() - start
    return {"return": total, "unstable": unstable, "trace": trace, "steps": steps, "seconds": seconds}


def evogym_episode(case: Case, gait: str, steps: int) -> dict[str, Any]:
    with contextlib.redirect_stdout(io.StringIO()):  # it announces its version and unstable episodes
        import evogym.envs  # noqa: F401 - registers Walker-v0

        body = gdabench.Body.from_text(case.body)
        env = gymnasium.make("Walker-v0", body=body.voxels.astype(float))
        sim = env.unwrapped
        width = body.shape[1]
        index = sim.get_actuator_indices("robot")
        actuators = np.array([(i // width, i % width, body.voxels.flat[i]) for i in index], dtype=np.int64)
        com_x = lambda: float(sim.object_pos_at_time(sim.get_time(), "robot")[0].mean())  # noqa: E731
        result = play(env, actions_for(gait, actuators, case.seed, steps), com_x)
        env.close()
    return result


def walker_episode(case: Case, gait: str, steps: int, engine: str, physics: WalkerPhysics) -> dict[str, Any]:
    if engine == "pymunk":
        env = gymnasium.make(ENGINES[engine], body=case.body, physics=physics)
        sim = env.unwrapped
        com_x = lambda: float(sim.sim.positions[:, 0].mean())  # noqa: E731
    else:
        env = gymnasium.make(ENGINES[engine], body=case.body)
        sim = env.unwrapped
        n = len(sim.batch.tables.objects[0].pos)
        com_x = lambda: float(sim.batch.state.pos[0, :n, 0].mean())  # noqa: E731
    result = play(env, actions_for(gait, sim.actuator_voxels, case.seed, steps), com_x)
    env.close()
    return result


def ranks(x: np.ndarray) -> np.ndarray:
    """Ranks of ``x`` from 0, ties sharing their mean rank."""
    order = np.argsort(x, kind="stable")
    r = np.empty(len(x))
    r[order] = np.arange(len(x))
    _, inverse, counts = np.unique(x, return_inverse=True, return_counts=True)
    sums = np.bincount(inverse, weights=r)
    return (sums / counts)[inverse]


def pearson(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.corrcoef(a, b)[0, 1]) if len(a) > 1 and a.std() > 0 and b.std() > 0 else float("nan")


def table(rows: list[dict[str, Any]]) -> dict[str, float]:
    """The comparison figures of one part (see the module docstring)."""
    ours = np.array([r["ours"]["return"] for r in rows])
    theirs = np.array([r["evogym"]["return"] for r in rows])
    gaps = []
    for r in rows:
        a, b = np.array(r["ours"]["trace"]), np.array(r["evogym"]["trace"])
        n = min(len(a), len(b))
        gaps.append(np.sqrt(np.mean((a[:n] - a[0] - (b[:n] - b[0])) ** 2)) / VOXEL)
    u_ours = np.array([r["ours"]["unstable"] for r in rows])
    u_theirs = np.array([r["evogym"]["unstable"] for r in rows])
    return {
        "bodies": len({r["body"] for r in rows}),
        "episodes": len(rows),
        "spearman": pearson(ranks(ours), ranks(theirs)),
        "pearson": pearson(ours, theirs),
        "sign_agreement": float(np.mean(np.sign(ours) == np.sign(theirs))),
        "positive_ours": float(np.mean(ours > 0)),
        "positive_evogym": float(np.mean(theirs > 0)),
        "trajectory_gap_voxels": float(np.median(gaps)),
        "unstable_ours": float(u_ours.mean()),
        "unstable_evogym": float(u_theirs.mean()),
        "unstable_ours_only": float((u_ours & ~u_theirs).mean()),
        "unstable_evogym_only": float((u_theirs & ~u_ours).mean()),
    }


def print_table(name: str, t: dict[str, float], per_gait: dict[str, float]) -> None:
    print(f"{name}: {t['bodies']} bodies, {t['episodes']} episodes")
    print(
        f"  return Spearman {t['spearman']:.3f}   Pearson {t['pearson']:.3f}   sign agreement "
        f"{100 * t['sign_agreement']:.1f}%"
    )
    print(f"  positive returns: ours {100 * t['positive_ours']:.1f}%, Evolution Gym {100 * t['positive_evogym']:.1f}%")
    print(f"  centre-of-mass x trajectory gap (RMS, median over episodes): {t['trajectory_gap_voxels']:.2f} voxels")
    print(
        f"  unstable episodes: ours {100 * t['unstable_ours']:.1f}%, Evolution Gym {100 * t['unstable_evogym']:.1f}%,"
        f" ours only {100 * t['unstable_ours_only']:.1f}%, Evolution Gym only {100 * t['unstable_evogym_only']:.1f}%"
    )
    print("  Spearman per gait: " + ", ".join(f"{g} {v:.2f}" for g, v in per_gait.items()))


def load_cache(path: Path | None) -> dict[str, dict[str, Any]]:
    if path is None or not path.exists():
        return {}
    return {entry["key"]: entry["result"] for entry in map(json.loads, path.read_text().splitlines())}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random-bodies", type=int, default=300)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--steps", type=int, default=STEPS)
    parser.add_argument("--part", choices=("all", "calibration", "held-out"), default="all")
    parser.add_argument("--gaits", default=",".join(GAITS), help="comma-separated names from: " + ", ".join(GAITS))
    parser.add_argument("--no-structured", action="store_true", help="random bodies only")
    parser.add_argument(
        "--engine", choices=tuple(ENGINES), default="voxel", help="which walker to check (default: voxel)"
    )
    parser.add_argument(
        "--physics", nargs="*", default=[], metavar="KEY=VALUE", help="override WalkerPhysics fields (pymunk)"
    )
    parser.add_argument(
        "--evogym-cache", type=Path, help="JSON lines file of Evolution Gym episodes to reuse and extend"
    )
    parser.add_argument("--json", type=Path, help="write every episode of both simulators here")
    parser.add_argument(
        "--shard",
        default="0/1",
        metavar="K/N",
        help="play only bodies K, K+N, K+2N, ... of the set (to fill a cache in parallel)",
    )
    args = parser.parse_args(argv)
    gaits = args.gaits.split(",")
    unknown = [g for g in gaits if g not in GAITS]
    if unknown:
        print(f"error: unknown gait {unknown[0]!r}; gaits: {', '.join(GAITS)}", file=sys.stderr)
        raise SystemExit(2)
    try:
        physics = WalkerPhysics().with_overrides(args.physics)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
    try:
        cases = body_set(args.seed, args.random_bodies)
    except ImportError as exc:
        print(
            f"error: Evolution Gym is not installed ({exc}); run this in plugins/gdabench-evogym's venv",
            file=sys.stderr,
        )
        raise SystemExit(2) from None
    if args.no_structured:
        cases = [c for c in cases if c.seed - args.seed * 1_000_003 < 500_000]
    if args.part != "all":
        cases = [c for c in cases if c.part == args.part]
    shard, n_shards = (int(v) for v in args.shard.split("/"))
    cases = cases[shard::n_shards]
    cache = load_cache(args.evogym_cache)
    cache_out = args.evogym_cache.open("a") if args.evogym_cache else None
    rows = []
    timing = {"ours": [0, 0.0], "evogym": [0, 0.0]}
    for case in cases:
        for gait in gaits:
            key = f"{case.body}|{gait}|{case.seed}|{args.steps}"
            theirs = cache.get(key)
            if theirs is None:
                theirs = evogym_episode(case, gait, args.steps)
                timing["evogym"][0] += theirs["steps"]
                timing["evogym"][1] += theirs["seconds"]
                if cache_out is not None:
                    cache_out.write(json.dumps({"key": key, "result": theirs}) + "\n")
                    cache_out.flush()
            ours = walker_episode(case, gait, args.steps, args.engine, physics)
            timing["ours"][0] += ours["steps"]
            timing["ours"][1] += ours["seconds"]
            rows.append({"body": case.body, "part": case.part, "gait": gait, "ours": ours, "evogym": theirs})
    if cache_out is not None:
        cache_out.close()
    print(
        f"gdabench {ENGINES[args.engine]} against Evolution Gym 2.0 Walker-v0; seed {args.seed}, "
        f"{args.steps} steps, gaits {', '.join(gaits)}"
    )
    if args.engine == "pymunk":
        changed = {
            f.name: getattr(physics, f.name)
            for f in fields(WalkerPhysics)
            if getattr(physics, f.name) != getattr(WalkerPhysics(), f.name)
        }
        print(f"physics: WalkerPhysics defaults{' with ' + json.dumps(changed) if changed else ''}")
    for part in ("calibration", "held-out"):
        part_rows = [r for r in rows if r["part"] == part]
        if part_rows:
            per_gait = {g: table([r for r in part_rows if r["gait"] == g])["spearman"] for g in gaits}
            print_table(part, table(part_rows), per_gait)
    (n_ours, s_ours), (n_evo, s_evo) = timing["ours"], timing["evogym"]
    if n_evo:
        print(
            f"speed (env steps/s, one process, episodes interleaved): Evolution Gym {n_evo / s_evo:.0f}, "
            f"ours {n_ours / s_ours:.0f}, ratio {(n_ours / s_ours) / (n_evo / s_evo):.2f}"
        )
    else:
        print(f"speed: ours {n_ours / s_ours:.0f} env steps/s (Evolution Gym's episodes came from the cache: no ratio)")
    if args.json:
        args.json.write_text(json.dumps(rows))


if __name__ == "__main__":
    main()
