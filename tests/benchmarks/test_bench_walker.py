"""Simulation speed of ``gdabench/Walker-v1``: environment steps per second on one core.

Target: at least 3 times Evolution Gym's env steps per second, measured side by side by
``benchmarks/compare/walker_fidelity.py`` (in the Evolution Gym plugin's venv).  One round is a full 500-step episode
of random actions through ``gymnasium.make``'s wrappers, reset included; ``extra_info`` holds the steps per second at
the median round.

    python -m pytest tests/benchmarks/test_bench_walker.py --benchmark-enable --benchmark-columns=median,rounds
"""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest

import gdabench

STEPS = 500
BODIES = {
    "all-actuators": "34343/43434/34343/43434/34343",  # the most points and springs a 5x5 body has
    "mixed": "33333/31113/31013/31013/31013",
    "legged": "00000/33333/44344/40004/40004",
}


def play(env: gymnasium.Env, actions: np.ndarray) -> int:
    env.reset(seed=0)
    for steps, action in enumerate(actions, start=1):
        _, _, terminated, truncated, info = env.step(action)
        assert "unstable" not in info
        if terminated or truncated:
            return steps
    return len(actions)


def record_speed(benchmark, steps: int) -> None:
    if benchmark.stats is not None:  # None when benchmarks are disabled (the test suite's default)
        benchmark.extra_info["steps_per_second"] = round(steps / benchmark.stats.stats.median)


@pytest.mark.parametrize("name", BODIES)
def test_bench_walker_episode(benchmark, name):
    env = gymnasium.make("gdabench/Walker-v1", body=BODIES[name])
    actions = np.random.default_rng(0).uniform(0.6, 1.6, size=(STEPS, *env.action_space.shape))
    steps = benchmark.pedantic(play, args=(env, actions), rounds=5, warmup_rounds=1)
    assert steps == STEPS
    record_speed(benchmark, STEPS)


def test_bench_walker_random_bodies(benchmark):
    """Twenty random 5x5 bodies from Evolution Gym's sampler, one episode each (env creation included)."""
    rng = np.random.default_rng(0)
    bodies = [gdabench.random_body(rng).text for _ in range(20)]
    actions = [rng.uniform(0.6, 1.6, size=(STEPS, 25)) for _ in bodies]

    def episodes() -> int:
        total = 0
        for body, acts in zip(bodies, actions):
            env = gymnasium.make("gdabench/Walker-v1", body=body)
            total += play(env, acts[:, : env.action_space.shape[0]])
        return total

    total = benchmark.pedantic(episodes, rounds=3)
    assert total == STEPS * len(bodies)
    record_speed(benchmark, total)
