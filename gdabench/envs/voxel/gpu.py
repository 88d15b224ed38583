"""The engine's step on an NVIDIA GPU: the same kernels, compiled by Numba for CUDA, one thread per environment.

Nothing here re-implements physics: :func:`kernels.step_env` (written allocation-free for this) is
called from a CUDA kernel, so the CPU and GPU paths share every line of the model; only where an
environment's temporaries live differs.  State stays on
the device between steps; arrays are Numba device arrays (``torch.as_tensor(x, device="cuda")``
reads them without a copy, through ``__cuda_array_interface__``).

    dev = gpu.to_device(tables)
    state = gpu.reset(dev, body)                 # body: host array of table indices
    state, out = gpu.step(dev, state, actions)   # actions: (N, A) host or device array

Observations and rewards are the task layer's, computed from the state on the host
(``state.pos.copy_to_host()``): the GPU steps the physics only.

Needs ``numba-cuda`` (NVIDIA's CUDA target for Numba) and a CUDA driver; importing this module
without them fails only when a step is compiled.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, fields, replace
from typing import Any

import numba
import numpy as np
from numba import cuda

from . import kernels
from .engine import BodyTables, State, StepOutput, kernel_args

#: threads per block: one environment per thread
THREADS = 64

@functools.cache
def _step_kernel(max_points: int, max_edges: int, max_surface: int) -> Any:
    """The step kernel for bodies padded to these sizes (compiled on first use, once per process).

    An environment's state and temporaries live in its thread's local memory, which the hardware
    interleaves across threads so that a warp's accesses coalesce: 1.4x the env steps/s of keeping
    them in per-environment global arrays, as the CPU does (docs/benchmarks/voxel-engine.md).
    """
    f64 = numba.float64
    point_temps, edge_temps, spring_temps = kernels.POINT_TEMPS, kernels.EDGE_TEMPS, kernels.SPRING_TEMPS  # constants

    @cuda.jit
    def kernel(active, index, actions, pos, vel, vt, unstable, body, terrain):
        i = cuda.grid(1)
        if i >= active.shape[0] or not active[i]:
            return
        wp = cuda.local.array((point_temps, max_points, 2), f64)
        we = cuda.local.array((edge_temps, max_edges, 2), f64)
        ws = cuda.local.array((spring_temps, max_edges), f64)
        wb = cuda.local.array((2, max_surface, 4), f64)
        lp = cuda.local.array((max_points, 2), f64)
        lv = cuda.local.array((max_points, 2), f64)
        lt = cuda.local.array((max_points, 2), f64)
        b = index[i]
        n = body[0][b]
        for m in range(n):
            for c in range(2):
                lp[m, c] = pos[i, m, c]
                lv[m, c] = vel[i, m, c]
                lt[m, c] = vt[i, m, c]
        unstable[i] = kernels.step_env(b, actions[i], lp, lv, lt, body, terrain, wp, we, ws, wb)
        for m in range(n):
            for c in range(2):
                pos[i, m, c] = lp[m, c]
                vel[i, m, c] = lv[m, c]
                vt[i, m, c] = lt[m, c]

    return kernel


@cuda.jit(cache=True)
def _zero_kernel(flat):
    i = cuda.grid(1)
    if i < flat.shape[0]:
        flat[i] = 0


def _blocks(n: int) -> int:
    return (n + THREADS - 1) // THREADS


def _zeros(shape: tuple, dtype: Any = np.float64) -> Any:
    out = cuda.device_array(shape, dtype=dtype)
    flat = out.reshape(-1)
    _zero_kernel[_blocks(flat.shape[0]), THREADS](flat)
    return out


@dataclass
class DeviceEngine:
    """A batch's tables and terrain on the GPU (every array a device array), and what its steps keep."""

    tables: Any
    init_pos: np.ndarray  # on the host: resets index it
    active: Any = None

    def all_active(self, n: int) -> Any:
        if self.active is None or self.active.shape[0] != n:
            self.active = cuda.to_device(np.ones(n, dtype=np.bool_))
        return self.active


def _moved(obj: Any) -> Any:
    return replace(obj, **{f.name: cuda.to_device(np.ascontiguousarray(getattr(obj, f.name)))
                           for f in fields(obj) if isinstance(getattr(obj, f.name), np.ndarray)})


def to_device(tables: BodyTables) -> DeviceEngine:
    """Copy a batch's tables and its world's terrain to the GPU (once per batch)."""
    world = replace(tables.world, terrain=_moved(tables.world.terrain))
    return DeviceEngine(tables=replace(_moved(tables), world=world), init_pos=tables.init_pos)


def reset(dev: DeviceEngine, body: np.ndarray, init_pos: np.ndarray | None = None) -> State:
    """Every environment ``i`` at rest in its body's initial pose (or at ``init_pos``), on the GPU."""
    body = np.asarray(body, dtype=np.int64)
    pos = dev.init_pos[body] if init_pos is None else np.asarray(init_pos, dtype=np.float64)
    return State(pos=cuda.to_device(pos), vel=cuda.to_device(np.zeros_like(pos)),
                 vtrue=cuda.to_device(np.zeros_like(pos)), body=cuda.to_device(body))


def _copy(x: Any) -> Any:
    out = cuda.device_array_like(x)
    out.copy_to_device(x)
    return out


def step(dev: DeviceEngine, state: State, actions: Any, active: Any = None) -> tuple[State, StepOutput]:
    """:func:`engine.step` on the GPU: inputs are kept, the new state and outputs are device arrays."""
    n = state.body.shape[0]
    t = dev.tables
    acts = cuda.to_device(np.ascontiguousarray(actions, dtype=np.float64)) if isinstance(actions, np.ndarray) \
        else actions
    if active is None:
        active = dev.all_active(n)
    elif isinstance(active, np.ndarray):
        active = cuda.to_device(np.ascontiguousarray(active, dtype=np.bool_))
    new = replace(state, pos=_copy(state.pos), vel=_copy(state.vel), vtrue=_copy(state.vtrue))
    out = StepOutput(unstable=_zeros((n,), np.bool_))
    args = (active, state.body, acts, new.pos, new.vel, new.vtrue, out.unstable, *kernel_args(t))
    _step_kernel(t.max_points, t.edges.shape[1], t.surface_points.shape[1])[_blocks(n), THREADS](*args)
    return new, out


class Stepper:
    """:func:`engine.step` for a batch whose state the caller keeps on the host (a task reads it every step):
    the tables go to the GPU once, the state there and back at every step.  What a run with ``device=cuda``
    uses; a loop that keeps everything on the device calls :func:`step` itself."""

    def __init__(self, tables: BodyTables):
        self.dev = to_device(tables)

    def step(self, state: State, actions: np.ndarray, active: np.ndarray) -> tuple[State, StepOutput]:
        on_device = State(pos=cuda.to_device(state.pos), vel=cuda.to_device(state.vel),
                          vtrue=cuda.to_device(state.vtrue), body=cuda.to_device(state.body))
        new, out = step(self.dev, on_device, np.ascontiguousarray(actions, dtype=np.float64), active)
        moved: Any = new  # device arrays (numba's), not numpy's
        host = State(pos=moved.pos.copy_to_host(), vel=moved.vel.copy_to_host(), vtrue=moved.vtrue.copy_to_host(),
                     body=state.body)
        flags: Any = out.unstable
        return host, StepOutput(unstable=flags.copy_to_host())
