"""Library comparison for the voxel engine: one core model of Evolution Gym's physics in torch (eager
and ``torch.compile``), NVIDIA Warp and Numba, next to our full engine, in env steps/s per core.

Research, kept for the record (``benchmarks/research/``): it COPIES a core model of the voxel engine's
physics into torch, Warp and Numba, so a change to ``gdabench/envs/voxel/`` does not reach those copies; the
engine itself is timed beside them (docs/benchmarks/voxel-libraries.md).

The core model is the voxel engine's physics without self-collision and terrain boxels: B copies of
one random 5x5 body (``gdabench.random_body(np.random.default_rng(0), (5, 5))``), started 0.05
above a y = 0 floor.  One env step = 30 substeps of dt 1e-4, each:

1. rest lengths re-anchored: ``rest = dist + (goal - dist) * 0.006`` (goal: the initial length, times
   the action 1.2 on actuated edges);
2. RK4 over the accelerations (mass 1) of springs ``f = d * ((|d| - rest) * k / |d|)`` (-f on end a,
   +f on end b), drag -0.1 v, gravity -110 and the floor (y < 0: normal -1.4e7 y, friction
   ``-2 * normal * tanh(v_x * normal * 0.2)``);
3. edge clamps: every edge within [0.75, 1.25] of its initial length (0.8 of half the excess on each
   end, all edges from the same positions);
4. true velocity = (pos - pos at the substep's start) / dt (kept, otherwise unused).

Implementations (all float64, all on one core; ``--libraries`` names in brackets where they differ):

* ``torch eager`` (``torch``): batched tensors ``(B, P, 2)``, spring forces scattered with
  ``index_add``; ``torch.set_num_threads(1)``.
* ``torch.compile`` (``compile``): the same substep function compiled by Inductor (CPU, C++/OpenMP
  codegen limited to one thread); the substep is called 30 times per env step from Python.  A new batch size may
  recompile (B = 1 is specialised; from the second size on shapes are dynamic).
* ``Warp`` (``warp``): per-stage kernels on the CPU device, one thread per (body, edge) for the
  springs, rest lengths and clamps (scatter by ``wp.atomic_add``), one per (body, point) for the RK4 stages; 12
  launches per substep.  On CUDA the same kernels run with ``device="cuda"``, and the order of the
  atomic additions is then nondeterministic (results differ in the last bits run to run).
* ``Warp (thread/body)`` (``warp-body``): one Warp kernel per env step, one thread per body, the
  Numba core model's loops (same module, so compiled together with the per-stage kernels).
* ``Numba core`` (``numba``): one ``njit`` kernel, a thread-per-body loop (serial here,
  ``cache=False``), the form of our engine's kernels.
* ``engine (full)`` (``engine``): ``gdabench.envs.voxel.engine.step`` (with self-collision, the
  Walker-v0 terrain row and the rigid 3 % clamps), same body, same B, ``numba.set_num_threads(1)``, actions 1.2.  Its
  kernels come from Numba's on-disk cache, so its first call is not a compile time.

Each cell is the median of ``--repeats`` runs of at least ``--seconds`` each: env steps/s = B x steps
over the process's CPU seconds (``time.process_time``; every implementation runs on one thread, so
this is per core and less sensitive to other jobs sharing the cores), and over wall-clock seconds; a
cell whose runs would take over ``--skip-over`` seconds is skipped.  "first call s" is the
first call's wall time minus one steady step: the compile (and tracing) time; Numba and Warp compile
once per process (at the first B), torch.compile may compile again for a new batch size.  Caches of
Warp and Inductor are pointed at fresh temporary folders, so their first calls are cold compiles.

Agreement: every implementation from the same start (B = 4), positions after 10 and after 50 env steps
compared with the Numba core model (max absolute difference).

    nice -n 5 python benchmarks/research/voxel_libraries.py --batches 1,16,64,256,1024
    python benchmarks/research/voxel_libraries.py --batches 1,64 --libraries numba,torch --seconds 0.5
"""

import argparse
import atexit
import math
import os
import shutil
import statistics
import sys
import tempfile
import time

_CACHE = tempfile.mkdtemp(prefix="voxel_libraries_")
atexit.register(shutil.rmtree, _CACHE, ignore_errors=True)
os.environ.setdefault("TORCHINDUCTOR_CACHE_DIR", os.path.join(_CACHE, "inductor"))
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numba  # noqa: E402 - after the thread and cache settings above
import numpy as np  # noqa: E402 - after the thread and cache settings above

