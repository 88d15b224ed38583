"""A body (and fixed terrain) as Evolution Gym 2.0's simulator builds it: points, edges, boxels.

A faithful port of ``ObjectCreator::read_object_from_array`` and ``SimObject::compute_surface``:
the same point and edge numbering (the observation's point order depends on it), the same
quirks (a shared edge keeps the spring constant of the last soft or actuator cell that touched
it in row-major order; corners are shared only through edge neighbours; surface edges are
re-oriented so that their normal points out of the body).  Pure numpy, built once per body.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

EMPTY, RIGID, SOFT, H_ACT, V_ACT, FIXED = 0, 1, 2, 3, 4, 5

#: Evolution Gym's ObjectCreator constants (voxel 0.1, point mass 1)
CELL = 0.1
MASS = 1.0
RIGID_K = 300000000.0 / 3.5
ACT_K = 300000000.0 / 5
SOFT_K = 300000000.0 / 6
DIAG_K = {RIGID: RIGID_K / 2.0, FIXED: RIGID_K / 2.0, SOFT: SOFT_K / 4.0, H_ACT: ACT_K / 2.0, V_ACT: ACT_K / 2.0}
MAIN_K = {SOFT: SOFT_K, H_ACT: ACT_K, V_ACT: ACT_K}

TOP, BOT, LEFT, RIGHT = 0, 1, 2, 3


@dataclass(frozen=True)
class Object:
    """One connected object: its points, springs and boxels, numbered as Evolution Gym numbers them.

    ``boxel_points`` are (top-left, top-right, bottom-right, bottom-left) and ``boxel_edges``
    (top, right, bottom, left), the orders ``Boxel::init`` stores and the contact code walks.
    """

    pos: np.ndarray  # (P, 2) initial positions
    fixed: np.ndarray  # (P,) bool
    edge_ab: np.ndarray  # (E, 2) point indices after surface re-orientation
    edge_len: np.ndarray  # (E,) initial (rest) length
    edge_k: np.ndarray  # (E,) spring constant
    edge_surface: np.ndarray  # (E,) bool
    boxel_type: np.ndarray  # (N,) cell code
    boxel_cell: np.ndarray  # (N, 2) (x, y) in the object's grid, y = 0 the top row
    boxel_points: np.ndarray  # (N, 4)
    boxel_edges: np.ndarray  # (N, 4)
    boxel_surface: np.ndarray  # (N,) bool: misses a neighbour on some side
    actuators: np.ndarray  # (A,) boxel index of each actuator, in action order (row-major grid index)
    width: int


def _connections(grid: np.ndarray) -> set[tuple[int, int]]:
    """Evolution Gym's full connectivity: every pair of 4-adjacent non-empty cells."""
    h, w = grid.shape
    pairs = set()
    for y in range(h):
        for x in range(w):
            if grid[y, x] == EMPTY:
                continue
            if x + 1 < w and grid[y, x + 1] != EMPTY:
                pairs.add((y * w + x, y * w + x + 1))
            if y + 1 < h and grid[y + 1, x] != EMPTY:
                pairs.add((y * w + x, (y + 1) * w + x))
    return pairs


