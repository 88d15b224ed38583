"""Would another memory layout make the voxel engine faster per core?  One RK4 stage in four layouts.

Research, kept for the record (``benchmarks/research/``): it COPIES one RK4 stage of the voxel engine's
physics into four layouts (the engine's own layout among them), so a change to ``gdabench/envs/voxel/``
does not reach it; the engine only sets up the states (docs/benchmarks/voxel-engine.md).

The stage is the engine's hot spot, done four times per physics update: each spring's force
``d * ((|d| - rest) * k / |d|)``, then each point's sum of its springs' forces (its edges as end a
with a minus sign, then as end b, in edge order: Evolution Gym's order, which bit-exact parity
needs), drag and gravity.  Every layout does the same arithmetic in the same order, so all four
give the same accelerations to the bit (checked before timing).

* ``per-env AoS``: the engine's form: one environment at a time, points ``(P, 2)``, each point's
  edges as a compressed list.
* ``per-env SoA``: one environment at a time, points ``(2, P)`` and the springs' forces in a
  contiguous pass of their own (the loop a compiler can turn into SIMD), each point's edges padded to
  the largest degree ``D`` so that the gather runs over contiguous rows.
* ``lanes, different bodies``: ``--lanes`` environments side by side in the innermost axis (the
  SIMD lanes' axis), each with its own body, so every load goes through a per-lane index (a gather).
* ``lanes, one body``: as many environments of one body: the indices are shared and every load is
  contiguous across the lanes.  The lane count is a runtime value: LLVM's loop vectorizer then takes
  the loop (a constant 8 is unrolled into scalar code).

Bodies: random 5x5 bodies (Evolution Gym's sampler, ``--seed``), positions and velocities after 60
env steps of an open-loop sinusoid on the engine.  Figures: microseconds per environment per stage,
the median of ``--repeats`` runs of ``--calls`` calls, on one thread.  ``--instructions`` counts
each kernel's square roots and divisions in its machine code, scalar (``sd``) or SIMD (``pd``).

    python benchmarks/research/voxel_layouts.py --instructions            # 8 lanes
    python benchmarks/research/voxel_layouts.py --lanes 32 --calls 5000
"""

from __future__ import annotations

import argparse
import math
import re
import time
from collections import Counter

import numba
import numpy as np

import gdabench
from gdabench.envs.voxel import engine

DRAG, GRAVITY = 0.1, 110.0
_nj = numba.njit(cache=False, error_model="numpy", boundscheck=False)


@_nj
def aos(calls, x, v, ea, rest, k, start, n_a, inc, ne, n, fe, out):
    for _ in range(calls):
        for b in range(x.shape[0]):
            for j in range(ne[b]):
                dx = x[b, ea[b, j, 0], 0] - x[b, ea[b, j, 1], 0]
                dy = x[b, ea[b, j, 0], 1] - x[b, ea[b, j, 1], 1]
                dist = math.sqrt(dx * dx + dy * dy)
                mag = (dist - rest[b, j]) * k[b, j] / dist
                fe[j, 0] = dx * mag
                fe[j, 1] = dy * mag
            for i in range(n[b]):
                fx = 0.0
                fy = 0.0
                first_b = start[b, i] + n_a[b, i]
                for m in range(start[b, i], first_b):
                    fx -= fe[inc[b, m], 0]
                    fy -= fe[inc[b, m], 1]
                for m in range(first_b, start[b, i + 1]):
                    fx += fe[inc[b, m], 0]
                    fy += fe[inc[b, m], 1]
                out[b, i, 0] = fx + v[b, i, 0] * -DRAG
                out[b, i, 1] = fy + v[b, i, 1] * -DRAG + 1.0 * -GRAVITY


@_nj
def soa(calls, x, v, ea, rest, k, inc, sign, ne, n, d, fe, out):
    for _ in range(calls):
        for b in range(x.shape[0]):
            for c in range(2):
                for j in range(ne[b]):
                    d[c, j] = x[b, c, ea[b, 0, j]] - x[b, c, ea[b, 1, j]]
            for j in range(ne[b]):
                dist = math.sqrt(d[0, j] * d[0, j] + d[1, j] * d[1, j])
                mag = (dist - rest[b, j]) * k[b, j] / dist
                fe[0, j] = d[0, j] * mag
                fe[1, j] = d[1, j] * mag
            for c in range(2):
                for i in range(n[b]):
                    out[b, c, i] = 0.0
                for m in range(inc.shape[1]):
                    for i in range(n[b]):
                        out[b, c, i] = out[b, c, i] + sign[b, m, i] * fe[c, inc[b, m, i]]
            for i in range(n[b]):
                out[b, 0, i] = out[b, 0, i] + v[b, 0, i] * -DRAG
                out[b, 1, i] = out[b, 1, i] + v[b, 1, i] * -DRAG + 1.0 * -GRAVITY