import gdabench  # noqa: E402 - after the thread and cache settings above
from gdabench.envs.voxel import engine  # noqa: E402 - after the thread and cache settings above

DT = 1e-4
SUBSTEPS = 30
CONVERGENCE = 0.006
DRAG = 0.1
GRAVITY = 110.0
K_GROUND = 1.4e7
FRICTION = -2.0  # -10 x dynamic friction 0.2
MU = 0.2
BAND = 0.25
ACTION = 1.2
DROP = 0.05  # the body's bottom starts this far above the floor


# --------------------------------------------------------------------------------------------- model
class Core:
    """The core model's tables for one body (numpy, float64 / int64)."""

    def __init__(self, seed: int = 0):
        self.body = gdabench.random_body(np.random.default_rng(seed), (5, 5))
        self.tables = engine.body_tables([self.body])
        obj = self.tables.objects[0]
        self.pos0 = obj.pos.astype(np.float64).copy()
        self.pos0[:, 1] -= self.pos0[:, 1].min() - DROP  # robot_object puts the bottom at y = 0.1: now 0.05
        self.edges = np.ascontiguousarray(obj.edge_ab, dtype=np.int64)
        self.rest0 = np.asarray(obj.edge_len, dtype=np.float64).copy()
        self.k = np.asarray(obj.edge_k, dtype=np.float64).copy()
        self.goal = self.rest0.copy()
        n_act = int(self.tables.n_act[0])
        actuated = np.unique(self.tables.act_edges[0][:n_act].ravel())
        self.goal[actuated] = self.rest0[actuated] * ACTION  # the mean of equal actions is the action
        self.n_act = n_act
        self.P = len(self.pos0)
        self.E = len(self.edges)

    def start(self, batch: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        pos = np.repeat(self.pos0[None], batch, axis=0)
        return pos, np.zeros_like(pos), np.zeros_like(pos)


# --------------------------------------------------------------------------------------------- numba
_nj = numba.njit(cache=False, error_model="numpy", boundscheck=False, fastmath=False)


@_nj
def _nb_slope(x, v, ea, rest, k, out):
    """Accelerations of one body: springs scattered over all a ends, then all b ends (edge order,
    as torch's ``index_add`` does), then drag, gravity and the floor."""
    P = x.shape[0]
    E = ea.shape[0]
    for i in range(P):
        out[i, 0] = 0.0
        out[i, 1] = 0.0
    fe = np.empty((E, 2))
    for j in range(E):
        dx = x[ea[j, 0], 0] - x[ea[j, 1], 0]
        dy = x[ea[j, 0], 1] - x[ea[j, 1], 1]
        dist = math.sqrt(dx * dx + dy * dy)
        mag = (dist - rest[j]) * k[j] / dist
        fe[j, 0] = dx * mag
        fe[j, 1] = dy * mag
    for j in range(E):
        out[ea[j, 0], 0] += -fe[j, 0]
        out[ea[j, 0], 1] += -fe[j, 1]
    for j in range(E):
        out[ea[j, 1], 0] += fe[j, 0]
        out[ea[j, 1], 1] += fe[j, 1]
    for i in range(P):
        fx = out[i, 0] - DRAG * v[i, 0]
        fy = out[i, 1] - DRAG * v[i, 1]
        fy = fy + -GRAVITY
        y = x[i, 1]
        normal = -K_GROUND * y if y < 0 else 0.0
        fx = fx + FRICTION * normal * math.tanh(v[i, 0] * normal * MU)
        fy = fy + normal
        out[i, 0] = fx
        out[i, 1] = fy


@_nj
def nb_step(pos, vel, vt, ea, rest0, k, goal):
    """One env step of every body, one body after another (a thread per body under ``prange``)."""
    B, P, _ = pos.shape
    E = ea.shape[0]
    rest = np.empty(E)
    x0 = np.empty((P, 2))
    v0 = np.empty((P, 2))
    xs = np.empty((P, 2))
    vs = np.empty((P, 2))
    acc = np.empty((P, 2))
    sp = np.empty((P, 2))
    sv = np.empty((P, 2))
    corr = np.empty((E, 2))
    for b in range(B):
        x = pos[b]
        v = vel[b]
        for _ in range(SUBSTEPS):
            for j in range(E):
                dx = x[ea[j, 0], 0] - x[ea[j, 1], 0]
                dy = x[ea[j, 0], 1] - x[ea[j, 1], 1]
                dist = math.sqrt(dx * dx + dy * dy)
                rest[j] = dist + (goal[j] - dist) * CONVERGENCE
            for i in range(P):
                for c in range(2):
                    x0[i, c] = x[i, c]
                    v0[i, c] = v[i, c]
            _nb_slope(x0, v0, ea, rest, k, acc)
            for i in range(P):
                for c in range(2):
                    kp = v0[i, c] * DT
                    kv = acc[i, c] * DT
                    sp[i, c] = kp
                    sv[i, c] = kv
                    xs[i, c] = x0[i, c] + kp * 0.5
                    vs[i, c] = v0[i, c] + kv * 0.5
            _nb_slope(xs, vs, ea, rest, k, acc)
            for i in range(P):
                for c in range(2):
                    kp = vs[i, c] * DT
                    kv = acc[i, c] * DT
                    sp[i, c] = sp[i, c] + 2 * kp
                    sv[i, c] = sv[i, c] + 2 * kv
                    xs[i, c] = x0[i, c] + kp * 0.5
                    vs[i, c] = v0[i, c] + kv * 0.5
            _nb_slope(xs, vs, ea, rest, k, acc)
            for i in range(P):
                for c in range(2):
                    kp = vs[i, c] * DT
                    kv = acc[i, c] * DT
                    sp[i, c] = sp[i, c] + 2 * kp
                    sv[i, c] = sv[i, c] + 2 * kv
                    xs[i, c] = x0[i, c] + kp
                    vs[i, c] = v0[i, c] + kv
            _nb_slope(xs, vs, ea, rest, k, acc)
            for i in range(P):
                for c in range(2):
                    x[i, c] = x0[i, c] + (sp[i, c] + vs[i, c] * DT) / 6
                    v[i, c] = v0[i, c] + (sv[i, c] + acc[i, c] * DT) / 6
            for j in range(E):
                dx = x[ea[j, 0], 0] - x[ea[j, 1], 0]
                dy = x[ea[j, 0], 1] - x[ea[j, 1], 1]
                dist = math.sqrt(dx * dx + dy * dy)
                stress = dist / rest0[j]
                over = (dist - rest0[j] * (1 + BAND)) / (dist * 2) if stress > 1 + BAND else 0.0
                under = (dist - rest0[j] * (1 - BAND)) / (dist * 2) if stress < 1 - BAND else 0.0
                c = over + under
                corr[j, 0] = dx * c * 0.8
                corr[j, 1] = dy * c * 0.8
            for j in range(E):
                x[ea[j, 0], 0] += -corr[j, 0]
                x[ea[j, 0], 1] += -corr[j, 1]
            for j in range(E):
                x[ea[j, 1], 0] += corr[j, 0]
                x[ea[j, 1], 1] += corr[j, 1]
            for i in range(P):
                vt[b, i, 0] = (x[i, 0] - x0[i, 0]) / DT
                vt[b, i, 1] = (x[i, 1] - x0[i, 1]) / DT


class NumbaCore:
    name = "Numba core (thread/body)"

    def __init__(self, core: Core, batch: int):
        self.c = core
        self.pos, self.vel, self.vt = core.start(batch)

    def step(self):
        c = self.c
        nb_step(self.pos, self.vel, self.vt, c.edges, c.rest0, c.k, c.goal)

    def positions(self) -> np.ndarray:
        return self.pos.copy()


# --------------------------------------------------------------------------------------------- torch
def torch_substep(pos, vel, a, b, rest0, k, goal):
    """One substep of every body: pos, vel (B, P, 2) -> pos, vel, true velocity."""
    import torch

    def lengths(x):
        d = x[:, a] - x[:, b]
        return d, torch.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1])

    def slope(x, v):
        d, dist = lengths(x)
        f = d * ((dist - rest) * k / dist).unsqueeze(-1)
        F = torch.zeros_like(x).index_add(1, a, -f).index_add(1, b, f)
        fx = F[..., 0] - DRAG * v[..., 0]
        fy = F[..., 1] - DRAG * v[..., 1]
        fy = fy + -GRAVITY
        y = x[..., 1]
        normal = torch.where(y < 0, -K_GROUND * y, torch.zeros_like(y))
        fx = fx + FRICTION * normal * torch.tanh(v[..., 0] * normal * MU)
        fy = fy + normal
        return torch.stack([fx, fy], dim=-1)

    x0, v0 = pos, vel
    _, dist = lengths(x0)
    rest = dist + (goal - dist) * CONVERGENCE
    acc = slope(x0, v0)
    kp, kv = v0 * DT, acc * DT
    sp, sv = kp, kv
    xs, vs = x0 + kp * 0.5, v0 + kv * 0.5
    acc = slope(xs, vs)
    kp, kv = vs * DT, acc * DT
    sp, sv = sp + 2 * kp, sv + 2 * kv
    xs, vs = x0 + kp * 0.5, v0 + kv * 0.5
    acc = slope(xs, vs)
    kp, kv = vs * DT, acc * DT
    sp, sv = sp + 2 * kp, sv + 2 * kv
    xs, vs = x0 + kp, v0 + kv
    acc = slope(xs, vs)
    x = x0 + (sp + vs * DT) / 6
    v = v0 + (sv + acc * DT) / 6
    d, dist = lengths(x)
    stress = dist / rest0
    zero = torch.zeros_like(dist)
    over = torch.where(stress > 1 + BAND, (dist - rest0 * (1 + BAND)) / (dist * 2), zero)
    under = torch.where(stress < 1 - BAND, (dist - rest0 * (1 - BAND)) / (dist * 2), zero)
    corr = d * (over + under).unsqueeze(-1) * 0.8
    x = x.index_add(1, a, -corr).index_add(1, b, corr)
    vt = (x - x0) / DT
    return x, v, vt