def build_object(grid: np.ndarray, at: tuple[int, int], point_offset: int = 0, edge_offset: int = 0) -> Object:
    """Build one object from a grid (rows top to bottom) placed with its bottom-left cell at ``at``.

    ``point_offset`` / ``edge_offset`` are the counts of points and edges created before this
    object: Evolution Gym treats index 0 as "not yet created", which only the first object meets.
    """
    grid = np.asarray(grid, dtype=np.int64)
    h, w = grid.shape
    start_x, start_y = at[0] * CELL, at[1] * CELL
    max_y = start_y + h * CELL
    n = h * w
    nb = np.zeros((n, 8), dtype=bool)  # TOP, BOT, LEFT, RIGHT, TL, TR, BL, BR
    for i, j in _connections(grid):
        if j - i == 1 and w != 1:
            nb[i, RIGHT] = nb[j, LEFT] = True
        if j - i == w:
            nb[i, BOT] = nb[j, TOP] = True
    pts: list[tuple[float, float]] = []
    edges: list[list] = []  # [a, b, length, k]
    tl = np.zeros(n, dtype=np.int64)
    tr = np.zeros(n, dtype=np.int64)
    bl = np.zeros(n, dtype=np.int64)
    br = np.zeros(n, dtype=np.int64)
    et = np.zeros(n, dtype=np.int64)
    eb = np.zeros(n, dtype=np.int64)
    el = np.zeros(n, dtype=np.int64)
    er = np.zeros(n, dtype=np.int64)

    def point(px: float, py: float) -> int:
        pts.append((px, py))
        return len(pts) + point_offset - 1

    def edge(a: int, b: int, length: float, k: float) -> int:
        edges.append([a, b, length, k])
        return len(edges) + edge_offset - 1

    def idx(x: int, y: int) -> int:
        return y * w + x

    for y in range(h):
        for x in range(w):
            c = idx(x, y)
            if grid[y, x] == EMPTY:
                continue
            top = idx(x, y - 1) if nb[c, TOP] else -1
            bot = idx(x, y + 1) if nb[c, BOT] else -1
            left = idx(x - 1, y) if nb[c, LEFT] else -1
            right = idx(x + 1, y) if nb[c, RIGHT] else -1
            t_l = t_r = b_l = b_r = -1
            if (top >= 0 and nb[top, LEFT]) or (left >= 0 and nb[left, TOP]):
                t_l = idx(x - 1, y - 1)
            if (top >= 0 and nb[top, RIGHT]) or (right >= 0 and nb[right, TOP]):
                t_r = idx(x + 1, y - 1)
            if (bot >= 0 and nb[bot, LEFT]) or (left >= 0 and nb[left, BOT]):
                b_l = idx(x - 1, y + 1)
            if (bot >= 0 and nb[bot, RIGHT]) or (right >= 0 and nb[right, BOT]):
                b_r = idx(x + 1, y + 1)
            nb[c, 4:] = [t_l >= 0, t_r >= 0, b_l >= 0, b_r >= 0]
            # corners: a later candidate overrides an earlier one, 0 means "not created" (as in C++)
            for src, attr in ((top, bl), (left, tr), (t_l, br)):
                if src >= 0 and attr[src] != 0:
                    tl[c] = attr[src]
            if tl[c] == 0:
                tl[c] = point(start_x + x * CELL, max_y - y * CELL)
            for src, attr in ((top, br), (right, tl), (t_r, bl)):
                if src >= 0 and attr[src] != 0:
                    tr[c] = attr[src]
            if tr[c] == 0:
                tr[c] = point(start_x + (x + 1) * CELL, max_y - y * CELL)
            for src, attr in ((bot, tl), (left, br), (b_l, tr)):
                if src >= 0 and attr[src] != 0:
                    bl[c] = attr[src]
            if bl[c] == 0:
                bl[c] = point(start_x + x * CELL, max_y - (y + 1) * CELL)
            for src, attr in ((bot, tr), (right, bl), (b_r, tl)):
                if src >= 0 and attr[src] != 0:
                    br[c] = attr[src]
            if br[c] == 0:
                br[c] = point(start_x + (x + 1) * CELL, max_y - (y + 1) * CELL)
            if top >= 0 and eb[top] != 0:
                et[c] = eb[top]
            if et[c] == 0:
                et[c] = edge(tl[c], tr[c], abs(CELL), RIGID_K)
            # (C++ reads top's edge here, a slip that never fires: the cell below is not built yet)
            if eb[c] == 0:
                eb[c] = edge(bl[c], br[c], abs(CELL), RIGID_K)
            if left >= 0 and er[left] != 0:
                el[c] = er[left]
            if el[c] == 0:
                el[c] = edge(tl[c], bl[c], abs(CELL), RIGID_K)
            if right >= 0 and el[right] != 0:
                er[c] = el[right]
            if er[c] == 0:
                er[c] = edge(tr[c], br[c], abs(CELL), RIGID_K)

    diag = math.sqrt(CELL * CELL + CELL * CELL)
    for y in range(h):
        for x in range(w):
            c = idx(x, y)
            code = int(grid[y, x])
            if code == EMPTY:
                continue
            if code in MAIN_K:
                for e in (et[c], eb[c], el[c], er[c]):
                    edges[e - edge_offset][3] = MAIN_K[code]
            edge(tr[c], bl[c], diag, DIAG_K[code])
            edge(tl[c], br[c], diag, DIAG_K[code])

    pos = np.array(pts, dtype=np.float64).reshape(-1, 2)
    fixed = np.zeros(len(pts), dtype=bool)
    cells = [idx(x, y) for y in range(h) for x in range(w) if grid[y, x] != EMPTY]
    for c in cells:
        if grid[c // w, c % w] == FIXED:
            fixed[[tl[c] - point_offset, tr[c] - point_offset, bl[c] - point_offset, br[c] - point_offset]] = True
    edge_arr = np.array(edges, dtype=np.float64).reshape(-1, 4)
    ab = edge_arr[:, :2].astype(np.int64) - point_offset
    surface = np.zeros(len(edges), dtype=bool)
    boxel_surface = np.zeros(len(cells), dtype=bool)
    sides = ((TOP, et, (0.0, 1.0)), (BOT, eb, (0.0, -1.0)), (LEFT, el, (-1.0, 0.0)), (RIGHT, er, (1.0, 0.0)))
    for i, c in enumerate(cells):
        for side, arr, ref in sides:
            if not nb[c, side]:
                e = arr[c] - edge_offset
                surface[e] = True
                boxel_surface[i] = True
                d = pos[ab[e, 1]] - pos[ab[e, 0]]
                if ref[0] * -d[1] + ref[1] * d[0] < 0:  # normal (-dy, dx) must point outwards
                    ab[e] = ab[e, ::-1].copy()
    boxel_type = np.array([grid[c // w, c % w] for c in cells], dtype=np.int64)
    return Object(
        pos=pos,
        fixed=fixed,
        edge_ab=ab,
        edge_len=edge_arr[:, 2].copy(),
        edge_k=edge_arr[:, 3].copy(),
        edge_surface=surface,
        boxel_type=boxel_type,
        boxel_cell=np.array([(c % w, c // w) for c in cells], dtype=np.int64).reshape(-1, 2),
        boxel_points=np.stack([tl[cells], tr[cells], br[cells], bl[cells]], axis=1).reshape(-1, 4) - point_offset,
        boxel_edges=np.stack([et[cells], er[cells], eb[cells], el[cells]], axis=1).reshape(-1, 4) - edge_offset,
        boxel_surface=boxel_surface,
        actuators=np.flatnonzero((boxel_type == H_ACT) | (boxel_type == V_ACT)),
        width=w,
    )
