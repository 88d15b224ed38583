"""Executor overhead: one generation of `simple` through a pool of two worker processes.

Run with ``python -m pytest tests/benchmarks/test_bench_scale.py --benchmark-enable``.  The
parallel speed-up and the Ray-versus-process comparison are measured by
``python benchmarks/figures/bench_scale.py`` (see its docstring); a tiny run of it here keeps it working.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

from gdabench.body import random_body
from gdabench.execution import EvalTask, Execution, make_executor
from gdabench.specs import Factory

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "figures" / "bench_scale.py"


def test_process_executor_generation_on_simple(benchmark):
    env = Factory.of("gdabench.envs.simple:SumOfVoxels", {"shape": (5, 5)})
    rng = np.random.default_rng(0)
    tasks = [EvalTask(random_body(rng, (5, 5)), i, env) for i in range(25)]
    with make_executor(Execution(workers=2), warm=[env]) as executor:
        executor.map(tasks[:2])  # workers started outside the measurement
        outcomes = benchmark(executor.map, tasks)
    assert [o.reward for o in outcomes] == [float(t.body.voxels.sum()) for t in tasks]
    benchmark.extra_info["evaluations_per_call"] = len(tasks)


def test_bench_scale_script_runs():
    args = [
        "--executors",
        "process",
        "--evals",
        "4",
        "--population",
        "2",
        "--overhead-evals",
        "10",
        "--repeats",
        "1",
        "-E",
        "iterations=1000",
    ]
    result = subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "process 2 workers" in result.stdout and "speed-up" in result.stdout and "ms per evaluation" in result.stdout