class TorchCore:
    name = "torch eager"
    _compiled = None

    def __init__(self, core: Core, batch: int, compiled: bool = False):
        import torch

        torch.set_num_threads(1)
        self.torch = torch
        pos, vel, vt = core.start(batch)
        self.pos, self.vel, self.vt = (torch.from_numpy(a) for a in (pos, vel, vt))
        self.a = torch.from_numpy(core.edges[:, 0].copy())
        self.b = torch.from_numpy(core.edges[:, 1].copy())
        self.rest0 = torch.from_numpy(core.rest0)
        self.k = torch.from_numpy(core.k)
        self.goal = torch.from_numpy(core.goal)
        if compiled:
            self.name = "torch.compile"
            if TorchCore._compiled is None:
                import torch._inductor.config as inductor_config

                inductor_config.compile_threads = 1
                TorchCore._compiled = torch.compile(torch_substep)
            self.fn = TorchCore._compiled
        else:
            self.fn = torch_substep

    def step(self):
        with self.torch.no_grad():
            for _ in range(SUBSTEPS):
                self.pos, self.vel, self.vt = self.fn(self.pos, self.vel, self.a, self.b, self.rest0, self.k, self.goal)

    def positions(self) -> np.ndarray:
        return self.pos.numpy().copy()


# --------------------------------------------------------------------------------------------- warp
_WARP = None


