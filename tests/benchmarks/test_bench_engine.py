"""The two inner loops of a co-design generation: the voxel engine stepping a batch of bodies, and one
lockstep PPO minibatch update of all their networks.  A regression in either slows every walker run.

    python -m pytest tests/benchmarks/test_bench_engine.py --benchmark-enable --benchmark-columns=median,rounds

``extra_info`` holds env steps per second (engine) and updates per second (PPO) at the median round.
The engine runs on one thread here (``GDABENCH_ENGINE_THREADS``'s choice for a trial beside other work);
``test_bench_engine_step[threads=2]`` shows what a second thread gives on an idle machine.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest
import torch

import gdabench
from gdabench.envs.voxel.batch import TaskBatch

BODIES = 25  # a generation
STEPS = 100  # env steps per round


def bodies(n: int = BODIES) -> list[str]:
    rng = np.random.default_rng(0)
    return [gdabench.random_body(rng).text for _ in range(n)]


@pytest.mark.parametrize("threads", [1, 2], ids=lambda t: f"threads={t}")
def test_bench_engine_step(benchmark, threads):
    if threads > numba.config.NUMBA_NUM_THREADS:
        pytest.skip(f"Numba has {numba.config.NUMBA_NUM_THREADS} thread(s) here")
    batch = TaskBatch("Walker-v0", bodies())
    batch.reset()
    rng = np.random.default_rng(1)
    width = max(batch.act_sizes)
    actions = rng.uniform(0.6, 1.6, size=(STEPS, batch.num_envs, width))
    previous = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:

        def play() -> int:
            for a in actions:
                batch.step(a)
            return STEPS

        benchmark.pedantic(play, rounds=5, warmup_rounds=1)
    finally:
        numba.set_num_threads(previous)
    if benchmark.stats is not None:  # None when benchmarks are disabled (the test suite's default)
        benchmark.extra_info["env_steps_per_second"] = round(STEPS * BODIES / benchmark.stats.stats.median)


def test_bench_lockstep_ppo_update(benchmark):
    """One minibatch step (Evolution Gym's 4 samples per body) of 25 bodies' actor-critics, as in training."""
    from gdabench.controllers.ppo.networks import ActorCritic, Stacked
    from gdabench.controllers.ppo.update import LockstepUpdate, LossSettings, Minibatch

    torch.manual_seed(0)
    sizes = [(2 + 2 * (10 + i % 20), 4 + i % 12) for i in range(BODIES)]  # walker-like observation and action sizes
    nets = Stacked([ActorCritic(o, a) for o, a in sizes], max(o for o, _ in sizes), max(a for _, a in sizes))
    update = LockstepUpdate(nets, LossSettings(0.1, 0.5, 0.01, 2.5e-4, 0.5))
    m = 4
    batch = Minibatch(torch.randn(BODIES, m, nets.n_obs), torch.randn(BODIES, m, nets.n_act),
                      torch.randn(BODIES, m), torch.randn(BODIES, m), torch.randn(BODIES, m))  # fmt: skip
    with torch.no_grad():
        before = [p.clone() for p in nets.params]
    losses = benchmark.pedantic(update, args=(batch,), rounds=20, iterations=10, warmup_rounds=2)
    assert losses.shape == (BODIES, 2) and torch.isfinite(losses).all()
    assert any(not torch.equal(a, b) for a, b in zip(before, nets.params))  # the step moved the networks
    if benchmark.stats is not None:
        benchmark.extra_info["updates_per_second"] = round(1 / benchmark.stats.stats.median)
