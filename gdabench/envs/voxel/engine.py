"""Batched Evolution Gym physics: static body tables, state as arrays, a pure step function.

    tables = body_tables([body_a, body_b])              # padded to the larger body
    state = reset(tables, body=np.array([0, 0, 1]))     # three environments: two of a, one of b
    state, out = step(tables, WALKER_TERRAIN, state, actions)

``step`` never changes its inputs: it returns a new :class:`State` and a :class:`StepOutput`
(observations, centre-of-mass gains, instability flags).  Bodies are padded to the batch's largest
(or to ``pad``); padding is never simulated, so a body's trajectory does not depend on its batch.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Sequence

import numba
import numpy as np

from ...body import Body, as_body
from . import kernels
from .model import FIXED, H_ACT, RIGID, V_ACT, Object, build_object

#: where Walker-v0 places the robot (voxels): x 1, bottom at y 1
ROBOT_AT = (1, 1)
#: smaller batches step on the calling thread: waking threads costs more than they save
PARALLEL_FROM = 8


@dataclass(frozen=True)
class BodyTables:
    """Every body of a batch as padded arrays (first axis: body), plus the unpadded objects."""

    objects: tuple[Object, ...]
    n_points: np.ndarray
    n_edges: np.ndarray
    edges: np.ndarray  # (B, E, 2)
    rest0: np.ndarray  # (B, E)
    spring_k: np.ndarray
    edge_surface: np.ndarray
    n_act: np.ndarray
    act_edges: np.ndarray  # (B, A, 2): the two edges each actuator drives
    n_surface: np.ndarray
    surface_points: np.ndarray  # (B, S, 4)
    surface_edges: np.ndarray  # (B, S, 4)
    n_pairs: np.ndarray
    pairs: np.ndarray  # (B, Q, 5): surface boxels i < j, grid neighbours?, corners of i (bits) not in j, of j not in i
    n_rigid: np.ndarray
    rigid_edges: np.ndarray  # (B, R, 4)
    point_edges: np.ndarray  # (B, 2E): per point, its edges where it is end a, then where it is end b
    point_start: np.ndarray  # (B, P + 1): where each point's run in point_edges starts
    point_n_a: np.ndarray  # (B, P): how many of them are a ends
    init_pos: np.ndarray  # (B, P, 2)

    @property
    def max_points(self) -> int:
        return self.init_pos.shape[1]

    @property
    def max_actuators(self) -> int:
        return self.act_edges.shape[1]

    def obs_size(self, b: int) -> int:
        return 2 + 2 * int(self.n_points[b])


@dataclass(frozen=True)
class Terrain:
    """Fixed terrain: static boxels (surface ones only) with a lookup by 0.1-wide column."""

    pos: np.ndarray
    edges: np.ndarray
    edge_surface: np.ndarray
    boxel_points: np.ndarray
    boxel_edges: np.ndarray
    bbox: np.ndarray
    col_start: np.ndarray
    col_boxel: np.ndarray
    zero: np.ndarray  # the terrain's (zero) velocities, and a sink for forces on it

    def arrays(self) -> tuple:
        return (self.pos, self.edges, self.edge_surface, self.boxel_points, self.boxel_edges, self.bbox,
                self.col_start, self.col_boxel, self.zero)


@dataclass(frozen=True)
class State:
    """Positions, velocities and true velocities (finite differences) of every environment's points."""

    pos: np.ndarray  # (N, P, 2)
    vel: np.ndarray
    vtrue: np.ndarray
    body: np.ndarray  # (N,) index into the tables


@dataclass(frozen=True)
class StepOutput:
    obs: np.ndarray  # (N, 2 + 2P): [v_com (2), x of each point, y of each point, padding]
    dx: np.ndarray  # (N,) gain of the centre of mass's x
    com: np.ndarray  # (N,) the centre of mass's x after the step
    unstable: np.ndarray  # (N,) bool


def robot_object(body: Body | np.ndarray | str, at: tuple[int, int] = ROBOT_AT) -> Object:
    grid = np.asarray(as_body(body).voxels) if not isinstance(body, np.ndarray) else body
    return build_object(grid, at)