@numba.njit(cache=False, error_model="numpy", boundscheck=False, inline="always")
def _zero(n, ax, ay):
    for i in range(n):
        for w in range(ax.shape[1]):
            ax[i, w] = 0.0
            ay[i, w] = 0.0


@numba.njit(cache=False, error_model="numpy", boundscheck=False, inline="always")
def _drag_gravity(n, vx, vy, ax, ay):
    """The lanes layouts' last pass: drag and gravity added to the springs' sums."""
    for i in range(n):
        for w in range(ax.shape[1]):
            ax[i, w] = ax[i, w] + vx[i, w] * -DRAG
            ay[i, w] = ay[i, w] + vy[i, w] * -DRAG + 1.0 * -GRAVITY


@_nj
def lanes(calls, x, y, vx, vy, ea, eb, rest, k, inc, sign, ne, n, fx, fy, ax, ay):
    """Per-lane index tables ``(…, lanes)``: every environment its own body."""
    for _ in range(calls):
        for j in range(ne):
            for w in range(x.shape[1]):
                dx = x[ea[j, w], w] - x[eb[j, w], w]
                dy = y[ea[j, w], w] - y[eb[j, w], w]
                dist = math.sqrt(dx * dx + dy * dy)
                mag = (dist - rest[j, w]) * k[j, w] / dist
                fx[j, w] = dx * mag
                fy[j, w] = dy * mag
        _zero(n, ax, ay)
        for m in range(inc.shape[0]):
            for i in range(n):
                for w in range(x.shape[1]):
                    ax[i, w] = ax[i, w] + sign[m, i, w] * fx[inc[m, i, w], w]
                    ay[i, w] = ay[i, w] + sign[m, i, w] * fy[inc[m, i, w], w]
        _drag_gravity(n, vx, vy, ax, ay)


@_nj
def lanes_shared(calls, x, y, vx, vy, ea, eb, rest, k, inc, sign, ne, n, fx, fy, ax, ay):
    """One body's index tables shared by every lane (rest lengths still per lane): contiguous loads."""
    for _ in range(calls):
        for j in range(ne):
            a = ea[j]
            b = eb[j]
            for w in range(x.shape[1]):
                dx = x[a, w] - x[b, w]
                dy = y[a, w] - y[b, w]
                dist = math.sqrt(dx * dx + dy * dy)
                mag = (dist - rest[j, w]) * k[j, w] / dist
                fx[j, w] = dx * mag
                fy[j, w] = dy * mag
        _zero(n, ax, ay)
        for m in range(inc.shape[0]):
            for i in range(n):
                e = inc[m, i]
                s = sign[m, i]
                for w in range(x.shape[1]):
                    ax[i, w] = ax[i, w] + s * fx[e, w]
                    ay[i, w] = ay[i, w] + s * fy[e, w]
        _drag_gravity(n, vx, vy, ax, ay)


def walked(seed: int, same: bool, lanes: int):
    """Tables and state of ``lanes`` environments (as many bodies, or copies of the first) after 60 env steps."""
    rng = np.random.default_rng(seed)
    bodies = [gdabench.random_body(rng, (5, 5)) for _ in range(lanes)]
    tables = engine.body_tables(bodies[:1] * lanes if same else bodies)
    state = engine.reset(tables, np.arange(lanes))
    for t in range(60):
        act = 1.1 + 0.5 * np.sin(2 * math.pi * t / 20 + np.arange(tables.max_actuators))
        state, _ = engine.step(tables, state, np.tile(act, (lanes, 1)))
    return tables, state


def incidence(tables, b: int, width: int, zero: int) -> tuple[np.ndarray, np.ndarray]:
    """Body ``b``'s edges per point, padded to ``width`` with the zero slot: ``(width, P)`` each."""
    ne, P = int(tables.n_edges[b]), tables.max_points
    inc, sign = np.full((width, P), zero, np.int64), np.full((width, P), -1.0)
    for p in range(int(tables.n_points[b])):
        ends_a = np.flatnonzero(tables.edges[b, :ne, 0] == p)
        ends_b = np.flatnonzero(tables.edges[b, :ne, 1] == p)
        inc[: len(ends_a) + len(ends_b), p] = np.concatenate([ends_a, ends_b])
        sign[len(ends_a): len(ends_a) + len(ends_b), p] = 1.0
    return inc, sign


