"""What Evolution Gym's tasks read of a simulation, for a batch of environments at once.

A :class:`Frame` is every environment's points at one time (arrays, no simulator), and these functions
compute from it what ``evogym.envs.EvoGymBase`` computes from its simulator: an object's centre of mass,
its velocity, its points relative to the centre, its orientation (``get_ort_obs``), and the terrain
below and above it (``get_floor_obs``, ``get_ceil_obs``).  They keep Evolution Gym's units and order of
operations where it can change a result: positions are read as its Python side scales them
(``x / 0.1 * 0.1``), sums run point by point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numba
import numpy as np

VOXEL = 0.1
_jit = numba.njit(cache=True, error_model="numpy", boundscheck=False)


@dataclass(frozen=True)
class Frame:
    """Every environment's points at one time.

    ``pos``/``vel``/``init`` are ``(N, P, 2)`` in metres (``init``: at the episode's start, which
    orientations are measured from).  Moving objects occupy the same columns in every environment
    (``objects[name] = (start, count)``), the robot ``robot_start`` onwards (``robot_count[i]`` points:
    bodies differ); objects that never move are given once, in ``static``; of an object only partly
    simulated (fixed voxels far from its moving ones), ``partial[name] = (start, which, rest)``: its points
    ``which`` occupy the columns from ``start``, all of them rest at ``rest``.
    """

    pos: np.ndarray
    vel: np.ndarray
    init: np.ndarray
    robot_start: int
    robot_count: np.ndarray
    objects: Mapping[str, tuple[int, int]]
    static: Mapping[str, np.ndarray]
    partial: Mapping[str, tuple[int, np.ndarray, np.ndarray]] = field(default_factory=dict)
    spans: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    @property
    def n(self) -> int:
        return self.pos.shape[0]

    def span(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(start, count) per environment of object ``name``'s points (the robot, or a wholly moving object);
        kept in ``spans``, which frames of one batch share."""
        if name not in self.spans:
            if name == "robot":
                self.spans[name] = np.full(self.n, self.robot_start, dtype=np.int64), self.robot_count
            elif name in self.objects:
                start, count = self.objects[name]
                self.spans[name] = np.full(self.n, start, dtype=np.int64), np.full(self.n, count, dtype=np.int64)
            else:
                raise ValueError(f"object {name!r} is not wholly simulated: read its points with Frame.points")
        return self.spans[name]

    def positions(self, name: str) -> np.ndarray:
        """Every point of object ``name`` (not the robot), ``(N, points, 2)``, in Evolution Gym's order."""
        if name in self.static:
            return np.broadcast_to(self.static[name], (self.n, *self.static[name].shape))
        if name in self.partial:
            start, which, rest = self.partial[name]
            out = np.repeat(rest[None], self.n, axis=0)
            out[:, which] = self.pos[:, start:start + len(which)]
            return out
        start, count = self.objects[name]
        return self.pos[:, start:start + count]

    def points(self, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
        """Positions of the named objects' points, ``(N, M, 2)``, and how many each environment has."""
        merged = np.ascontiguousarray(np.concatenate([self.positions(name) for name in names], axis=1))
        return merged, np.full(self.n, merged.shape[1], dtype=np.int64)


# -- kernels (one environment per row) -------------------------------------------------------
@_jit
def _com(pos, start, count, out):
    for i in range(pos.shape[0]):
        sx = 0.0
        sy = 0.0
        for m in range(start[i], start[i] + count[i]):
            sx += pos[i, m, 0] / 0.1 * 0.1
            sy += pos[i, m, 1] / 0.1 * 0.1
        out[i, 0] = sx / count[i]
        out[i, 1] = sy / count[i]


@_jit
def _vel_com(vel, start, count, out):
    for i in range(vel.shape[0]):
        vx = 0.0
        vy = 0.0
        for m in range(start[i], start[i] + count[i]):
            vx += vel[i, m, 0] / 0.1
            vy += vel[i, m, 1] / 0.1
        out[i, 0] = vx / count[i] * 0.1
        out[i, 1] = vy / count[i] * 0.1


@_jit
def _relative(pos, start, count, out):
    for i in range(pos.shape[0]):
        n = count[i]
        mx = 0.0
        my = 0.0
        for m in range(start[i], start[i] + n):
            mx += pos[i, m, 0] / 0.1
            my += pos[i, m, 1] / 0.1
        mx = mx / n
        my = my / n
        for k in range(n):
            out[i, k] = (pos[i, start[i] + k, 0] / 0.1 - mx) * 0.1
            out[i, n + k] = (pos[i, start[i] + k, 1] / 0.1 - my) * 0.1
        for k in range(2 * n, out.shape[1]):
            out[i, k] = 0.0


@_jit
def _eigen_sum(a, n):
    """``Array::sum()`` as Evolution Gym's Eigen computes it with SSE2: two 2-wide accumulators, then the rest."""
    if n < 2:
        return a[0]
    end2 = (n // 4) * 4
    end = (n // 2) * 2
    r0 = a[0]
    r1 = a[1]
    if end > 2:
        s0 = a[2]
        s1 = a[3]
        for k in range(4, end2, 4):
            r0 = r0 + a[k]
            r1 = r1 + a[k + 1]
            s0 = s0 + a[k + 2]
            s1 = s1 + a[k + 3]
        r0 = r0 + s0
        r1 = r1 + s1
        if end > end2:
            r0 = r0 + a[end2]
            r1 = r1 + a[end2 + 1]
    res = r0 + r1
    for k in range(end, n):
        res = res + a[k]
    return res


@_jit
def _eigen_row_sum(x, s, n, c):
    """``rowwise().sum()`` of a 2 x n matrix as Eigen computes it: the first column, then groups of four summed
    pairwise, then the rest (row ``c`` of points ``s`` .. ``s + n - 1``)."""
    p = x[s, c]
    size4 = (n - 1) & ~3
    k = 1
    while k < size4:
        p = p + ((x[s + k, c] + x[s + k + 1, c]) + (x[s + k + 2, c] + x[s + k + 3, c]))
        k += 4
    while k < n:
        p = p + x[s + k, c]
        k += 1
    return p


@_jit
def _orientation(pos, init, start, count, out):
    """``Environment::object_orientation_at_time``: the mean angle of the points about the centre since the
    start, weighted by their distance from it then, in [0, 2 pi), counter-clockwise; Eigen's sums in Eigen's
    order (at the start every angle is rounding noise, which this reproduces)."""
    width = 1
    for i in range(pos.shape[0]):
        width = max(width, count[i])
    angles = np.empty(width)
    mags = np.empty(width)
    crosses = np.empty(width)
    for i in range(pos.shape[0]):
        s = start[i]
        n = count[i]
        nx = _eigen_row_sum(pos[i], s, n, 0) / n
        ny = _eigen_row_sum(pos[i], s, n, 1) / n
        ox = _eigen_row_sum(init[i], s, n, 0) / n
        oy = _eigen_row_sum(init[i], s, n, 1) / n
        for k in range(n):
            ax = pos[i, s + k, 0] - nx
            ay = pos[i, s + k, 1] - ny
            bx = init[i, s + k, 0] - ox
            by = init[i, s + k, 1] - oy
            mag_a = math.sqrt(ax * ax + ay * ay)
            mag_b = math.sqrt(bx * bx + by * by)
            ax /= mag_a
            ay /= mag_a
            bx /= mag_b
            by /= mag_b
            c = ax * bx + ay * by
            if mag_a * mag_b < 0.0000001:
                c = 0.99999
            if c > 1.0:
                c = 0.99999
            if c < -1.0:
                c = -0.99999
            angles[k] = math.acos(c) * mag_b
            mags[k] = mag_b
            crosses[k] = ax * by - ay * bx
        angle = _eigen_sum(angles, n) / _eigen_sum(mags, n)
        if _eigen_sum(crosses, n) > 0:
            angle = 2 * 3.1415926 - angle
        out[i] = angle


@_jit
def _elevations(pos, start, count, terrain, n_terrain, sight_dist, sight_range, below, out):
    """``get_floor_obs`` (``below``) / ``get_ceil_obs``, in voxels then scaled: per column around the object's
    centre, the distance to the highest terrain point below it (lowest above it), capped at ``sight_range``."""
    for i in range(pos.shape[0]):
        cx = 0.0
        cy = 0.0
        for m in range(start[i], start[i] + count[i]):
            cx += pos[i, m, 0] / 0.1
            cy += pos[i, m, 1] / 0.1
        cx /= count[i]
        cy /= count[i]
        for k in range(2 * sight_dist + 1):
            d = k - sight_dist
            found = False
            best = 0.0
            for m in range(n_terrain[i]):
                x = terrain[i, m, 0] / 0.1
                y = terrain[i, m, 1] / 0.1
                if not (x > cx - (sight_dist + 0.5) and x < cx + (sight_dist + 0.5)):
                    continue
                if below and not y < cy:
                    continue
                if not below and not y > cy:
                    continue
                if x > cx + (d - 0.5) and x < cx + (d + 0.5):
                    if not found or (below and y > best) or (not below and y < best):
                        best = y
                        found = True
            if below:
                e = cy - (best if found else cy - sight_range)
            else:
                e = (best if found else cy + sight_range) - cy
            out[i, k] = min(max(e, 0.0), sight_range) * 0.1


# -- what tasks call -----------------------------------------------------------------------------
def com(frame: Frame, name: str) -> np.ndarray:
    """``np.mean(object_pos_at_time(t, name), 1)``: ``(N, 2)``."""
    out = np.empty((frame.n, 2))
    _com(frame.pos, *frame.span(name), out)
    return out


def vel_com(frame: Frame, name: str) -> np.ndarray:
    """``get_vel_com_obs(name)``: ``(N, 2)``."""
    out = np.empty((frame.n, 2))
    _vel_com(frame.vel, *frame.span(name), out)
    return out


def relative(frame: Frame, name: str, width: int) -> np.ndarray:
    """``get_relative_pos_obs(name)``: every x, then every y, relative to the centre; rows padded to ``width``."""
    out = np.empty((frame.n, width))
    _relative(frame.pos, *frame.span(name), out)
    return out


def orientation(frame: Frame, name: str) -> np.ndarray:
    """``get_ort_obs(name)``: ``(N,)`` radians."""
    out = np.empty(frame.n)
    _orientation(frame.pos, frame.init, *frame.span(name), out)
    return out


def floor(frame: Frame, name: str, terrain: tuple[str, ...], sight_dist: int, sight_range: float = 5) -> np.ndarray:
    """``get_floor_obs(name, terrain, sight_dist)``: ``(N, 2 sight_dist + 1)``."""
    return _look(frame, name, terrain, sight_dist, sight_range, True)


def ceiling(frame: Frame, name: str, terrain: tuple[str, ...], sight_dist: int, sight_range: float = 5) -> np.ndarray:
    """``get_ceil_obs(name, terrain, sight_dist)``: ``(N, 2 sight_dist + 1)``."""
    return _look(frame, name, terrain, sight_dist, sight_range, False)


def _look(frame: Frame, name: str, terrain: tuple[str, ...], sight_dist: int, sight_range: float,
          below: bool) -> np.ndarray:
    points, counts = frame.points(terrain)
    out = np.empty((frame.n, 2 * sight_dist + 1))
    _elevations(frame.pos, *frame.span(name), points, counts, sight_dist, float(sight_range), below, out)
    return out


# -- observation parts (appended by the locomotion and climbing tasks) -----------------------------
def robot_relative(frame: Frame) -> tuple[np.ndarray, np.ndarray]:
    """``get_relative_pos_obs("robot")`` as an observation part: environment ``i`` uses ``2 * points`` columns."""
    return relative(frame, "robot", 2 * int(frame.robot_count.max())), 2 * frame.robot_count
