"""Batched Evolution Gym physics: a world, static tables of its bodies, state as arrays, a pure step function.

    world = engine.world({"ground": (grid, (0, 0)), "package": (box, (3, 6))}, robot_at=(1, 1))
    tables = engine.body_tables([body_a, body_b], world)   # padded to the larger body
    state = engine.reset(tables, body=np.array([0, 0, 1])) # three environments: two of a, one of b
    state, out = engine.step(tables, state, actions)

A **world** is what Evolution Gym builds from a task's sim file: named objects of any voxel types, and
the place where the robot is added.  Objects made only of fixed voxels never move, so they become one
static collider (exactly equivalent: forces on fixed points are discarded); every other object (a
package, a beam, a bridge of soft cells between fixed ones) is simulated in every environment, its
fixed points pinned as Evolution Gym pins them.  Each environment's points are the moving objects'
(in the world's order) followed by its robot's, so an object's points sit at the same indices in
every environment and the robot's start at ``tables.robot_start``.

``step`` never changes its inputs: it returns a new :class:`State` and a :class:`StepOutput` (which
environments became unstable).  The engine knows no task: observations and rewards are computed from
the state by the task layer (:mod:`gdabench.envs.tasks`).  Bodies are padded to the batch's largest
(or to ``pad``); padding is never simulated, so a body's trajectory does not depend on its batch.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Mapping, Sequence

import numba
import numpy as np

from ...body import Body, as_body
from ...cpu import start_numba_threads
from . import PARALLEL_FROM, kernels
from .model import CELL, FIXED, H_ACT, RIGID, V_ACT, Object, build_object

start_numba_threads()  # now, not at the first step: inside a training it would change torch's threads

#: where Walker-v0 places the robot (voxels): x 1, bottom at y 1
ROBOT_AT = (1, 1)

#: pair kinds (column 2 of ``pairs``): the robot's non-adjacent and adjacent boxels, two boxels of one other
#: object, boxels of two different objects; Evolution Gym meets a pair within one object twice
ROBOT_APART, ROBOT_ADJACENT, SAME_OBJECT, TWO_OBJECTS = 0, 1, 2, 3


@dataclass(frozen=True)
class Terrain:
    """Static colliders: their surface boxels, with a lookup by 0.1-wide column and row."""

    pos: np.ndarray
    edges: np.ndarray
    edge_surface: np.ndarray
    boxel_points: np.ndarray
    boxel_edges: np.ndarray
    bbox: np.ndarray
    owner: np.ndarray  # the moving object each boxel belongs to (pairs within one object count twice), or -1
    link: np.ndarray  # (T, 4): each corner's index among the moving points, if it is one of them, else -1
    bin_start: np.ndarray  # ((columns * rows) + 1,): where each (column, row) bin's run in bin_boxel starts
    bin_boxel: np.ndarray
    rows: np.ndarray  # (1,): the number of rows of bins
    zero: np.ndarray  # the terrain's (zero) velocities, and a sink for forces on it

    def arrays(self) -> tuple:
        return (self.pos, self.edges, self.edge_surface, self.boxel_points, self.boxel_edges, self.bbox,
                self.owner, self.link, self.bin_start, self.bin_boxel, self.rows, self.zero)


def terrain(parts: Sequence[tuple[Object, np.ndarray, int, np.ndarray | None]]) -> Terrain:
    """One static collider: of each ``(object, boxels, owner, link)``, those boxels (surface ones), binned by
    the cell of their corner.  ``owner`` is the moving object the boxels belong to (Evolution Gym meets pairs
    within one object twice), or -1 for objects that never move; ``link[p]`` is where the object's point ``p``
    is simulated, if it is (a corner shared with a moving boxel is not a contact), else -1."""
    if not parts:  # no static object: one empty bin
        i64 = np.zeros(0, dtype=np.int64)
        return Terrain(pos=np.zeros((0, 2)), edges=np.zeros((0, 2), np.int64), edge_surface=np.zeros(0, np.bool_),
                       boxel_points=np.zeros((0, 4), np.int64), boxel_edges=np.zeros((0, 4), np.int64),
                       bbox=np.zeros((0, 4)), owner=i64, link=np.zeros((0, 4), np.int64),
                       bin_start=np.zeros(2, np.int64), bin_boxel=i64,
                       rows=np.ones(1, np.int64), zero=np.zeros((0, 2)))
    pos, edges, surf, points, boxel_edges, owners, links = [], [], [], [], [], [], []
    n_points = n_edges = 0
    for obj, boxels, owner, link in parts:
        links.append(np.full((len(boxels), 4), -1, dtype=np.int64) if link is None else link[obj.boxel_points[boxels]])
        pos.append(obj.pos)
        edges.append(obj.edge_ab + n_points)
        surf.append(obj.edge_surface)
        points.append(obj.boxel_points[boxels] + n_points)
        boxel_edges.append(obj.boxel_edges[boxels] + n_edges)
        owners.append(np.full(len(boxels), owner, dtype=np.int64))
        n_points += len(obj.pos)
        n_edges += len(obj.edge_ab)
    all_pos = np.concatenate(pos)
    boxel_points = np.concatenate(points)
    corners = all_pos[boxel_points]  # (n, 4, 2)
    bbox = np.concatenate([corners.min(axis=1), corners.max(axis=1)], axis=1)
    col = np.floor(bbox[:, 0] / CELL + 0.5).astype(np.int64)
    row = np.floor(bbox[:, 1] / CELL + 0.5).astype(np.int64)
    n_rows = int(row.max()) + 1
    key = col * n_rows + row
    order = np.argsort(key, kind="stable")
    n_bins = (int(col.max()) + 1) * n_rows
    start = np.searchsorted(key[order], np.arange(n_bins + 1)).astype(np.int64)
    return Terrain(
        pos=all_pos, edges=np.concatenate(edges), edge_surface=np.concatenate(surf), boxel_points=boxel_points,
        boxel_edges=np.concatenate(boxel_edges), bbox=bbox, owner=np.concatenate(owners),
        link=np.concatenate(links), bin_start=start,
        bin_boxel=order.astype(np.int64), rows=np.array([n_rows], dtype=np.int64), zero=np.zeros_like(all_pos),
    )


def _subset(obj: Object, points: np.ndarray, boxels: np.ndarray) -> Object:
    """``obj`` restricted to ``points`` (and the edges between them) and ``boxels`` (whose corners they hold)."""
    new_index = np.full(len(obj.pos), -1, dtype=np.int64)
    new_index[points] = np.arange(len(points))
    edges = np.flatnonzero(np.all(new_index[obj.edge_ab] >= 0, axis=1))
    new_edge = np.full(len(obj.edge_ab), -1, dtype=np.int64)
    new_edge[edges] = np.arange(len(edges))
    return Object(
        pos=obj.pos[points], fixed=obj.fixed[points], edge_ab=new_index[obj.edge_ab[edges]],
        edge_len=obj.edge_len[edges], edge_k=obj.edge_k[edges], edge_surface=obj.edge_surface[edges],
        boxel_type=obj.boxel_type[boxels], boxel_cell=obj.boxel_cell[boxels],
        boxel_points=new_index[obj.boxel_points[boxels]], boxel_edges=new_edge[obj.boxel_edges[boxels]],
        boxel_surface=obj.boxel_surface[boxels], actuators=np.zeros(0, dtype=np.int64), width=obj.width,
    )


def _prune(obj: Object) -> tuple[Object, np.ndarray, np.ndarray]:
    """The part of a moving object that must be simulated; which of its points that is; and the surface boxels
    left out (static colliders from now on).

    A fixed point never moves, but RK4 moves it through its stages, and a point it shares a spring with feels
    that: its position in stages 3 and 4 depends on its accelerations in stages 1 and 2, which depend on its
    own springs at the stage's positions (its fixed neighbours have not moved yet then) and on the collision
    forces on it.  So the moving points (M), the fixed points sharing a spring with them (R1, simulated with
    their collisions) and the fixed points sharing one with those (R2, held where they rest) give M exactly
    Evolution Gym's trajectory; a boxel without a corner in M or R1 collides as a static one.  An object
    whose rigid voxels touch fixed ones is kept whole: Evolution Gym's rigid pass moves fixed points.
    """
    everything = np.arange(len(obj.pos))
    rigid = obj.boxel_points[obj.boxel_type == RIGID]
    if not obj.fixed.any() or obj.fixed[rigid].any():
        return obj, everything, np.zeros(0, dtype=np.int64)

    def ring(inner: np.ndarray) -> np.ndarray:
        touch = np.zeros(len(obj.pos), dtype=bool)
        a, b = obj.edge_ab[:, 0], obj.edge_ab[:, 1]
        touch[b[inner[a]]] = True
        touch[a[inner[b]]] = True
        return touch & ~inner

    moving = ~obj.fixed
    r1 = ring(moving)
    near = moving | r1
    keep_points = np.flatnonzero(near | ring(near))
    keep = near[obj.boxel_points].any(axis=1)
    removed = np.flatnonzero(~keep & obj.boxel_surface)
    return _subset(obj, keep_points, np.flatnonzero(keep)), keep_points, removed


@dataclass(frozen=True)
class World:
    """A task's world without its robot: the objects simulated in every environment, the static ones, and
    where the robot goes.  ``moving`` objects are numbered as if created after the robot (never index 0);
    of a moving object with fixed voxels only the part that can affect its moving points is simulated
    (``kept[k]``: which of its points; ``rest[k]``: where all of them rest)."""

    names: tuple[str, ...]  # the moving objects' names, in order
    moving: tuple[Object, ...]  # the simulated part of each
    whole: tuple[Object, ...]  # and each whole
    kept: tuple[np.ndarray, ...]
    rest: tuple[np.ndarray, ...]
    static_names: tuple[str, ...]
    static: tuple[Object, ...]
    terrain: Terrain
    robot_at: tuple[int, int]
    grids: Mapping[str, np.ndarray]  # every object's cells (rows top to bottom), by name

    @property
    def point_starts(self) -> dict[str, int]:
        """Where each moving object's (simulated) points start in an environment's point arrays."""
        starts, n = {}, 0
        for name, obj in zip(self.names, self.moving):
            starts[name] = n
            n += len(obj.pos)
        return starts

    @property
    def n_points(self) -> int:
        return sum(len(obj.pos) for obj in self.moving)


def world(objects: Mapping[str, tuple[np.ndarray, tuple[int, int]]], robot_at: tuple[int, int] = ROBOT_AT,
          moving: Sequence[str] = ()) -> World:
    """A world of named objects (cells with rows top to bottom, bottom-left voxel), in Evolution Gym's order
    (by name).  Objects with any non-fixed voxel, and those named in ``moving`` (placed per environment),
    are simulated; the rest are one static collider."""
    names: list[str] = []
    static_names: list[str] = []
    built: list[Object] = []
    whole: list[Object] = []
    static: list[Object] = []
    kept: list[np.ndarray] = []
    rest: list[np.ndarray] = []
    colliders: list[tuple[Object, np.ndarray, int, np.ndarray | None]] = []
    removed_parts: list[tuple[int, Object, np.ndarray]] = []
    grids = {}
    for name in sorted(objects):
        grid, at = objects[name]
        grid = np.asarray(grid, dtype=np.int64)
        grids[name] = grid
        obj = build_object(grid, at, point_offset=1, edge_offset=1)
        if name in moving:  # placed per environment: simulated whole
            part, points, removed = obj, np.arange(len(obj.pos)), np.zeros(0, dtype=np.int64)
        elif np.all(grid[grid != 0] == FIXED):
            static_names.append(name)
            static.append(obj)
            colliders.append((obj, np.flatnonzero(obj.boxel_surface), -1, None))
            continue
        else:
            part, points, removed = _prune(obj)
        if len(removed):
            removed_parts.append((len(names), obj, removed))
        names.append(name)
        built.append(part)
        whole.append(obj)
        kept.append(points)
        rest.append(obj.pos)
    start = np.concatenate([[0], np.cumsum([len(part.pos) for part in built])])
    for k, obj, removed in removed_parts:  # the object's simulated points, as every environment numbers them
        link = np.full(len(obj.pos), -1, dtype=np.int64)
        link[kept[k]] = start[k] + np.arange(len(kept[k]))
        colliders.append((obj, removed, k, link))
    return World(names=tuple(names), moving=tuple(built), whole=tuple(whole), kept=tuple(kept), rest=tuple(rest),
                 static_names=tuple(static_names), static=tuple(static), terrain=terrain(colliders),
                 robot_at=robot_at, grids=grids)


#: Walker-v0's world: a row of 100 fixed voxels, the robot at voxel (1, 1)
WALKER_WORLD = world({"ground": (np.full((1, 100), FIXED), (0, 0))})


@dataclass(frozen=True)
class BodyTables:
    """Every body of a batch in its world as padded arrays (first axis: body), plus the unpadded robots."""

    world: World
    robots: tuple[Object, ...]
    robot_start: int  # where the robot's points (and edges) start: after the moving objects'
    n_robot_points: np.ndarray  # (B,)
    n_points: np.ndarray
    n_edges: np.ndarray
    edges: np.ndarray  # (B, E, 2)
    rest0: np.ndarray  # (B, E)
    spring_k: np.ndarray
    edge_surface: np.ndarray
    fixed: np.ndarray  # (B, P) bool
    n_act: np.ndarray
    act_edges: np.ndarray  # (B, A, 2): the two edges each actuator drives
    n_surface: np.ndarray
    n_robot_surface: np.ndarray  # the robot's surface boxels come first; its unstable threshold
    surface_owner: np.ndarray  # (B, S): the moving object each surface boxel belongs to (the robot: after them)
    surface_points: np.ndarray  # (B, S, 4)
    surface_edges: np.ndarray  # (B, S, 4)
    n_pairs: np.ndarray
    pairs: np.ndarray  # (B, Q, 5): surface boxels i < j, pair kind, corners of i (bits) not in j, of j not in i
    n_groups: np.ndarray
    group_start: np.ndarray  # (B, G + 1): where each group of surface boxels starts (the robot: group 0)
    n_group_pairs: np.ndarray
    group_pairs: np.ndarray  # (B, GP, 4): groups g1 <= g2 and the run of ``pairs`` between them
    n_rigid: np.ndarray
    rigid_edges: np.ndarray  # (B, R, 4)
    point_edges: np.ndarray  # (B, 2E): per point, its edges where it is end a, then where it is end b
    point_start: np.ndarray  # (B, P + 1): where each point's run in point_edges starts
    point_n_a: np.ndarray  # (B, P): how many of them are a ends
    live: np.ndarray  # (B, 2): how many edges touch a moving point (they come first), a moving or near one (_live)
    far: np.ndarray  # (B, P) bool: pinned points sharing no spring with a moving point
    init_pos: np.ndarray  # (B, P, 2)

    @property
    def objects(self) -> tuple[Object, ...]:
        """The robots (one per body), as earlier versions named them."""
        return self.robots

    @property
    def max_points(self) -> int:
        return self.init_pos.shape[1]

    @property
    def max_actuators(self) -> int:
        return self.act_edges.shape[1]

    @property
    def max_robot_points(self) -> int:
        return self.max_points - self.robot_start


@dataclass(frozen=True)
class State:
    """Positions, velocities and true velocities (finite differences) of every environment's points."""

    pos: np.ndarray  # (N, P, 2)
    vel: np.ndarray
    vtrue: np.ndarray
    body: np.ndarray  # (N,) index into the tables


