"""Cost of the analytic landscapes: scoring a body, and the nk environment's exact optimum.

Run with ``python -m pytest tests/benchmarks/test_bench_landscapes.py --benchmark-enable``
(the normal test run executes each benchmark once, as a smoke test).
"""

from __future__ import annotations

import numpy as np
import pytest

from gdabench import make_env
from gdabench.body import random_body


@pytest.mark.parametrize("name, params", [("two-peaks", {}), ("target", {"class_credit": 0.5}), ("nk", {"k": 4})])
def test_evaluate_100_bodies(benchmark, name, params):
    env = make_env(name, **params)
    rng = np.random.default_rng(0)
    bodies = [random_body(rng) for _ in range(100)]
    rewards = benchmark(lambda: [env.evaluate(b, seed=0) for b in bodies])
    assert len(set(rewards)) > 1


@pytest.mark.parametrize(
    "k, table_seed, path",
    [(2, 0, "unconstrained best is valid"), (5, 0, "validity-aware DP"), (8, 0, "unconstrained best is valid")],
)
def test_nk_exact_optimum_5x5(benchmark, k, table_seed, path):
    """A fresh environment per round, so the cached optimum is recomputed every time."""

    def optimum():
        env = make_env("nk", k=k, table_seed=table_seed)
        return env.optimum, env.upper_bound

    value, bound = benchmark.pedantic(optimum, rounds=3, iterations=1)
    assert value is not None
    assert (value < bound) == (path == "validity-aware DP")
