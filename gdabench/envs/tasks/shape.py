"""Evolution Gym's shape-changing tasks (``evogym/envs/change_shape.py``): AreaMaximizer-v0, AreaMinimizer-v0,
WingspanMazimizer-v0, HeightMaximizer-v0.

The robot stands on flat ground and is rewarded for the change, over one step, of a measure of its shape:
the area of the convex hull of its points (times 10; AreaMinimizer-v0 rewards its loss), its width, or its
height.  The observation is the robot's points relative to its centre, nothing else (no velocity).  No goal
ends an episode; an unstable simulation ends it with -3.

The hull is Evolution Gym's own (``ShapeBase.jarvis_march``): a gift-wrapping march from the first point of
least x that keeps, of candidate points in line, the one it met first, and the shoelace area of the hull's
points in the march's order.  Which points in line it keeps (a robot's points start on a grid) decides
which products the area sums, so :func:`_march` takes the same tests in the same order, on the positions as
Evolution Gym's Python side reads them (``x / 0.1 * 0.1``).
"""

from __future__ import annotations

from typing import ClassVar

import numba
import numpy as np

from . import sense
from .base import Part, Task, penalised
from .sense import Frame

_jit = numba.njit(cache=True, error_model="numpy", boundscheck=False)


@_jit
def _march(s, n, hull):
    """``ShapeBase.jarvis_march`` of points ``s[:n]`` into ``hull``: how many points the hull has, or -1 where
    Evolution Gym's march would raise IndexError (points in line can send it back and forth, never closing)."""
    first = 0
    for k in range(1, n):
        if s[k, 0] < s[first, 0]:
            first = k
    hx = s[first, 0]
    hy = s[first, 1]
    m = 0
    while True:
        if m == n:
            return -1
        hull[m, 0] = hx
        hull[m, 1] = hy
        ex = s[0, 0]
        ey = s[0, 1]
        for j in range(1, n):
            # replace the endpoint if it is the current point, or if s[j] is not CCW(s[j], hull point, endpoint)
            ax = s[j, 0]
            ay = s[j, 1]
            if (ex == hx and ey == hy) or not ((ey - ay) * (hx - ax) >= (hy - ay) * (ex - ax)):
                ex = ax
                ey = ay
        m += 1
        hx = ex
        hy = ey
        if ex == hull[0, 0] and ey == hull[0, 1]:
            return m


@_jit
def _turns_left(hull, m, s, k):
    """Whether point ``s[k]`` turns strictly left of the last edge of ``hull[:m]``."""
    return ((hull[m - 1, 0] - hull[m - 2, 0]) * (s[k, 1] - hull[m - 2, 1])
            - (hull[m - 1, 1] - hull[m - 2, 1]) * (s[k, 0] - hull[m - 2, 0])) > 0


@_jit
def _chain(s, n, hull):
    """The convex hull of points ``s[:n]`` by Andrew's monotone chain, counter-clockwise into ``hull``: how many
    points it has (a robust march for the point sets on which Evolution Gym's fails)."""
    order = np.argsort(s[:n, 1], kind="mergesort")
    order = order[np.argsort(s[order, 0], kind="mergesort")]  # by x, then y
    m = 0
    for k in order:  # the lower hull, left to right
        while m >= 2 and not _turns_left(hull, m, s, k):
            m -= 1
        hull[m] = s[k]
        m += 1
    lower = m
    for k in order[::-1][1:]:  # the upper hull, right to left
        while m > lower and not _turns_left(hull, m, s, k):
            m -= 1
        hull[m] = s[k]
        m += 1
    return max(m - 1, 1)  # the last point is the first again


@_jit
def _hull_areas(pos, start, count, out):
    """``convex_poly_area(jarvis_march(points))`` of each environment's points ``start .. start + count``."""
    width = 1
    for i in range(pos.shape[0]):
        width = max(width, count[i])
    s = np.empty((width, 2))
    hull = np.empty((2 * width, 2))
    for i in range(pos.shape[0]):
        n = count[i]
        for k in range(n):
            s[k, 0] = pos[i, start[i] + k, 0] / 0.1 * 0.1
            s[k, 1] = pos[i, start[i] + k, 1] / 0.1 * 0.1
        m = _march(s, n, hull)
        if m < 0:
            m = _chain(s, n, hull)
        area = 0.0
        for k in range(m):
            k1 = k + 1 if k + 1 < m else 0
            area += hull[k, 0] * hull[k1, 1] - hull[k1, 0] * hull[k, 1]
        out[i] = 0.5 * area


@_jit
def _spans(pos, start, count, axis, out):
    """``max - min`` of each environment's points along ``axis`` (as Evolution Gym's Python side reads them)."""
    for i in range(pos.shape[0]):
        lo = np.inf
        hi = -np.inf
        for k in range(start[i], start[i] + count[i]):
            v = pos[i, k, axis] / 0.1 * 0.1
            lo = min(lo, v)
            hi = max(hi, v)
        out[i] = hi - lo


def hull_area(frame: Frame, name: str) -> np.ndarray:
    """The area of object ``name``'s convex hull as Evolution Gym computes it: ``(N,)``.

    Where Evolution Gym's march would not close and raise IndexError, this gives the true hull's area (the
    march fails on some grids of points taken in some orders; it did not on the start positions of 300 of
    ``sample_robot``'s 5 x 5 bodies, in the robot's own order)."""
    out = np.empty(frame.n)
    _hull_areas(frame.pos, *frame.span(name), out)
    return out


def span(frame: Frame, name: str, axis: int) -> np.ndarray:
    """Object ``name``'s extent along ``axis`` (0: width, 1: height), in metres: ``(N,)``."""
    out = np.empty(frame.n)
    _spans(frame.pos, *frame.span(name), axis, out)
    return out


class ShapeChange(Task):
    """Reward ``weight`` times the step's change of :meth:`measure`; done only when unstable."""

    world, robot_at = "ShapeChange", (7, 1)
    weight: ClassVar[float]

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        return 2 * robot_points

    def observe(self, frame: Frame) -> list[Part]:
        return [sense.robot_relative(frame)]

    def measure(self, frame: Frame) -> np.ndarray:
        raise NotImplementedError

    def reward(self, before: Frame, after: Frame, unstable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # (after - before) * -10 is (before - after) * 10 bit for bit: IEEE rounding is symmetric in sign
        reward = (self.measure(after) - self.measure(before)) * self.weight
        return penalised(reward, unstable), unstable.copy()


class Area(ShapeChange):
    def measure(self, frame: Frame) -> np.ndarray:
        return hull_area(frame, "robot")


class AreaMaximizerV0(Area):
    id, weight = "AreaMaximizer-v0", 10.0


class AreaMinimizerV0(Area):
    id, weight = "AreaMinimizer-v0", -10.0


class WingspanMazimizerV0(ShapeChange):
    id, weight = "WingspanMazimizer-v0", 1.0

    def measure(self, frame: Frame) -> np.ndarray:
        return span(frame, "robot", 0)


class HeightMaximizerV0(ShapeChange):
    id, weight = "HeightMaximizer-v0", 1.0

    def measure(self, frame: Frame) -> np.ndarray:
        return span(frame, "robot", 1)


DEFINED = (AreaMaximizerV0, AreaMinimizerV0, WingspanMazimizerV0, HeightMaximizerV0)