@dataclass(frozen=True)
class StepOutput:
    unstable: np.ndarray  # (N,) bool: the step was undone (Evolution Gym's snapshot is the state before it)


def robot_object(body: Body | np.ndarray | str, at: tuple[int, int] = ROBOT_AT) -> Object:
    grid = np.asarray(as_body(body).voxels) if not isinstance(body, np.ndarray) else body
    return build_object(grid, at)


def _pad(rows: Sequence[np.ndarray], shape: tuple[int, ...], dtype, fill=0) -> np.ndarray:
    out = np.full((len(rows), *shape), fill, dtype=dtype)
    for i, r in enumerate(rows):
        out[i][tuple(slice(0, s) for s in r.shape)] = r
    return out


def _incidence(edge_ab: np.ndarray, n_points: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each point's edges (as end a, then as end b, in edge order), where its run starts, its a count."""
    runs, n_a = [], []
    for p in range(n_points):
        ends_a = np.flatnonzero(edge_ab[:, 0] == p)
        runs.append(np.concatenate([ends_a, np.flatnonzero(edge_ab[:, 1] == p)]))
        n_a.append(len(ends_a))
    start = np.concatenate([[0], np.cumsum([len(r) for r in runs])])
    return np.concatenate(runs).astype(np.int64), start.astype(np.int64), np.array(n_a, dtype=np.int64)


def _live(edge_ab: np.ndarray, fixed: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which accelerations can reach a moving point: ``(edge order, counts, far points)`` for the kernel.

    A pinned point's RK4 update is discarded and its velocity stays zero, so its position is its rest in
    stages 1 and 2 and moves in stages 3 and 4 by its accelerations in stages 1 and 2.  Hence a moving point's
    accelerations are needed in all four stages; a pinned point's sharing a spring with one (a "near" point)
    in the first two; every other ("far") point's never, and an edge's force only where it touches a point
    computed then.  The edges are put in that order: those touching a moving point, those touching a near
    one, the rest (each part in edge order, in which the clamps apply their corrections; an edge between
    pinned points moves neither)."""
    moving = ~fixed
    a, b = edge_ab[:, 0], edge_ab[:, 1]
    touch_moving = moving[a] | moving[b]
    near = moving.copy()
    near[a[touch_moving]] = True
    near[b[touch_moving]] = True
    touch_near = near[a] | near[b]
    order = np.concatenate([np.flatnonzero(touch_moving), np.flatnonzero(touch_near & ~touch_moving),
                            np.flatnonzero(~touch_near)])
    return order, np.array([touch_moving.sum(), touch_near.sum()], dtype=np.int64), ~near


def _unshared(main: np.ndarray, ref: np.ndarray) -> int:
    """Bit mask of ``main``'s corners that ``ref`` does not share (the only ones tested for contact)."""
    return sum(1 << k for k in range(4) if main[k] not in ref)


#: a moving object's surface boxels are grouped by blocks of this many cells a side: pairs of groups whose
#: bounding boxes are apart are skipped at once (the robot is one group, tested pair by pair as always)
BLOCK = 3


@dataclass(frozen=True)
class _Part:
    """One object placed in an environment's arrays: its surface boxels (in group order) and their groups."""

    obj: Object
    owner: int  # its index among the environment's objects (the robot: last)
    point0: int
    edge0: int
    surface: np.ndarray  # its surface boxels (indices into obj's boxels), group by group
    groups: list[np.ndarray]  # positions in ``surface`` of each group's boxels
    surface0: int = 0  # where they start in the environment's surface list


def _part(obj: Object, owner: int, point0: int, edge0: int, whole: bool) -> _Part:
    surface = np.flatnonzero(obj.boxel_surface)
    if whole:
        return _Part(obj, owner, point0, edge0, surface, [np.arange(len(surface))])
    block = obj.boxel_cell[surface] // BLOCK
    key = block[:, 0] * 100_000 + block[:, 1]
    order = np.argsort(key, kind="stable")
    surface, key = surface[order], key[order]
    cuts = np.flatnonzero(np.diff(key)) + 1
    return _Part(obj, owner, point0, edge0, surface, np.split(np.arange(len(surface)), cuts))


def _pairs(parts: Sequence[_Part], robot: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Candidate boxel pairs, grouped: the surface list's group boundaries, and for every pair of groups
    ``(g1, g2, first pair, end)`` into the pair rows ``(i, j, kind, corners of i not in j, of j not in i)``.

    The robot's own pairs come first (kind by adjacency), then each object's, then pairs across objects.
    Pairs whose eight corners are all fixed are left out: their forces land on points that cannot move them."""
    order = [robot] + [k for k in range(len(parts)) if k != robot]
    starts, group_of = [0], {}
    for k in order:
        for g, members in enumerate(parts[k].groups):
            group_of[k, g] = len(starts) - 1
            starts.append(starts[-1] + len(members))

    def pinned(part: _Part, s: int) -> bool:
        return bool(np.all(part.obj.fixed[part.obj.boxel_points[part.surface[s]]]))

    rows: list[tuple[int, int, int, int, int]] = []
    group_pairs: list[tuple[int, int, int, int]] = []

    def add(pa: _Part, ga: int, pb: _Part, gb: int) -> None:
        first = len(rows)
        same = pa is pb
        cells_a, corners_a = pa.obj.boxel_cell[pa.surface], pa.obj.boxel_points[pa.surface]
        cells_b, corners_b = pb.obj.boxel_cell[pb.surface], pb.obj.boxel_points[pb.surface]
        for i in pa.groups[ga]:
            for j in pb.groups[gb]:
                if same and j <= i:
                    continue
                if same and pa.owner == robot:
                    kind = ROBOT_ADJACENT if np.all(np.abs(cells_a[i] - cells_b[j]) <= 1) else ROBOT_APART
                elif pinned(pa, i) and pinned(pb, j):
                    continue
                else:
                    kind = SAME_OBJECT if same else TWO_OBJECTS
                mask_a = _unshared(corners_a[i], corners_b[j]) if same else 15
                mask_b = _unshared(corners_b[j], corners_a[i]) if same else 15
                rows.append((pa.surface0 + i, pb.surface0 + j, kind, mask_a, mask_b))
        if len(rows) > first:
            group_pairs.append((group_of[pa.owner, ga], group_of[pb.owner, gb], first, len(rows)))

    for k in order:  # within each object
        part = parts[k]
        for ga in range(len(part.groups)):
            for gb in range(ga, len(part.groups)):
                add(part, ga, part, gb)
    for a in range(len(order)):  # across objects
        for b in range(a + 1, len(order)):
            pa, pb = parts[order[a]], parts[order[b]]
            for ga in range(len(pa.groups)):
                for gb in range(len(pb.groups)):
                    add(pa, ga, pb, gb)
    return (np.array(rows, dtype=np.int64).reshape(-1, 5), np.array(starts, dtype=np.int64),
            np.array(group_pairs, dtype=np.int64).reshape(-1, 4))


def _assemble(w: World, robot: Object) -> dict[str, np.ndarray]:
    """One environment's arrays: the world's moving objects, then the robot."""
    parts: list[_Part] = []
    point0 = edge0 = 0
    for obj in (*w.moving, robot):
        parts.append(_part(obj, len(parts), point0, edge0, whole=obj is robot))
        point0 += len(obj.pos)
        edge0 += len(obj.edge_ab)
    robot_index = len(parts) - 1
    surface0 = 0
    for k in [robot_index] + list(range(robot_index)):  # the robot's surface boxels first
        parts[k] = replace(parts[k], surface0=surface0)
        surface0 += len(parts[k].surface)
    by_surface = sorted(parts, key=lambda p: p.surface0)
    edge_ab = np.concatenate([p.obj.edge_ab + p.point0 for p in parts])
    rigid = np.concatenate([p.obj.boxel_edges[p.obj.boxel_type == RIGID] + p.edge0 for p in by_surface])
    acts = []
    for a in robot.actuators:
        top, right, bot, left = robot.boxel_edges[a] + parts[robot_index].edge0
        assert robot.boxel_type[a] in (H_ACT, V_ACT)
        acts.append((top, bot) if robot.boxel_type[a] == H_ACT else (left, right))
    pairs, group_start, group_pairs = _pairs(parts, robot_index)
    fixed = np.concatenate([p.obj.fixed for p in parts])
    order, live, far = _live(edge_ab, fixed)
    renumber = np.empty_like(order)  # edges are renumbered in that order (no edge index leaves the kernel)
    renumber[order] = np.arange(len(order))
    inc, inc_start, inc_n_a = _incidence(edge_ab, point0)  # (each point's edges in their first order)
    return {
        "edges": edge_ab[order],
        "rest0": np.concatenate([p.obj.edge_len for p in parts])[order],
        "spring_k": np.concatenate([p.obj.edge_k for p in parts])[order],
        "edge_surface": np.concatenate([p.obj.edge_surface for p in parts])[order],
        "fixed": fixed,
        "act_edges": renumber[np.array(acts, dtype=np.int64).reshape(-1, 2)],
        "surface_owner": np.concatenate([np.full(len(p.surface), p.owner) for p in by_surface]),
        "surface_points": np.concatenate([p.obj.boxel_points[p.surface] + p.point0 for p in by_surface]),
        "surface_edges": renumber[np.concatenate([p.obj.boxel_edges[p.surface] + p.edge0 for p in by_surface])],
        "pairs": pairs,
        "group_start": group_start,
        "group_pairs": group_pairs,
        "rigid_edges": renumber[rigid.reshape(-1, 4)],
        "incidence": (renumber[inc], inc_start, inc_n_a),
        "live": live,
        "far": far,
        "init_pos": np.concatenate([p.obj.pos for p in parts]),
        "n_robot_surface": np.array(len(parts[robot_index].surface)),
    }


def body_tables(bodies: Sequence[Body | np.ndarray | str], w: World = WALKER_WORLD,
                pad: BodyTables | None = None) -> BodyTables:
    """Build and pad the tables of ``bodies`` in world ``w`` (to the largest of them, or at least to ``pad``'s
    sizes)."""
    robots = tuple(robot_object(b, w.robot_at) for b in bodies)
    rows = [_assemble(w, r) for r in robots]

    def size(key: str, axis: int = 0, padded: np.ndarray | None = None) -> int:
        return max([1 if padded is None else padded.shape[1]] + [r[key].shape[axis] for r in rows])

    P = size("init_pos", padded=None if pad is None else pad.init_pos)
    E = size("edges", padded=None if pad is None else pad.edges)
    S = size("surface_points", padded=None if pad is None else pad.surface_points)
    Q = size("pairs", padded=None if pad is None else pad.pairs)
    R = size("rigid_edges", padded=None if pad is None else pad.rigid_edges)
    G = size("group_start", padded=None if pad is None else pad.group_start)
    GP = size("group_pairs", padded=None if pad is None else pad.group_pairs)
    A = size("act_edges", padded=None if pad is None else pad.act_edges)
    i64 = np.int64

    def stack(key: str, shape: tuple[int, ...], dtype: Any, fill: Any = 0) -> np.ndarray:
        return _pad([r[key] for r in rows], shape, dtype, fill)

    return BodyTables(
        world=w,
        robots=robots,
        robot_start=w.n_points,
        n_robot_points=np.array([len(r.pos) for r in robots], dtype=i64),
        n_points=np.array([len(r["init_pos"]) for r in rows], dtype=i64),
        n_edges=np.array([len(r["edges"]) for r in rows], dtype=i64),
        edges=stack("edges", (E, 2), i64),
        rest0=stack("rest0", (E,), np.float64, 1.0),
        spring_k=stack("spring_k", (E,), np.float64),
        edge_surface=stack("edge_surface", (E,), np.bool_),
        fixed=stack("fixed", (P,), np.bool_),
        n_act=np.array([len(r["act_edges"]) for r in rows], dtype=i64),
        act_edges=stack("act_edges", (A, 2), i64),
        n_surface=np.array([len(r["surface_points"]) for r in rows], dtype=i64),
        n_robot_surface=np.array([int(r["n_robot_surface"]) for r in rows], dtype=i64),
        surface_owner=stack("surface_owner", (S,), i64, -2),
        surface_points=stack("surface_points", (S, 4), i64),
        surface_edges=stack("surface_edges", (S, 4), i64),
        n_pairs=np.array([len(r["pairs"]) for r in rows], dtype=i64),
        pairs=stack("pairs", (Q, 5), i64),
        n_groups=np.array([len(r["group_start"]) - 1 for r in rows], dtype=i64),
        group_start=stack("group_start", (G,), i64),
        n_group_pairs=np.array([len(r["group_pairs"]) for r in rows], dtype=i64),
        group_pairs=stack("group_pairs", (GP, 4), i64),
        n_rigid=np.array([len(r["rigid_edges"]) for r in rows], dtype=i64),
        rigid_edges=stack("rigid_edges", (R, 4), i64),
        point_edges=_pad([r["incidence"][0] for r in rows], (2 * E,), i64),
        point_start=_pad([r["incidence"][1] for r in rows], (P + 1,), i64),
        point_n_a=_pad([r["incidence"][2] for r in rows], (P,), i64),
        live=np.stack([r["live"] for r in rows]),
        far=stack("far", (P,), np.bool_),
        init_pos=stack("init_pos", (P, 2), np.float64),
    )


def reset(tables: BodyTables, body: np.ndarray, init_pos: np.ndarray | None = None) -> State:
    """Every environment ``i`` at rest in its body's initial pose (``body[i]`` indexes the tables), or at
    ``init_pos`` (``(N, P, 2)``: where a task places its objects per environment)."""
    body = np.asarray(body, dtype=np.int64)
    pos = tables.init_pos[body].copy() if init_pos is None else np.array(init_pos, dtype=np.float64)
    return State(pos=pos, vel=np.zeros_like(pos), vtrue=np.zeros_like(pos), body=body)


def kernel_args(tables: BodyTables) -> tuple[tuple, tuple]:
    """The tables' arrays and the terrain's, as the kernels take them (after the state)."""
    body = (tables.n_points, tables.n_edges, tables.edges, tables.rest0, tables.spring_k, tables.edge_surface,
            tables.fixed, tables.n_act, tables.act_edges, tables.n_surface, tables.n_robot_surface,
            tables.surface_owner, tables.surface_points, tables.surface_edges, tables.pairs, tables.n_groups,
            tables.group_start, tables.n_group_pairs, tables.group_pairs, tables.n_rigid, tables.rigid_edges,
            tables.point_edges, tables.point_start, tables.point_n_a, tables.live, tables.far)
    return body, tables.world.terrain.arrays()


def _max_threads() -> int:
    return int(numba.config.NUMBA_NUM_THREADS)  # type: ignore[attr-defined]  # (set at import, untyped)


def default_threads(n: int) -> int:
    """Threads worth using for ``n`` environments: one for small batches (waking threads, and sharing cores
    with other work, costs more than they save: 8 environments ran 6x faster on one thread than on two busy
    cores), else one per 16 environments, up to the cores this process may use."""
    import os

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return 1 if n < 32 else max(1, min(cores, _max_threads(), n // 16))


def step(tables: BodyTables, state: State, actions: np.ndarray, active: np.ndarray | None = None,
         threads: int | None = None) -> tuple[State, StepOutput]:
    """One env step of every environment: actions ``(N, A)`` (clipped to [0.6, 1.6]), padded per body.

    Environments with ``active[i]`` False keep their state.  ``threads``: how many threads step the
    batch (None: Numba's current count, from :data:`PARALLEL_FROM` environments); results are the same
    on any number.
    """
    n = len(state.body)
    acts = np.asarray(actions, dtype=np.float64).reshape(n, -1)
    if acts.shape[1] < tables.max_actuators:
        acts = np.pad(acts, ((0, 0), (0, tables.max_actuators - acts.shape[1])), constant_values=1.0)
    new = replace(state, pos=state.pos.copy(), vel=state.vel.copy(), vtrue=state.vtrue.copy())
    active = np.ones(n, dtype=np.bool_) if active is None else np.asarray(active, dtype=np.bool_)
    unstable = np.zeros(n, dtype=np.bool_)
    work = kernels.workspace(n, tables.max_points, tables.edges.shape[1], tables.surface_points.shape[1])
    body, terrain = kernel_args(tables)
    args = (active, state.body, np.ascontiguousarray(acts), new.pos, new.vel, new.vtrue, unstable, *work, *body,
            *terrain)
    before = numba.get_num_threads()
    use = before if threads is None else max(1, min(int(threads), _max_threads()))
    if n < PARALLEL_FROM or use == 1:
        kernels.step_serial(*args)
    elif use == before:
        kernels.step_parallel(*args)
    else:
        numba.set_num_threads(use)
        try:
            kernels.step_parallel(*args)
        finally:
            numba.set_num_threads(before)
    return new, StepOutput(unstable=unstable)