def _warp_kernels():
    """Build Warp's kernels once (imports Warp, points its kernel cache at a fresh folder)."""
    global _WARP
    if _WARP is not None:
        return _WARP
    import warp as wp

    wp.config.kernel_cache_dir = os.path.join(_CACHE, "warp")
    wp.config.quiet = True
    wp.config.enable_backward = False  # no adjoint kernels: forward simulation only (halves the compile)
    wp.init()
    f64 = wp.float64
    v2 = wp.vec2d

    @wp.kernel
    def w_rest(x: wp.array2d(dtype=v2), ea: wp.array2d(dtype=wp.int32), goal: wp.array(dtype=f64),
               rest: wp.array2d(dtype=f64)):
        b, e = wp.tid()
        d = x[b, ea[e, 0]] - x[b, ea[e, 1]]
        dist = wp.sqrt(d[0] * d[0] + d[1] * d[1])
        rest[b, e] = dist + (goal[e] - dist) * f64(CONVERGENCE)

    @wp.kernel
    def w_springs(x: wp.array2d(dtype=v2), ea: wp.array2d(dtype=wp.int32), rest: wp.array2d(dtype=f64),
                  k: wp.array(dtype=f64), force: wp.array2d(dtype=v2)):
        b, e = wp.tid()
        i = ea[e, 0]
        j = ea[e, 1]
        d = x[b, i] - x[b, j]
        dist = wp.sqrt(d[0] * d[0] + d[1] * d[1])
        f = d * ((dist - rest[b, e]) * k[e] / dist)
        wp.atomic_sub(force, b, i, f)
        wp.atomic_add(force, b, j, f)

    @wp.kernel
    def w_stage(stage: int, xin: wp.array2d(dtype=v2), vin: wp.array2d(dtype=v2), force: wp.array2d(dtype=v2),
                x0: wp.array2d(dtype=v2), v0: wp.array2d(dtype=v2), xs: wp.array2d(dtype=v2),
                vs: wp.array2d(dtype=v2), sp: wp.array2d(dtype=v2), sv: wp.array2d(dtype=v2),
                pos: wp.array2d(dtype=v2), vel: wp.array2d(dtype=v2)):
        """Accelerations at one RK4 stage (the spring forces are in ``force``, zeroed here for the next)
        and the stage's update; stage 0 reads pos/vel and keeps them as x0/v0, stage 3 writes pos/vel."""
        b, p = wp.tid()
        x = xin[b, p]
        v = vin[b, p]
        f = force[b, p]
        force[b, p] = v2(f64(0.0), f64(0.0))
        fx = f[0] - f64(DRAG) * v[0]
        fy = f[1] - f64(DRAG) * v[1]
        fy = fy + f64(-GRAVITY)
        y = x[1]
        normal = f64(0.0)
        if y < f64(0.0):
            normal = f64(-K_GROUND) * y
        fx = fx + f64(FRICTION) * normal * wp.tanh(v[0] * normal * f64(MU))
        fy = fy + normal
        acc = v2(fx, fy)
        kp = v * f64(DT)
        kv = acc * f64(DT)
        if stage == 0:
            x0[b, p] = x
            v0[b, p] = v
            sp[b, p] = kp
            sv[b, p] = kv
            xs[b, p] = x + kp * f64(0.5)
            vs[b, p] = v + kv * f64(0.5)
        elif stage == 1:
            sp[b, p] = sp[b, p] + f64(2.0) * kp
            sv[b, p] = sv[b, p] + f64(2.0) * kv
            xs[b, p] = x0[b, p] + kp * f64(0.5)
            vs[b, p] = v0[b, p] + kv * f64(0.5)
        elif stage == 2:
            sp[b, p] = sp[b, p] + f64(2.0) * kp
            sv[b, p] = sv[b, p] + f64(2.0) * kv
            xs[b, p] = x0[b, p] + kp
            vs[b, p] = v0[b, p] + kv
        else:
            pos[b, p] = x0[b, p] + (sp[b, p] + v * f64(DT)) / f64(6.0)
            vel[b, p] = v0[b, p] + (sv[b, p] + acc * f64(DT)) / f64(6.0)

    @wp.kernel
    def w_clamp(x: wp.array2d(dtype=v2), ea: wp.array2d(dtype=wp.int32), rest0: wp.array(dtype=f64),
                corr: wp.array2d(dtype=v2)):
        b, e = wp.tid()
        d = x[b, ea[e, 0]] - x[b, ea[e, 1]]
        dist = wp.sqrt(d[0] * d[0] + d[1] * d[1])
        r = rest0[e]
        stress = dist / r
        over = f64(0.0)
        under = f64(0.0)
        if stress > f64(1.0 + BAND):
            over = (dist - r * f64(1.0 + BAND)) / (dist * f64(2.0))
        if stress < f64(1.0 - BAND):
            under = (dist - r * f64(1.0 - BAND)) / (dist * f64(2.0))
        corr[b, e] = d * (over + under) * f64(0.8)

    @wp.kernel
    def w_apply(corr: wp.array2d(dtype=v2), ea: wp.array2d(dtype=wp.int32), x: wp.array2d(dtype=v2)):
        b, e = wp.tid()
        c = corr[b, e]
        wp.atomic_sub(x, b, ea[e, 0], c)
        wp.atomic_add(x, b, ea[e, 1], c)

    @wp.kernel
    def w_vtrue(x: wp.array2d(dtype=v2), x0: wp.array2d(dtype=v2), vt: wp.array2d(dtype=v2)):
        b, p = wp.tid()
        vt[b, p] = (x[b, p] - x0[b, p]) / f64(DT)

    @wp.func
    def w_slope(b: int, x: wp.array2d(dtype=v2), v: wp.array2d(dtype=v2), ea: wp.array2d(dtype=wp.int32),
                rest: wp.array2d(dtype=f64), k: wp.array(dtype=f64), acc: wp.array2d(dtype=v2)):
        P = x.shape[1]
        E = ea.shape[0]
        for i in range(P):
            acc[b, i] = v2(f64(0.0), f64(0.0))
        for e in range(E):
            i = ea[e, 0]
            j = ea[e, 1]
            d = x[b, i] - x[b, j]
            dist = wp.sqrt(d[0] * d[0] + d[1] * d[1])
            f = d * ((dist - rest[b, e]) * k[e] / dist)
            acc[b, i] = acc[b, i] - f
            acc[b, j] = acc[b, j] + f
        for i in range(P):
            f = acc[b, i]
            xv = v[b, i]
            fx = f[0] - f64(DRAG) * xv[0]
            fy = f[1] - f64(DRAG) * xv[1]
            fy = fy + f64(-GRAVITY)
            y = x[b, i][1]
            normal = f64(0.0)
            if y < f64(0.0):
                normal = f64(-K_GROUND) * y
            fx = fx + f64(FRICTION) * normal * wp.tanh(xv[0] * normal * f64(MU))
            fy = fy + normal
            acc[b, i] = v2(fx, fy)
        return 0

    @wp.kernel
    def w_body(pos: wp.array2d(dtype=v2), vel: wp.array2d(dtype=v2), vt: wp.array2d(dtype=v2),
               ea: wp.array2d(dtype=wp.int32), rest0: wp.array(dtype=f64), k: wp.array(dtype=f64),
               goal: wp.array(dtype=f64), rest: wp.array2d(dtype=f64), corr: wp.array2d(dtype=v2),
               x0: wp.array2d(dtype=v2), v0: wp.array2d(dtype=v2), xs: wp.array2d(dtype=v2),
               vs: wp.array2d(dtype=v2), acc: wp.array2d(dtype=v2), sp: wp.array2d(dtype=v2),
               sv: wp.array2d(dtype=v2)):
        """One env step of body ``b`` (all 30 substeps), the Numba core model's loops."""
        b = wp.tid()
        P = pos.shape[1]
        E = ea.shape[0]
        for _s in range(SUBSTEPS):
            for e in range(E):
                d = pos[b, ea[e, 0]] - pos[b, ea[e, 1]]
                dist = wp.sqrt(d[0] * d[0] + d[1] * d[1])
                rest[b, e] = dist + (goal[e] - dist) * f64(CONVERGENCE)
            for i in range(P):
                x0[b, i] = pos[b, i]
                v0[b, i] = vel[b, i]
            w_slope(b, x0, v0, ea, rest, k, acc)
            for i in range(P):
                kp = v0[b, i] * f64(DT)
                kv = acc[b, i] * f64(DT)
                sp[b, i] = kp
                sv[b, i] = kv
                xs[b, i] = x0[b, i] + kp * f64(0.5)
                vs[b, i] = v0[b, i] + kv * f64(0.5)
            w_slope(b, xs, vs, ea, rest, k, acc)
            for i in range(P):
                kp = vs[b, i] * f64(DT)
                kv = acc[b, i] * f64(DT)
                sp[b, i] = sp[b, i] + f64(2.0) * kp
                sv[b, i] = sv[b, i] + f64(2.0) * kv
                xs[b, i] = x0[b, i] + kp * f64(0.5)
                vs[b, i] = v0[b, i] + kv * f64(0.5)
            w_slope(b, xs, vs, ea, rest, k, acc)
            for i in range(P):
                kp = vs[b, i] * f64(DT)
                kv = acc[b, i] * f64(DT)
                sp[b, i] = sp[b, i] + f64(2.0) * kp
                sv[b, i] = sv[b, i] + f64(2.0) * kv
                xs[b, i] = x0[b, i] + kp
                vs[b, i] = v0[b, i] + kv
            w_slope(b, xs, vs, ea, rest, k, acc)
            for i in range(P):
                pos[b, i] = x0[b, i] + (sp[b, i] + vs[b, i] * f64(DT)) / f64(6.0)
                vel[b, i] = v0[b, i] + (sv[b, i] + acc[b, i] * f64(DT)) / f64(6.0)
            for e in range(E):
                d = pos[b, ea[e, 0]] - pos[b, ea[e, 1]]
                dist = wp.sqrt(d[0] * d[0] + d[1] * d[1])
                r = rest0[e]
                stress = dist / r
                over = f64(0.0)
                under = f64(0.0)
                if stress > f64(1.0 + BAND):
                    over = (dist - r * f64(1.0 + BAND)) / (dist * f64(2.0))
                if stress < f64(1.0 - BAND):
                    under = (dist - r * f64(1.0 - BAND)) / (dist * f64(2.0))
                corr[b, e] = d * (over + under) * f64(0.8)
            for e in range(E):
                pos[b, ea[e, 0]] = pos[b, ea[e, 0]] - corr[b, e]
                pos[b, ea[e, 1]] = pos[b, ea[e, 1]] + corr[b, e]
            for i in range(P):
                vt[b, i] = (pos[b, i] - x0[b, i]) / f64(DT)

    _WARP = (wp, w_rest, w_springs, w_stage, w_clamp, w_apply, w_vtrue, w_body)
    return _WARP