def terrain(grid: np.ndarray, at: tuple[int, int] = (0, 0)) -> Terrain:
    """Tables of a fixed terrain object (every cell fixed)."""
    obj = build_object(np.where(np.asarray(grid) != 0, FIXED, 0), at, point_offset=1, edge_offset=1)
    idx = np.flatnonzero(obj.boxel_surface)
    pts = obj.pos[obj.boxel_points[idx]]  # (n, 4, 2)
    bbox = np.concatenate([pts.min(axis=1), pts.max(axis=1)], axis=1)
    col = np.floor(bbox[:, 0] / 0.1 + 0.5).astype(np.int64)
    order = np.argsort(col, kind="stable")
    ncol = int(col.max()) + 1
    start = np.searchsorted(col[order], np.arange(ncol + 1)).astype(np.int64)
    return Terrain(
        pos=obj.pos, edges=obj.edge_ab, edge_surface=obj.edge_surface,
        boxel_points=obj.boxel_points[idx], boxel_edges=obj.boxel_edges[idx], bbox=bbox,
        col_start=start, col_boxel=order.astype(np.int64), zero=np.zeros_like(obj.pos),
    )


#: Walker-v0's terrain: a row of 100 fixed voxels
WALKER_TERRAIN = terrain(np.full((1, 100), FIXED))


def _pad(rows: Sequence[np.ndarray], shape: tuple[int, ...], dtype, fill=0) -> np.ndarray:
    out = np.full((len(rows), *shape), fill, dtype=dtype)
    for i, r in enumerate(rows):
        out[i][tuple(slice(0, s) for s in r.shape)] = r
    return out


