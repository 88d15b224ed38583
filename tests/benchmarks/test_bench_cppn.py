"""Seconds per generation of the ``cppn`` designer itself (ask + tell, no evaluation cost).

Run with ``python -m pytest tests/benchmarks/test_bench_cppn.py --benchmark-enable`` (the normal
test run executes one generation, as a smoke test).  The 40 rounds are the 40 generations of a
default run (1,000 evaluations, population 25, seed 0) on the ``simple`` reward, so the figure
includes the growing cost of rejecting already-seen bodies.
"""

from __future__ import annotations

from gdabench.designers.cppn import CppnNeat
from gdabench.envs.simple import SumOfVoxels
from gdabench.seeding import designer_seed

GENERATIONS = 40


def test_cppn_seconds_per_generation(benchmark):
    env = SumOfVoxels(shape=(5, 5))
    designer = CppnNeat(seed=designer_seed(0))

    def generation() -> int:
        bodies = designer.ask()
        designer.tell(bodies, [env.evaluate(b, seed=0) for b in bodies])
        return len(bodies)

    sizes = benchmark.pedantic(generation, rounds=GENERATIONS, iterations=1)
    assert sizes == 25
    assert designer.generation >= 1
    benchmark.extra_info["generations"] = designer.generation
