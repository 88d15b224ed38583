"""Stability of the walker simulator: random valid bodies driven by random actions.

For each body (Evolution Gym's sampler, ``gdabench.random_body``) one episode of uniformly
random actions in [0.6, 1.6] (or, with ``--actions open-loop``, the open-loop controller's
default gait) is played on the walker of ``--engine`` (``voxel``: ``gdabench/Walker-v2``, the
default; ``pymunk``: ``gdabench/Walker-v1``; ``evogym``: Evolution Gym 2.0's own Walker-v0, run in the
Evolution Gym plugin's venv, for reference).  Prints the share of
episodes that ended unstable (-3, terminated) with the reasons, and checks that nothing
slipped through undetected: no exception, no NaN, every observation inside the observation
space, no step moving the centre of mass implausibly far, every unstable step rewarded -3.

    python benchmarks/compare/walker_stability.py --bodies 1000 --steps 500 --seed 0
    python benchmarks/compare/walker_stability.py --bodies 1000 --actions open-loop
    python benchmarks/compare/walker_stability.py --bodies 200 --engine pymunk --physics substeps=4
    python benchmarks/compare/walker_stability.py --bodies 100 --actions open-loop --engine evogym
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import io
import sys
import time

import gymnasium
import numpy as np

import gdabench
from gdabench.controllers.open_loop import OpenLoop
from gdabench.envs.walker.env import ENGINES
from gdabench.envs.walker.sim import WalkerPhysics
from gdabench.errors import ConfigError

#: per-step centre-of-mass motion no stable simulation produces (100 m/s, max_speed, for 0.003 s)
IMPLAUSIBLE_STEP = 0.3
#: what Evolution Gym adds to the reward of an unstable step
UNSTABLE_PENALTY = -3.0


def step_problems(obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray, unstable: np.ndarray,
                  still_reward: np.ndarray, moved: np.ndarray, bound: float) -> dict[str, np.ndarray]:
    """What went wrong undetected in one step of N environments (each a bool array): a NaN in the
    observation or reward, an observation outside [-bound, bound], an unstable step not ended with the
    task's reward for standing still plus the penalty of -3 (to 1e-9: a goal bonus may be added before or
    after it), a stable step moving the centre of mass
    ``moved`` metres, implausibly far."""
    return {
        "nan": ~(np.isfinite(obs).all(axis=1) & np.isfinite(reward)),
        "outside": ~(np.abs(obs) <= bound).all(axis=1),
        "bad_penalty": unstable & ((np.abs(reward - (still_reward + UNSTABLE_PENALTY)) > 1e-9) | ~terminated),
        "implausible": ~unstable & (moved > IMPLAUSIBLE_STEP),
    }


def make(body: gdabench.Body, engine: str, physics: WalkerPhysics, steps: int) -> tuple[gymnasium.Env, np.ndarray]:
    """The environment, and its actuator voxels (row, col, code) in action order."""
    if engine == "evogym":
        with contextlib.redirect_stdout(io.StringIO()):
            import evogym.envs  # noqa: F401 - registers Walker-v0

            env = gymnasium.make("Walker-v0", body=body.voxels.astype(float), max_episode_steps=steps)
        width = body.shape[1]
        index = env.unwrapped.get_actuator_indices("robot")
        return env, np.array([(i // width, i % width, body.voxels.flat[i]) for i in index], dtype=np.int64)
    extra = {"physics": physics} if engine == "pymunk" else {}
    env = gymnasium.make(ENGINES[engine], body=body, max_episode_steps=steps, **extra)
    return env, env.unwrapped.actuator_voxels


def episode(body: gdabench.Body, engine: str, physics: WalkerPhysics, rng: np.random.Generator, steps: int,
            actions: str) -> dict:
    env, actuators = make(body, engine, physics, steps)
    out = {"unstable": None, "nan": False, "outside": False, "implausible": False, "bad_penalty": False, "steps": 0}
    obs, _ = env.reset(seed=0)
    space = env.observation_space
    gait = OpenLoop().pattern
    phases = gait.phases(actuators)
    while True:
        if actions == "random":
            action = rng.uniform(0.6, 1.6, size=env.action_space.shape)
        else:
            action = np.clip(gait.action(phases, out["steps"]), 0.6, 1.6)
        with contextlib.redirect_stdout(io.StringIO()):  # Evolution Gym prints its unstable steps
            obs, reward, terminated, truncated, info = env.step(action)
        if engine == "evogym" and terminated and reward < -1.0:
            info = {"unstable": "self-intersection"}
        out["steps"] += 1
        unstable = "unstable" in info
        if unstable:
            out["unstable"] = info["unstable"]
        # the walker's reward is the centre of mass's x motion, plus a goal bonus of 1; a still step earns 0
        found = step_problems(np.asarray(obs, dtype=np.float64)[None], np.array([reward]), np.array([terminated]),
                              np.array([unstable]), np.zeros(1), np.array([abs(reward) - 1.0]), space.high.max())
        for key, flags in found.items():
            out[key] |= bool(flags[0])
        if terminated or truncated:
            return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bodies", type=int, default=1000)
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--shape", default="5x5")
    parser.add_argument("--actions", choices=("random", "open-loop"), default="random")
    parser.add_argument("--engine", choices=(*ENGINES, "evogym"), default="voxel")
    parser.add_argument(
        "--physics", nargs="*", default=[], metavar="KEY=VALUE", help="override WalkerPhysics fields (pymunk)"
    )
    args = parser.parse_args()
    try:
        physics = WalkerPhysics().with_overrides(args.physics)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
    shape = tuple(int(v) for v in args.shape.split("x"))
    body_rng, action_rng = (np.random.default_rng(s) for s in np.random.SeedSequence(args.seed).spawn(2))
    reasons: collections.Counter[str] = collections.Counter()
    problems: collections.Counter[str] = collections.Counter()
    examples: dict[str, str] = {}
    total_steps, start = 0, time.perf_counter()
    for _ in range(args.bodies):
        body = gdabench.random_body(body_rng, shape)
        try:
            result = episode(body, args.engine, physics, action_rng, args.steps, args.actions)
        except Exception as exc:  # noqa: BLE001 - counted and reported, never hidden
            problems["exception"] += 1
            examples.setdefault("exception", f"{body.text}: {type(exc).__name__}: {exc}")
            continue
        total_steps += result["steps"]
        if result["unstable"]:
            reasons[result["unstable"]] += 1
            examples.setdefault(result["unstable"], body.text)
        for key in ("nan", "outside", "implausible", "bad_penalty"):
            if result[key]:
                problems[key] += 1
                examples.setdefault(key, body.text)
    seconds = time.perf_counter() - start
    unstable = sum(reasons.values())
    print(
        f"{ENGINES.get(args.engine, 'Evolution Gym 2.0 Walker-v0')}: {args.bodies} bodies ({args.shape}), "
        f"{args.actions} actions, {args.steps} steps each, seed {args.seed}"
    )
    print(f"unstable episodes: {unstable} ({100.0 * unstable / args.bodies:.2f}%)")
    for reason, count in reasons.most_common():
        print(f"  {count:5d}  {reason}  (e.g. {examples[reason]})")
    print(f"undetected problems: {sum(problems.values())} {dict(problems) or ''}")
    for key, text in examples.items():
        if key in problems:
            print(f"  {key}: {text}")
    print(f"env steps: {total_steps} in {seconds:.1f} s ({total_steps / seconds:.0f} steps/s including env creation)")


if __name__ == "__main__":
    main()