def _incidence(obj: Object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each point's edges (as end a, then as end b, in edge order), where its run starts, its a count."""
    runs, n_a = [], []
    for p in range(len(obj.pos)):
        ends_a = np.flatnonzero(obj.edge_ab[:, 0] == p)
        runs.append(np.concatenate([ends_a, np.flatnonzero(obj.edge_ab[:, 1] == p)]))
        n_a.append(len(ends_a))
    start = np.concatenate([[0], np.cumsum([len(r) for r in runs])])
    return np.concatenate(runs).astype(np.int64), start.astype(np.int64), np.array(n_a, dtype=np.int64)


def _unshared(main: np.ndarray, ref: np.ndarray) -> int:
    """Bit mask of ``main``'s corners that ``ref`` does not share (the only ones tested for contact)."""
    return sum(1 << k for k in range(4) if main[k] not in ref)


def body_tables(bodies: Sequence[Body | np.ndarray | str], pad: BodyTables | None = None,
                at: tuple[int, int] = ROBOT_AT) -> BodyTables:
    """Build and pad the tables of ``bodies`` placed at voxel ``at`` (to the largest of them, or at
    least to ``pad``'s sizes)."""
    objs = tuple(robot_object(b, at) for b in bodies)
    surf = [np.flatnonzero(o.boxel_surface) for o in objs]
    pair_rows, rigid_rows, act_rows = [], [], []
    for o, s in zip(objs, surf):
        cells, corners = o.boxel_cell[s], o.boxel_points[s]
        rows = [(i, j, int(np.all(np.abs(cells[i] - cells[j]) <= 1)),
                 _unshared(corners[i], corners[j]), _unshared(corners[j], corners[i]))
                for i in range(len(s)) for j in range(i + 1, len(s))]
        pair_rows.append(np.array(rows, dtype=np.int64).reshape(-1, 5))
        rigid_rows.append(o.boxel_edges[o.boxel_type == RIGID])
        acts = []
        for a in o.actuators:
            top, right, bot, left = o.boxel_edges[a]
            acts.append((top, bot) if o.boxel_type[a] == H_ACT else (left, right))
            assert o.boxel_type[a] in (H_ACT, V_ACT)
        act_rows.append(np.array(acts, dtype=np.int64).reshape(-1, 2))

    def size(rows, axis=0, minimum=0):
        return max([minimum, 1] + [r.shape[axis] for r in rows])

    P = size([o.pos for o in objs], minimum=0 if pad is None else pad.init_pos.shape[1])
    E = size([o.edge_ab for o in objs], minimum=0 if pad is None else pad.edges.shape[1])
    S = size([o.boxel_points[s] for o, s in zip(objs, surf)], minimum=0 if pad is None else pad.surface_points.shape[1])
    Q = size(pair_rows, minimum=0 if pad is None else pad.pairs.shape[1])
    R = size(rigid_rows, minimum=0 if pad is None else pad.rigid_edges.shape[1])
    A = size(act_rows, minimum=0 if pad is None else pad.act_edges.shape[1])
    incidence = [_incidence(o) for o in objs]
    i64 = np.int64
    return BodyTables(
        objects=objs,
        n_points=np.array([len(o.pos) for o in objs], dtype=i64),
        n_edges=np.array([len(o.edge_ab) for o in objs], dtype=i64),
        edges=_pad([o.edge_ab for o in objs], (E, 2), i64),
        rest0=_pad([o.edge_len for o in objs], (E,), np.float64, 1.0),
        spring_k=_pad([o.edge_k for o in objs], (E,), np.float64),
        edge_surface=_pad([o.edge_surface for o in objs], (E,), np.bool_),
        n_act=np.array([len(r) for r in act_rows], dtype=i64),
        act_edges=_pad(act_rows, (A, 2), i64),
        n_surface=np.array([len(s) for s in surf], dtype=i64),
        surface_points=_pad([o.boxel_points[s] for o, s in zip(objs, surf)], (S, 4), i64),
        surface_edges=_pad([o.boxel_edges[s] for o, s in zip(objs, surf)], (S, 4), i64),
        n_pairs=np.array([len(r) for r in pair_rows], dtype=i64),
        pairs=_pad(pair_rows, (Q, 5), i64),
        n_rigid=np.array([len(r) for r in rigid_rows], dtype=i64),
        rigid_edges=_pad(rigid_rows, (R, 4), i64),
        point_edges=_pad([inc[0] for inc in incidence], (2 * E,), i64),
        point_start=_pad([inc[1] for inc in incidence], (P + 1,), i64),
        point_n_a=_pad([inc[2] for inc in incidence], (P,), i64),
        init_pos=_pad([o.pos for o in objs], (P, 2), np.float64),
    )


def reset(tables: BodyTables, body: np.ndarray) -> State:
    """Every environment ``i`` at rest in its body's initial pose (``body[i]`` indexes the tables)."""
    body = np.asarray(body, dtype=np.int64)
    pos = tables.init_pos[body].copy()
    return State(pos=pos, vel=np.zeros_like(pos), vtrue=np.zeros_like(pos), body=body)


def observe(tables: BodyTables, state: State) -> np.ndarray:
    """Walker-v0's observation of every environment (padded to the tables' largest body)."""
    out = np.zeros((len(state.body), 2 + 2 * tables.max_points))
    kernels.observe_batch(state.body, state.pos, state.vel, tables.n_points, out)
    return out


def kernel_args(tables: BodyTables, terrain: Terrain) -> tuple:
    """The tables' and terrain's arrays in the order the kernels take them (after the state)."""
    return (tables.n_points, tables.n_edges, tables.edges, tables.rest0, tables.spring_k, tables.edge_surface,
            tables.n_act, tables.act_edges, tables.n_surface, tables.surface_points, tables.surface_edges,
            tables.n_pairs, tables.pairs, tables.n_rigid, tables.rigid_edges, tables.point_edges, tables.point_start,
            tables.point_n_a, *terrain.arrays())


def step(tables: BodyTables, terrain: Terrain, state: State, actions: np.ndarray,
         active: np.ndarray | None = None) -> tuple[State, StepOutput]:
    """One env step of every environment: actions ``(N, A)`` (clipped to [0.6, 1.6]), padded per body.

    Environments with ``active[i]`` False keep their state (their outputs are zeros).
    """
    n = len(state.body)
    acts = np.asarray(actions, dtype=np.float64).reshape(n, -1)
    if acts.shape[1] < tables.max_actuators:
        acts = np.pad(acts, ((0, 0), (0, tables.max_actuators - acts.shape[1])), constant_values=1.0)
    new = replace(state, pos=state.pos.copy(), vel=state.vel.copy(), vtrue=state.vtrue.copy())
    active = np.ones(n, dtype=np.bool_) if active is None else np.asarray(active, dtype=np.bool_)
    obs = np.zeros((n, 2 + 2 * tables.max_points))
    dx = np.zeros(n)
    com = np.zeros(n)
    unstable = np.zeros(n, dtype=np.bool_)
    work = kernels.workspace(n, tables.max_points, tables.edges.shape[1], tables.surface_points.shape[1])
    kernel: Any = kernels.step_parallel if n >= PARALLEL_FROM and numba.get_num_threads() > 1 else kernels.step_serial
    kernel(active, state.body, np.ascontiguousarray(acts), new.pos, new.vel, new.vtrue, *kernel_args(tables, terrain),
           obs, dx, com, unstable, *work)
    return new, StepOutput(obs=obs, dx=dx, com=com, unstable=unstable)
