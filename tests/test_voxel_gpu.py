"""The voxel engine's GPU path (``gdabench.envs.voxel.gpu``): the CPU kernels compiled for CUDA.

Skipped where Numba sees no CUDA device (CI has none); run on a machine with a GPU.  Bit-identity
with the CPU is not expected (NVVM fuses multiply-adds, CUDA's tanh is not glibc's): over the first
10 steps the GPU agrees with the CPU within 1e-6, the bar the CPU engine meets against Evolution
Gym's recorded numbers; on the GPU itself a body steps bit-identically alone and in a batch.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import gdabench
from gdabench.envs.voxel import engine

cuda = pytest.importorskip("numba.cuda")
pytestmark = pytest.mark.skipif(not cuda.is_available(), reason="no CUDA GPU for Numba")


def _bodies(count: int) -> list[gdabench.Body]:
    rng = np.random.default_rng(11)
    return [gdabench.random_body(rng) for _ in range(count)]


def _actions(t: int, n: int, width: int) -> np.ndarray:
    wave = 1.1 + 0.5 * np.sin(2 * math.pi * t / 20 + np.arange(width))
    return np.ascontiguousarray(np.broadcast_to(wave, (n, width)))


def test_gpu_steps_as_the_cpu_does_to_rounding():
    from gdabench.envs.voxel import gpu

    bodies = _bodies(6)
    tables = engine.body_tables(bodies)
    index = np.array([0, 1, 2, 3, 4, 5, 0])
    dev = gpu.to_device(tables)
    cpu_state, gpu_state = engine.reset(tables, index), gpu.reset(dev, index)
    active = np.array([True] * 6 + [False])
    for t in range(10):
        a = _actions(t, len(index), tables.max_actuators)
        cpu_state, cpu_out = engine.step(tables, cpu_state, a, active)
        gpu_state, gpu_out = gpu.step(dev, gpu_state, a, active)
    np.testing.assert_allclose(gpu_state.pos.copy_to_host(), cpu_state.pos, rtol=0, atol=1e-6)
    np.testing.assert_allclose(gpu_state.vel.copy_to_host(), cpu_state.vel, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(gpu_out.unstable.copy_to_host(), cpu_out.unstable)
    np.testing.assert_array_equal(gpu_state.pos.copy_to_host()[6], tables.init_pos[0])  # inactive: not stepped


def test_a_body_steps_bit_identically_alone_and_in_a_batch_on_the_gpu():
    from gdabench.envs.voxel import gpu

    bodies = _bodies(8)
    tables = engine.body_tables(bodies)
    batch = gpu.to_device(tables)
    alone = gpu.to_device(engine.body_tables(bodies[3:4], pad=tables))
    in_batch, by_itself = gpu.reset(batch, np.arange(8)), gpu.reset(alone, np.array([0]))
    for t in range(20):
        a = _actions(t, 8, tables.max_actuators)
        in_batch, _ = gpu.step(batch, in_batch, a)
        by_itself, _ = gpu.step(alone, by_itself, a[3:4])
    assert np.array_equal(in_batch.pos.copy_to_host()[3], by_itself.pos.copy_to_host()[0])


@pytest.mark.parametrize("task", ["Walker-v0", "Carrier-v0", "BridgeWalker-v0"])
def test_a_task_batch_on_the_gpu_plays_as_on_the_cpu(task):
    from gdabench.envs.voxel.batch import TaskBatch

    bodies = [b.text for b in _bodies(4)]
    cpu, gpu_batch = TaskBatch(task, bodies), TaskBatch(task, bodies, device="cuda")
    for batch in (cpu, gpu_batch):
        batch.seed([0, 1, 2, 3])
        batch.reset()
    for t in range(10):
        a = _actions(t, 4, cpu.tables.max_actuators)
        obs_c, reward_c, done_c, _ = cpu.step(a)
        obs_g, reward_g, done_g, _ = gpu_batch.step(a)
    np.testing.assert_allclose(obs_g, obs_c, rtol=0, atol=1e-6)
    np.testing.assert_allclose(reward_g, reward_c, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(done_g, done_c)
