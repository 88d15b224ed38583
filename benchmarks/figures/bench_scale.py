"""Evaluation throughput of the executors: parallel speed-up and per-evaluation overhead.

Prints, for each executor, evaluations per second with 1 and with 2 workers on a CPU-bound
environment (the speed-up target is 1.8x on 2 cores), and the time per evaluation of each
executor on ``simple``, where evaluating costs nothing and only the executor's overhead is left.

    python benchmarks/figures/bench_scale.py                                  # CPU-bound stand-in (cpu-burn)
    python benchmarks/figures/bench_scale.py --env walker --controller open-loop
    python benchmarks/figures/bench_scale.py --executors process --repeats 5

Bodies are evaluated in batches of ``--population`` as the harness does (one batch per
generation), after a warm-up batch that starts the workers; figures are medians over
``--repeats``.  Speed-ups measured on a machine shared with other work understate the real one,
so two figures that do not depend on other load are printed too: *busy*, the share of the
workers' wall time spent inside evaluations (what the executor leaves idle between bodies is
its own loss), and, for environments that report ``cpu_seconds`` (the stand-in does), *CPU*,
the share of the evaluations' wall time they actually had a CPU (what other processes took).
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # cpu_burn, for the driver and (via sys.path) its workers

from gdabench import EnvironmentSpec, hookimpl
from gdabench.body import random_body
from gdabench.execution import OK, EvalTask, Executor, SerialExecutor
from gdabench.execution.pool import ProcessExecutor
from gdabench.experiment.config import PluginChoice, parse_params
from gdabench.plugins import Registry
from gdabench.specs import Factory


class StandIn:
    @hookimpl
    def gdabench_environments(self):
        return [
            EnvironmentSpec("cpu-burn", "cpu_burn:CpuBurn", "fixed pure-Python CPU work per body (benchmark stand-in)")
        ]


def recipes(
    reg: Registry, env: str, env_params: list[str], controller: str | None, ctrl_params: list[str], shape
) -> tuple[Factory, Factory | None]:
    env_choice = PluginChoice.parse(env).with_params(parse_params(env_params))
    env_recipe = reg.get("environment", env_choice.name).spec.recipe({"shape": shape, **env_choice.params})
    ctrl_recipe = None
    if controller:
        ctrl_choice = PluginChoice.parse(controller).with_params(parse_params(ctrl_params))
        ctrl_recipe = reg.get("controller", ctrl_choice.name).spec.recipe(ctrl_choice.params)
    return env_recipe, ctrl_recipe


def make_tasks(env: Factory, ctrl: Factory | None, n: int, shape, seed: int) -> list[EvalTask]:
    rng, seen = np.random.default_rng(seed), set()
    tasks = []
    for i in range(n):
        body = random_body(rng, shape, exclude=seen)
        seen.add(body.hash)
        tasks.append(EvalTask(body, i, env, ctrl))
    return tasks


def make_executor(kind: str, workers: int, warm: list[Factory]) -> Executor:
    """The evaluation executor ``kind`` (serial, process or ray) with ``workers`` workers."""
    if kind == "serial":
        return SerialExecutor()
    if kind == "process":
        return ProcessExecutor(workers, warm=warm)
    from gdabench.execution.ray import RayExecutor

    return RayExecutor(workers, warm=warm)


def rate(
    kind: str, workers: int, tasks: list[EvalTask], population: int, repeats: int, warm: list[Factory]
) -> tuple[float, float, float]:
    """Evaluations per second, busy share and CPU share (medians over ``repeats`` passes through ``tasks``)."""
    rates, busy, cpu = [], [], []
    with make_executor(kind, workers, warm) as executor:
        executor.map(tasks[:workers])  # start the workers
        for _ in range(repeats):
            start = time.perf_counter()
            outcomes = [o for i in range(0, len(tasks), population) for o in executor.map(tasks[i : i + population])]
            wall = time.perf_counter() - start
            bad = [o.message for o in outcomes if o.status != OK]
            if bad:
                raise SystemExit(f"{kind}: {len(bad)} evaluations failed, e.g. {bad[0]}")
            inside = sum(o.seconds for o in outcomes)
            rates.append(len(tasks) / wall)
            busy.append(inside / (workers * wall))
            cpu.append(sum(o.info.get("cpu_seconds", math.nan) for o in outcomes) / inside)
    return statistics.median(rates), statistics.median(busy), statistics.median(cpu)


def shares(busy: float, cpu: float) -> str:
    return f"busy {busy:4.0%}" + ("" if math.isnan(cpu) else f", CPU {cpu:4.0%}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--env", default="cpu-burn", help="environment for the speed-up (default: the CPU-bound stand-in)"
    )
    parser.add_argument("-E", "--env-param", action="append", default=[])
    parser.add_argument("--controller")
    parser.add_argument("-C", "--controller-param", action="append", default=[])
    parser.add_argument("--executors", default="process,ray")
    parser.add_argument("--evals", type=int, default=50, help="evaluations per timed pass of the speed-up")
    parser.add_argument("--overhead-evals", type=int, default=500, help="evaluations per timed pass on simple")
    parser.add_argument("--population", type=int, default=25)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    executors = [e for e in args.executors.split(",") if e]
    reg = Registry(extra_plugins={"bench": StandIn()})
    shape = (5, 5)
    if "ray" in executors:
        import ray

        ray.init(
            num_cpus=2,
            include_dashboard=False,
            logging_level="WARNING",
            runtime_env={"env_vars": {"PYTHONPATH": os.pathsep.join(sys.path)}},
        )
    print(
        f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} at start (shared machines "
        "understate speed-ups)"
    )

    env, ctrl = recipes(reg, args.env, args.env_param, args.controller, args.controller_param, shape)
    warm = [r for r in (env, ctrl) if r is not None]
    tasks = make_tasks(env, ctrl, args.evals, shape, seed=1)
    label = args.env + (f" / {args.controller}" if args.controller else "")
    print(
        f"\nthroughput on {label}: {args.evals} evaluations per pass, batches of {args.population}, median "
        f"of {args.repeats}"
    )
    serial, busy, cpu = rate("serial", 1, tasks, args.population, args.repeats, warm)
    print(f"  serial            {serial:8.2f} evals/s  ({1000 / serial:.1f} ms per evaluation; {shares(busy, cpu)})")
    for kind in executors:
        one, busy1, cpu1 = rate(kind, 1, tasks, args.population, args.repeats, warm)
        two, busy2, cpu2 = rate(kind, 2, tasks, args.population, args.repeats, warm)
        print(f"  {kind:<7} 1 worker  {one:8.2f} evals/s  ({shares(busy1, cpu1)})")
        print(f"  {kind:<7} 2 workers {two:8.2f} evals/s  ({shares(busy2, cpu2)})  speed-up {two / one:.2f}x")

    simple, _ = recipes(reg, "simple", [], None, [], shape)
    light = make_tasks(simple, None, args.overhead_evals, shape, seed=2)
    print(
        f"\nper-evaluation overhead on simple: {args.overhead_evals} evaluations per pass, batches of {args.population}"
    )
    per_eval = {
        kind: 1e3 / rate(kind, 2 if kind != "serial" else 1, light, args.population, args.repeats, [simple])[0]
        for kind in ["serial", *executors]
    }
    for kind, ms in per_eval.items():
        print(f"  {kind:<7} {ms:7.3f} ms per evaluation" + ("" if kind == "serial" else " (2 workers)"))
    if {"process", "ray"} <= set(per_eval):
        print(f"  ray - process: {per_eval['ray'] - per_eval['process']:+.3f} ms per evaluation")


if __name__ == "__main__":
    main()