def layouts(tables, state) -> dict[str, tuple]:
    """Each layout's kernel, its arguments, and a function from its output to ``(B, P, 2)``."""
    B, P, E = len(state.body), tables.max_points, tables.edges.shape[1]
    x, v, rest, k, ne, n = state.pos, state.vel, tables.rest0, tables.spring_k, tables.n_edges, tables.n_points
    width = max(int(np.bincount(tables.edges[b, : ne[b]].ravel()).max()) for b in range(B))
    incs = [incidence(tables, b, width, E) for b in range(B)]
    out_aos, out_soa = np.zeros((B, P, 2)), np.zeros((B, 2, P))
    result = {
        "per-env AoS": (aos, (x, v, tables.edges, rest, k, tables.point_start, tables.point_n_a,
                              tables.point_edges, ne, n, np.zeros((E, 2)), out_aos), lambda: out_aos),
        "per-env SoA": (soa, (np.ascontiguousarray(x.transpose(0, 2, 1)), np.ascontiguousarray(v.transpose(0, 2, 1)),
                              np.ascontiguousarray(tables.edges.transpose(0, 2, 1)), rest, k,
                              np.stack([i for i, _ in incs]), np.stack([s for _, s in incs]), ne, n,
                              np.zeros((2, E)), np.zeros((2, E + 1)), out_soa), lambda: out_soa.transpose(0, 2, 1)),
    }
    # lanes: two extra points per lane, (0, 0) and (1, 0), for padded springs of stiffness 0
    lx, ly = np.zeros((P + 2, B)), np.zeros((P + 2, B))
    lx[P + 1] = 1.0
    lvx, lvy = np.zeros((P + 2, B)), np.zeros((P + 2, B))
    ea, eb = np.full((E, B), P, np.int64), np.full((E, B), P + 1, np.int64)
    lrest, lk = np.ones((E, B)), np.zeros((E, B))
    for b in range(B):
        lx[:n[b], b], ly[:n[b], b] = x[b, :n[b], 0], x[b, :n[b], 1]
        lvx[:n[b], b], lvy[:n[b], b] = v[b, :n[b], 0], v[b, :n[b], 1]
        ea[:ne[b], b], eb[:ne[b], b] = tables.edges[b, :ne[b], 0], tables.edges[b, :ne[b], 1]
        lrest[:ne[b], b], lk[:ne[b], b] = rest[b, :ne[b]], k[b, :ne[b]]
    ax, ay = np.zeros((P, B)), np.zeros((P, B))
    common = (lx, ly, lvx, lvy)
    temps = (np.zeros((E + 1, B)), np.zeros((E + 1, B)), ax, ay)

    def lanes_out() -> np.ndarray:
        return np.stack([ax.T, ay.T], axis=2)

    if np.all(tables.edges == tables.edges[0]):
        result["lanes, one body"] = (lanes_shared, (*common, ea[:, 0].copy(), eb[:, 0].copy(), lrest, lk, incs[0][0],
                                                    incs[0][1], int(ne.max()), int(n.max()), *temps), lanes_out)
    else:
        inc = np.stack([i for i, _ in incs], axis=2)
        sign = np.stack([s for _, s in incs], axis=2)
        result["lanes, different bodies"] = (lanes, (*common, ea, eb, lrest, lk, inc, sign, int(ne.max()), int(n.max()),
                                                     *temps), lanes_out)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--calls", type=int, default=20000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--lanes", type=int, default=8, help="environments side by side (the lanes layouts' width)")
    parser.add_argument("--instructions", action="store_true",
                        help="count each kernel's square roots and divisions, scalar (sd) or SIMD (pd)")
    args = parser.parse_args()
    numba.set_num_threads(1)
    rows: list[tuple[str, str, list[float]]] = []
    for same in (False, True):
        tables, state = walked(args.seed, same, args.lanes)
        found = layouts(tables, state)
        reference = None
        for name, (kernel, kargs, output) in found.items():
            kernel(1, *kargs)
            got = output()
            for b in range(args.lanes):
                got[b, tables.n_points[b]:] = 0.0
            if reference is None:
                reference = got.copy()
            if not np.array_equal(got, reference):
                raise SystemExit(f"{name} disagrees with per-env AoS: largest gap {np.abs(got - reference).max():.3g}")
            times = []
            for _ in range(args.repeats):
                start = time.perf_counter()
                kernel(args.calls, *kargs)
                times.append((time.perf_counter() - start) / args.calls / args.lanes * 1e6)
            rows.append((f"one body x {args.lanes}" if same else f"{args.lanes} bodies", name, times))
    print(f"one RK4 stage, microseconds per environment (median of {args.repeats}); numba {numba.__version__}, "
          f"one thread; every layout bit-identical to per-env AoS")
    print("| environments | layout | us | x per-env AoS | runs |")
    print("|---|---|--:|--:|---|")
    base: dict[str, float] = {}
    for group, name, times in rows:
        med = float(np.median(times))
        base.setdefault(group, med)
        print(f"| {group} | {name} | {med:.3f} | {base[group] / med:.2f} | {', '.join(f'{t:.3f}' for t in times)} |")
    if args.instructions:
        for kernel in (aos, soa, lanes, lanes_shared):
            asm = "".join(kernel.inspect_asm().values())
            found = Counter(re.findall(r"\t(v(?:sqrt|div)[sp]d)\s", asm))
            print(f"{kernel.__name__}: " + ", ".join(f"{op} {count}" for op, count in sorted(found.items())))


if __name__ == "__main__":
    main()
