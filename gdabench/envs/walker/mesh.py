"""The mass-spring mesh of a voxel body: point masses, springs and how actuators drive them.

Pure topology and geometry (numpy only); :mod:`.sim` turns a :class:`Mesh` into pymunk objects.
The structure is Evolution Gym's (its ``ObjectCreator`` and ``PhysicsEngine``):

* every voxel is a square cell whose four corners are point masses; voxels that share an edge
  share that edge's two corners, voxels that touch only at a corner (and have no common edge
  neighbour there) keep separate, coincident points, because voxels join only through edges;
* every voxel edge is one spring, shared by the (up to two) voxels on either side; each voxel
  adds its two diagonals as springs of its own;
* a shared edge takes the constant of the last soft or actuator voxel touching it, in row-major
  order from the top row (Evolution Gym creates edges with the rigid constant and lets each
  soft or actuator voxel overwrite the constants of its four edges); rigid voxels also keep their
  four edges within a few percent of their length (:attr:`Mesh.rigid_edge`);
* actuators drive edges only, never diagonals: a horizontal actuator (code 3) with ratio ``r``
  wants its top and bottom edges ``r`` voxels long, a vertical one (code 4) its left and right
  edges; an edge driven by two actuators wants the mean of their ratios, and an edge shared with
  a rigid voxel stays as the rigid voxel holds it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...body import EMPTY, H_ACT, RIGID, V_ACT

#: spring kinds
EDGE, DIAGONAL = 0, 1


@dataclass(frozen=True)
class SpringTable:
    """Stiffness (N/m) of one voxel type's edge and diagonal springs."""

    edge_stiffness: float
    diagonal_stiffness: float


@dataclass(frozen=True)
class Mesh:
    """Points, springs and actuator drive of one body placed in the world.

    Points are numbered in Evolution Gym's order: voxels row by row from the top row of the
    body array, each creating its missing corners top-left, top-right, bottom-left, bottom-right.
    """

    points: np.ndarray  # (n_points, 2) initial positions
    spring_ends: np.ndarray  # (n_springs, 2) point indices
    spring_kind: np.ndarray  # (n_springs,) EDGE or DIAGONAL
    spring_base: np.ndarray  # (n_springs,) rest length with every actuator at ratio 1
    stiffness: np.ndarray  # (n_springs,)
    rigid_edge: np.ndarray  # (n_springs,) bool: an edge of a rigid voxel, held near its length
    voxel_corners: np.ndarray  # (n_voxels, 4) point indices TL, TR, BR, BL: a loop around the voxel
    voxel_codes: np.ndarray  # (n_voxels,) codes 1-4
    voxel_cells: np.ndarray  # (n_voxels, 2) (row, col) in the body array
    surface: np.ndarray  # (n_voxels,) bool: the voxel has an edge without a neighbour
    actuator_cells: np.ndarray  # (n_actuators, 3) (row, col, code), in action order
    driven: np.ndarray  # indices of the springs some actuator drives
    # actuator drive: actuator drive_act[j] pulls on spring driven[drive_slot[j]]
    drive_slot: np.ndarray
    drive_act: np.ndarray
    drive_count: np.ndarray  # (len(driven),) how many actuators drive each driven spring
    voxel_size: float

    @property
    def n_points(self) -> int:
        return len(self.points)

    @property
    def n_actuators(self) -> int:
        return len(self.actuator_cells)

    def rest_lengths(self, ratios: np.ndarray) -> np.ndarray:
        """Rest length of each spring in ``driven`` for actuator length ratios ``ratios``."""
        r = np.asarray(ratios, dtype=float)[self.drive_act]
        mean = np.bincount(self.drive_slot, weights=r, minlength=len(self.driven)) / self.drive_count
        return mean * self.voxel_size


def _corner_groups(occupied: np.ndarray, i: int, j: int) -> list[list[tuple[int, int]]]:
    """Voxels around lattice corner (i, j), grouped into sets that share one point there.

    The (up to) four voxels around a corner share its point when they are linked through
    common edges; two voxels touching only at this corner keep separate points.
    """
    h, w = occupied.shape
    around = [(i - 1, j - 1), (i - 1, j), (i, j), (i, j - 1)]  # clockwise: consecutive ones share an edge
    present = [0 <= r < h and 0 <= c < w and bool(occupied[r, c]) for r, c in around]
    groups: list[list[tuple[int, int]]] = []
    start = next((k for k in range(4) if not present[k]), None)
    if start is None:  # all four present: one group
        return [around]
    current: list[tuple[int, int]] = []
    for step in range(1, 5):
        k = (start + step) % 4
        if present[k]:
            current.append(around[k])
        elif current:
            groups.append(current)
            current = []
    if current:
        groups.append(current)
    return groups


