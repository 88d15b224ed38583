"""Throughput of the core: validity checks, a GA generation on `simple`, a whole small run.

Run with ``python -m pytest tests/benchmarks/test_bench_core.py --benchmark-enable``
(the normal test run executes each benchmark once, as a smoke test).
"""

from __future__ import annotations

import numpy as np

from gdabench import Experiment, PluginChoice
from gdabench.body import EVOGYM_VOXEL_WEIGHTS, invalid_reason
from gdabench.designers.ga import GeneticAlgorithm
from gdabench.envs.simple import SumOfVoxels
from gdabench.running.runner import compare
from gdabench.seeding import designer_seed


def test_validity_check(benchmark):
    rng = np.random.default_rng(0)
    grids = rng.choice(5, size=(1000, 5, 5), p=EVOGYM_VOXEL_WEIGHTS).astype(np.int8)

    def check_all():
        return sum(invalid_reason(g) is None for g in grids)

    valid = benchmark(check_all)
    assert 0 < valid < 1000
    benchmark.extra_info["checks_per_call"] = len(grids)


def test_ga_generation_on_simple(benchmark):
    """ask + evaluate + tell of one GA generation (25 bodies), from a mid-run state."""
    env = SumOfVoxels()
    ga = GeneticAlgorithm(population=25, budget=10**6, survivors=5, seed=designer_seed(0))
    bodies = ga.ask()
    ga.tell(bodies, [env.evaluate(b, seed=0) for b in bodies])

    def generation():
        gen = ga.ask()
        ga.tell(gen, [env.evaluate(b, seed=0) for b in gen])
        return gen

    assert len(benchmark(generation)) == 20


def test_harness_run_ga_simple_1000(benchmark, tmp_path):
    """The whole harness (rows, parquet after every generation, checkpoints) for 1,000 evaluations."""
    counter = iter(range(10**6))

    def run():
        exp = Experiment(designers=(PluginChoice("ga"),), envs=PluginChoice("simple"), budget=1000)
        return compare(exp, tmp_path / f"run{next(counter)}")

    run_dir = benchmark.pedantic(run, rounds=3, iterations=1)
    assert run_dir.meta["status"] == "complete"
