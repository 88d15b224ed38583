"""The mass-spring mesh of a voxel body: point masses, springs and how actuators drive them.

Pure topology and geometry (numpy only); :mod:`.sim` turns a :class:`Mesh` into pymunk objects.

As in Evolution Gym, every voxel is a square cell whose four corners are point masses.  Voxels
that share an edge share that edge's two corners; voxels that touch only at a corner (and
have no common edge neighbour there) get separate, coincident corner points, because Evolution
Gym connects voxels only through edges.  Each voxel contributes six springs: its four edges
and its two diagonals; a rigid voxel instead makes all six fixed distances (and so does the
edge it shares with a soft or actuator voxel).  An edge shared by two voxels is one spring whose stiffness is the sum
of the two voxels' contributions and whose rest length is their stiffness-weighted mean, which
is exactly two parallel springs merged into one.

Actuators change rest lengths: a horizontal actuator (code 3) with ratio ``r`` wants its top
and bottom edges ``r`` times their voxel length and its diagonals ``hypot(r, 1)`` voxel lengths
(the diagonals of an ``r x 1`` rectangle); a vertical actuator (code 4) does the same along y.
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
    """Stiffness and damping of one voxel type's springs (per voxel, before merging)."""

    edge_stiffness: float
    diagonal_stiffness: float
    edge_damping: float
    diagonal_damping: float


#: rigid voxels' edges and diagonals are fixed distances, not springs: they add no stiffness
RIGID_TABLE = SpringTable(0.0, 0.0, 0.0, 0.0)


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
    stiffness: np.ndarray  # (n_springs,) summed over the voxels sharing the spring
    damping: np.ndarray  # (n_springs,)
    spring_rigid: np.ndarray  # (n_springs,) bool: a rigid voxel owns it, so it is a fixed distance
    voxel_corners: np.ndarray  # (n_voxels, 4) point indices TL, TR, BR, BL: a loop around the voxel
    voxel_codes: np.ndarray  # (n_voxels,) codes 1-4
    actuator_cells: np.ndarray  # (n_actuators, 3) (row, col, code), in action order
    # actuator drive: contribution j adds drive_k[j] * length(ratio[drive_act[j]]) to spring drive_spring[j]
    drive_spring: np.ndarray
    drive_act: np.ndarray
    drive_kind: np.ndarray
    drive_k: np.ndarray
    fixed_weighted: np.ndarray  # (n_springs,) sum of k * L over the contributions no actuator drives
    driven: np.ndarray  # indices of the springs (not rigid) whose rest length depends on an actuator
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
        length = np.where(self.drive_kind == EDGE, r, np.sqrt(r * r + 1.0)) * self.voxel_size
        weighted = self.fixed_weighted + np.bincount(self.drive_spring, weights=self.drive_k * length, minlength=len(self.stiffness))
        return weighted[self.driven] / self.stiffness[self.driven]


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

    ``tables`` gives the spring constants of soft and actuator voxels; rigid voxels make every
    spring they touch a fixed distance (see :class:`Mesh`).
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

    # -- springs: per-voxel contributions, merged by point pair -------------------------------
    spring_index: dict[tuple[int, int], int] = {}
    ends: list[tuple[int, int]] = []
    kinds: list[int] = []
    base: list[float] = []
    stiffness: list[float] = []
    damping: list[float] = []
    fixed_weighted: list[float] = []
    rigid: list[bool] = []
    drive: list[tuple[int, int, int, float]] = []  # (spring, actuator, kind, k)
    corners: list[tuple[int, int, int, int]] = []
    codes: list[int] = []
    actuators: list[tuple[int, int, int]] = []
    diagonal = math.sqrt(2.0) * voxel_size

    def contribute(a: int, b: int, kind: int, length: float, k: float, c: float, actuator: int | None, is_rigid: bool) -> None:
        key = (min(a, b), max(a, b))
        s = spring_index.get(key)
        if s is None:
            s = spring_index[key] = len(ends)
            ends.append(key)
            kinds.append(kind)
            base.append(length)
            stiffness.append(0.0)
            damping.append(0.0)
            fixed_weighted.append(0.0)
            rigid.append(False)
        rigid[s] = rigid[s] or is_rigid
        stiffness[s] += k
        damping[s] += c
        if actuator is None:
            fixed_weighted[s] += k * length
        else:
            drive.append((s, actuator, kind, k))

    for r, c in voxel_cells:
        code = int(grid[r, c])
        tl, tr, bl, br = (corner_point[(r + di, c + dj, r, c)] for di, dj in corner_offsets)
        corners.append((tl, tr, br, bl))
        codes.append(code)
        t = RIGID_TABLE if code == RIGID else tables[code]
        act = None
        if code in (H_ACT, V_ACT):
            act = len(actuators)
            actuators.append((r, c, code))
        along_x = act if code == H_ACT else None  # horizontal actuators drive the edges along x
        along_y = act if code == V_ACT else None
        contribute(tl, tr, EDGE, voxel_size, t.edge_stiffness, t.edge_damping, along_x, code == RIGID)
        contribute(bl, br, EDGE, voxel_size, t.edge_stiffness, t.edge_damping, along_x, code == RIGID)
        contribute(tl, bl, EDGE, voxel_size, t.edge_stiffness, t.edge_damping, along_y, code == RIGID)
        contribute(tr, br, EDGE, voxel_size, t.edge_stiffness, t.edge_damping, along_y, code == RIGID)
        contribute(tl, br, DIAGONAL, diagonal, t.diagonal_stiffness, t.diagonal_damping, act, code == RIGID)
        contribute(tr, bl, DIAGONAL, diagonal, t.diagonal_stiffness, t.diagonal_damping, act, code == RIGID)

    drive_arr = np.array(drive, dtype=float).reshape(-1, 4)
    driven = np.unique(drive_arr[:, 0].astype(np.intp))
    return Mesh(
        points=np.array(points, dtype=float),
        spring_ends=np.array(ends, dtype=np.intp).reshape(-1, 2),
        spring_kind=np.array(kinds, dtype=np.int8),
        spring_base=np.array(base, dtype=float),
        stiffness=np.array(stiffness, dtype=float),
        damping=np.array(damping, dtype=float),
        spring_rigid=np.array(rigid, dtype=bool),
        voxel_corners=np.array(corners, dtype=np.intp).reshape(-1, 4),
        voxel_codes=np.array(codes, dtype=np.int8),
        actuator_cells=np.array(actuators, dtype=np.intp).reshape(-1, 3),
        drive_spring=drive_arr[:, 0].astype(np.intp),
        drive_act=drive_arr[:, 1].astype(np.intp),
        drive_kind=drive_arr[:, 2].astype(np.int8),
        drive_k=drive_arr[:, 3],
        fixed_weighted=np.array(fixed_weighted, dtype=float),
        driven=driven[~np.array(rigid, dtype=bool)[driven]],
        voxel_size=float(voxel_size),
    )