def build_mesh(
    voxels: np.ndarray,
    tables: dict[int, SpringTable],
    *,
    voxel_size: float,
    origin: tuple[float, float],
) -> Mesh:
    """Mesh of ``voxels`` (codes, row 0 on top) whose grid's lower-left corner sits at ``origin``.

    ``tables`` gives the spring constants of every voxel type (codes 1-4).
    """
    grid = np.asarray(voxels)
    h, w = grid.shape
    occupied = grid != EMPTY
    x0, y0 = origin

    # -- points ------------------------------------------------------------------------------
    corner_point: dict[tuple[int, int, int, int], int] = {}  # (i, j, voxel row, voxel col) -> point
    points: list[tuple[float, float]] = []
    voxel_cells = [(r, c) for r in range(h) for c in range(w) if occupied[r, c]]
    corner_offsets = ((0, 0), (0, 1), (1, 0), (1, 1))  # TL, TR, BL, BR as lattice offsets (di, dj)
    for r, c in voxel_cells:
        for di, dj in corner_offsets:
            i, j = r + di, c + dj
            if (i, j, r, c) in corner_point:
                continue
            index = len(points)
            points.append((x0 + j * voxel_size, y0 + (h - i) * voxel_size))
            group = next(g for g in _corner_groups(occupied, i, j) if (r, c) in g)
            for vr, vc in group:
                corner_point[(i, j, vr, vc)] = index

    # -- springs ------------------------------------------------------------------------------
    spring_index: dict[tuple[int, int], int] = {}
    ends: list[tuple[int, int]] = []
    kinds: list[int] = []
    base: list[float] = []
    stiffness: list[float] = []
    rigid_edge: list[bool] = []
    drive: dict[int, list[int]] = {}  # spring -> actuators driving it
    corners: list[tuple[int, int, int, int]] = []
    codes: list[int] = []
    surface: list[bool] = []
    actuators: list[tuple[int, int, int]] = []
    diagonal = math.sqrt(2.0) * voxel_size

    def edge(a: int, b: int, code: int, actuator: int | None) -> None:
        key = (min(a, b), max(a, b))
        s = spring_index.get(key)
        if s is None:
            s = spring_index[key] = len(ends)
            ends.append(key)
            kinds.append(EDGE)
            base.append(voxel_size)
            stiffness.append(tables[RIGID].edge_stiffness)
            rigid_edge.append(False)
        if code == RIGID:
            rigid_edge[s] = True
        else:  # soft and actuator voxels overwrite the constant, the last one in row-major order wins
            stiffness[s] = tables[code].edge_stiffness
        if actuator is not None:
            drive.setdefault(s, []).append(actuator)

    def diagonal_spring(a: int, b: int, code: int) -> None:
        spring_index[(min(a, b), max(a, b))] = len(ends)
        ends.append((min(a, b), max(a, b)))
        kinds.append(DIAGONAL)
        base.append(diagonal)
        stiffness.append(tables[code].diagonal_stiffness)
        rigid_edge.append(False)

    for r, c in voxel_cells:
        code = int(grid[r, c])
        tl, tr, bl, br = (corner_point[(r + di, c + dj, r, c)] for di, dj in corner_offsets)
        corners.append((tl, tr, br, bl))
        codes.append(code)
        neighbours = [(r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)]
        surface.append(not all(0 <= i < h and 0 <= j < w and occupied[i, j] for i, j in neighbours))
        act = None
        if code in (H_ACT, V_ACT):
            act = len(actuators)
            actuators.append((r, c, code))
        along_x = act if code == H_ACT else None  # horizontal actuators drive the edges along x
        along_y = act if code == V_ACT else None
        edge(tl, tr, code, along_x)
        edge(bl, br, code, along_x)
        edge(tl, bl, code, along_y)
        edge(tr, br, code, along_y)
    for _, (tl, tr, br, bl), code in zip(voxel_cells, corners, codes):  # diagonals after all edges, as Evolution Gym
        diagonal_spring(tr, bl, code)
        diagonal_spring(tl, br, code)

    # a rigid voxel holds its edges within a few percent: an actuator beside it cannot drive that edge
    driven = np.array(sorted(s for s in drive if not rigid_edge[s]), dtype=np.intp)
    pairs = [(slot, a) for slot, s in enumerate(driven.tolist()) for a in drive[s]]
    pair_arr = np.array(pairs, dtype=np.intp).reshape(-1, 2)
    return Mesh(
        points=np.array(points, dtype=float),
        spring_ends=np.array(ends, dtype=np.intp).reshape(-1, 2),
        spring_kind=np.array(kinds, dtype=np.int8),
        spring_base=np.array(base, dtype=float),
        stiffness=np.array(stiffness, dtype=float),
        rigid_edge=np.array(rigid_edge, dtype=bool),
        voxel_corners=np.array(corners, dtype=np.intp).reshape(-1, 4),
        voxel_codes=np.array(codes, dtype=np.int8),
        voxel_cells=np.array(voxel_cells, dtype=np.intp).reshape(-1, 2),
        surface=np.array(surface, dtype=bool),
        actuator_cells=np.array(actuators, dtype=np.intp).reshape(-1, 3),
        driven=driven,
        drive_slot=pair_arr[:, 0],
        drive_act=pair_arr[:, 1],
        drive_count=np.array([len(drive[s]) for s in driven.tolist()], dtype=float),
        voxel_size=float(voxel_size),
    )