class WarpCore:
    name = "Warp (CPU, kernels per stage)"

    def __init__(self, core: Core, batch: int, device: str = "cpu", per_body: bool = False):
        wp, *self.kernels = _warp_kernels()
        self.per_body = per_body
        if per_body:
            self.name = "Warp (CPU, thread/body)"
        self.wp = wp
        self.device = device
        pos, vel, vt = core.start(batch)
        B, P, E = batch, core.P, core.E
        self.B, self.P, self.E = B, P, E
        v2 = wp.vec2d

        def arr(a):
            return wp.array(np.ascontiguousarray(a), dtype=v2, device=device)

        self.pos, self.vel, self.vt = arr(pos), arr(vel), arr(vt)
        self.x0, self.v0, self.xs, self.vs, self.sp, self.sv, self.force = (
            wp.zeros((B, P), dtype=v2, device=device) for _ in range(7))
        self.acc = wp.zeros((B, P), dtype=v2, device=device)
        self.rest = wp.zeros((B, E), dtype=wp.float64, device=device)
        self.corr = wp.zeros((B, E), dtype=v2, device=device)
        self.ea = wp.array(core.edges.astype(np.int32), dtype=wp.int32, device=device)
        self.rest0 = wp.array(core.rest0, dtype=wp.float64, device=device)
        self.k = wp.array(core.k, dtype=wp.float64, device=device)
        self.goal = wp.array(core.goal, dtype=wp.float64, device=device)

    def step(self):
        wp = self.wp
        w_rest, w_springs, w_stage, w_clamp, w_apply, w_vtrue, w_body = self.kernels
        be, bp, dev = (self.B, self.E), (self.B, self.P), self.device
        if self.per_body:
            wp.launch(w_body, dim=self.B, inputs=[self.pos, self.vel, self.vt, self.ea, self.rest0, self.k, self.goal,
                                                  self.rest, self.corr, self.x0, self.v0, self.xs, self.vs, self.acc,
                                                  self.sp, self.sv], device=dev)
            wp.synchronize_device(dev)
            return
        for _ in range(SUBSTEPS):
            wp.launch(w_rest, dim=be, inputs=[self.pos, self.ea, self.goal, self.rest], device=dev)
            for stage in range(4):
                x, v = (self.pos, self.vel) if stage == 0 else (self.xs, self.vs)
                wp.launch(w_springs, dim=be, inputs=[x, self.ea, self.rest, self.k, self.force], device=dev)
                wp.launch(w_stage, dim=bp, inputs=[stage, x, v, self.force, self.x0, self.v0, self.xs, self.vs,
                                                   self.sp, self.sv, self.pos, self.vel], device=dev)
            wp.launch(w_clamp, dim=be, inputs=[self.pos, self.ea, self.rest0, self.corr], device=dev)
            wp.launch(w_apply, dim=be, inputs=[self.corr, self.ea, self.pos], device=dev)
            wp.launch(w_vtrue, dim=bp, inputs=[self.pos, self.x0, self.vt], device=dev)
        wp.synchronize_device(dev)

    def positions(self) -> np.ndarray:
        return self.pos.numpy().reshape(self.B, self.P, 2).copy()


# --------------------------------------------------------------------------------------------- full engine
class FullEngine:
    name = "engine (full, Numba)"

    def __init__(self, core: Core, batch: int):
        numba.set_num_threads(1)
        self.tables = core.tables
        self.state = engine.reset(self.tables, np.zeros(batch, dtype=np.int64))
        self.actions = np.full((batch, self.tables.max_actuators), ACTION)

    def step(self):
        self.state, _ = engine.step(self.tables, self.state, self.actions)

    def positions(self) -> np.ndarray:
        return self.state.pos.copy()


# --------------------------------------------------------------------------------------------- harness
LIBRARIES = {
    "torch": lambda core, B: TorchCore(core, B),
    "compile": lambda core, B: TorchCore(core, B, compiled=True),
    "warp": lambda core, B: WarpCore(core, B),
    "warp-body": lambda core, B: WarpCore(core, B, per_body=True),
    "numba": lambda core, B: NumbaCore(core, B),
    "engine": lambda core, B: FullEngine(core, B),
}


def measure(make, core: Core, batch: int, seconds: float, repeats: int, skip_over: float):
    """(name, env steps/s or None when skipped, first call s, note)."""
    sim = make(core, batch)
    t0 = time.perf_counter()
    sim.step()
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    sim.step()
    one = time.perf_counter() - t0
    if repeats * max(seconds, one) > skip_over:
        return sim.name, None, max(first - one, 0.0), f"skipped: one step took {one:.2f} s"
    rates, cpu_rates = [], []
    for _ in range(repeats):
        steps, t0, c0 = 0, time.perf_counter(), time.process_time()
        while True:
            sim.step()
            steps += 1
            elapsed = time.perf_counter() - t0
            if elapsed >= seconds:
                break
        rates.append(batch * steps / elapsed)
        cpu_rates.append(batch * steps / max(time.process_time() - c0, 1e-9))
    return sim.name, (statistics.median(rates), statistics.median(cpu_rates)), max(first - one, 0.0), ""


def agreement(core: Core, libs: list[str], batch: int = 4, checkpoints=(10, 50)) -> list[tuple]:
    """Max |position difference| of each core implementation against the Numba core model."""
    ref = NumbaCore(core, batch)
    sims = {lib: LIBRARIES[lib](core, batch) for lib in libs if lib not in ("numba", "engine")}
    rows, done = [], 0
    for n in checkpoints:
        for _ in range(n - done):
            ref.step()
            for s in sims.values():
                s.step()
        done = n
        r = ref.positions()
        for s in sims.values():
            rows.append((s.name, n, float(np.abs(s.positions() - r).max()), float(r[..., 1].min())))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--batches", default="1,16,64,256,1024")
    ap.add_argument("--libraries", default="torch,compile,warp,warp-body,numba,engine",
                    help="comma list of: " + ",".join(LIBRARIES))
    ap.add_argument("--seconds", type=float, default=1.0, help="least length of one timed run")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--skip-over", type=float, default=20.0, help="skip a cell whose timed runs would take longer")
    ap.add_argument("--no-agreement", action="store_true")
    args = ap.parse_args(argv)
    batches = [int(b) for b in args.batches.split(",")]
    libs = [lib.strip() for lib in args.libraries.split(",")]
    numba.set_num_threads(1)
    core = Core()
    print(f"body {core.body} ({core.P} points, {core.E} edges, {core.n_act} actuators); "
          f"load {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; python {sys.version.split()[0]}", flush=True)
    versions = [f"numba {numba.__version__}", f"numpy {np.__version__}"]
    if any(lib in ("torch", "compile") for lib in libs):
        import torch

        versions.append(f"torch {torch.__version__}")
    if any(lib.startswith("warp") for lib in libs):
        versions.append(f"warp {_warp_kernels()[0].__version__}")
    print(", ".join(versions), flush=True)

    rows = []
    for lib in libs:
        for B in batches:
            name, rate, first, note = measure(LIBRARIES[lib], core, B, args.seconds, args.repeats, args.skip_over)
            rows.append((name, B, rate, first, note))
            shown = "-" if rate is None else f"{rate[0]:10.0f} wall, {rate[1]:10.0f} per CPU s"
            print(f"  {name:32s} B={B:5d} {shown} env steps/s, first call +{first:.2f} s {note}", flush=True)
    print()
    print("| library | B | env steps/s per core (per CPU second) | env steps/s (wall clock) | compile s (first call) |")
    print("|---|---:|---:|---:|---:|")
    for name, B, rate, first, note in rows:
        cells = f"{note} | -" if rate is None else f"{rate[1]:,.0f} | {rate[0]:,.0f}"
        print(f"| {name} | {B} | {cells} | {first:.2f} |")
    if not args.no_agreement:
        print()
        print("| implementation vs Numba core (B = 4) | env steps | max position difference | lowest y |")
        print("|---|---:|---:|---:|")
        for name, n, diff, low in agreement(core, libs):
            print(f"| {name} | {n} | {diff:.3g} | {low:.4f} |")
    print(f"\nload after: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
