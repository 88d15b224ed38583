"""Exact best body for rewards that add up along the row-major line (the ``nk`` landscape).

The reward is a sum over voxels ``i`` of ``gain_i(x_{i-K}, ..., x_i)`` (codes of voxels before
the first count as empty).  Dynamic programming over the voxels in row-major order, keeping the
last K codes as state, finds the best body in ``voxels * 5^(K+1)`` steps.

That body may be invalid (disconnected, or without an actuator), and the harness never scores
invalid bodies, so the DP can also carry the validity rule: a *connectivity profile* (the
frontier of the last W placed voxels, one per column, labelled by which connected component
each belongs to, plus "has an actuator" and "the body is closed") is added to the state, as in
the classic broken-profile DP for connected shapes.  A component that leaves the frontier can
never be joined again, so it must be the only one, and nothing may be placed after it.  The
cost grows with the number of reachable profiles, which :func:`profile_count` gives up front
so callers can decide whether the exact answer is affordable.
"""

from __future__ import annotations

import functools
from typing import Callable, Hashable, cast

import numpy as np

from ..body import EMPTY, H_ACT, N_VOXEL_TYPES, V_ACT

A = N_VOXEL_TYPES
Profile = Hashable

#: (frontier labels per column, has an actuator, closed)
ValidProfile = tuple[tuple[int, ...], bool, bool]
VALID_START: ValidProfile = ((), False, False)  # the frontier tuple is sized on first use


def _relabel(labels: list[int]) -> tuple[int, ...]:
    """Number components by first appearance, so equal frontiers get equal keys."""
    names: dict[int, int] = {}
    return tuple(names.setdefault(x, len(names) + 1) if x else 0 for x in labels)


@functools.lru_cache(maxsize=None)
def valid_step(profile: ValidProfile, width: int, col: int, code: int) -> ValidProfile | None:
    """Profile after placing ``code`` in column ``col`` of the next row-major cell, or None if
    no valid body can continue from there."""
    labels, actuated, closed = profile
    frontier = list(labels or (0,) * width)
    up = frontier[col]
    if code == EMPTY:
        frontier[col] = 0
        if up and up not in frontier:  # the component above is sealed off for good
            if any(frontier):
                return None  # ... while another one exists: disconnected
            closed = True
        return _relabel(frontier), actuated, closed
    if closed:
        return None  # a voxel after the body was sealed would be a second component
    left = frontier[col - 1] if col > 0 else 0
    label = up or left or max(frontier) + 1
    if up and left and up != left:
        frontier = [up if x == left else x for x in frontier]
    frontier[col] = label
    return _relabel(frontier), actuated or code in (H_ACT, V_ACT), False


def valid_end(profile: ValidProfile) -> bool:
    """A complete body is valid: it has an actuator and exactly one component."""
    labels, actuated, closed = profile
    return actuated and (closed or max(labels, default=0) == 1)


def free_step(profile: Profile, width: int, col: int, code: int) -> Profile:
    return profile


def profile_count(shape: tuple[int, int], limit: int) -> int | None:
    """Reachable validity profiles summed over the voxels (the DP's cost), or None above ``limit``."""
    h, w = shape
    layer, total = {VALID_START}, 0
    for i in range(h * w):
        layer = {q for p in layer for v in range(A) if (q := valid_step(p, w, i % w, v)) is not None}
        total += len(layer)
        if total > limit:
            return None
    return total


def best_body(
    shape: tuple[int, int],
    k: int,
    gain: Callable[[int], np.ndarray],
    *,
    valid: bool,
) -> tuple[np.ndarray, float] | None:
    """The body maximising ``sum_i gain(i)[window code]`` and that sum, or None if none exists.

    ``gain(i)`` returns the ``5^(K+1)`` contributions of voxel ``i`` indexed by the base-5 code
    of ``(x_{i-K}, ..., x_i)``, oldest digit most significant.  With ``valid`` only valid bodies
    count.
    """
    h, w = shape
    states = A**k  # codes of the last K voxels
    step, start = (valid_step, VALID_START) if valid else (free_step, ())
    first = np.full(states, -np.inf)
    first[0] = 0.0  # the virtual voxels before the first are empty
    layer: dict[Profile, np.ndarray] = {start: first}
    history: list[tuple[list[Profile], dict[Profile, tuple[np.ndarray, np.ndarray, np.ndarray]]]] = []
    keep = np.arange(states // A) if k else np.zeros(1, dtype=int)
    for i in range(h * w):
        col = i % w
        g = gain(i).reshape(states, A)
        profiles = list(layer)
        new: dict[Profile, np.ndarray] = {}
        back: dict[Profile, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        for p_index, p in enumerate(profiles):
            score = layer[p]
            for v in range(A):
                q = step(p, w, col, v)
                if q is None:
                    continue
                cand = (score + g[:, v]).reshape(-1, keep.size)  # rows: the oldest code, dropped now
                oldest = cand.argmax(axis=0)
                value = cand[oldest, keep]
                target = keep * A + v if k else keep
                if q not in new:
                    new[q] = np.full(states, -np.inf)
                    back[q] = (np.zeros(states, np.int32), np.zeros(states, np.int64), np.zeros(states, np.int8))
                better = value > new[q][target]
                if better.any():
                    idx = target[better]
                    new[q][idx] = value[better]
                    back[q][0][idx] = p_index
                    back[q][1][idx] = (oldest * keep.size + keep)[better]
                    back[q][2][idx] = v
        history.append((profiles, back))
        layer = new
    ends = [(float(a.max()), p) for p, a in layer.items() if not valid or valid_end(cast(ValidProfile, p))]
    ends = [(s, p) for s, p in ends if np.isfinite(s)]
    if not ends:
        return None
    total, p = max(ends, key=lambda e: e[0])
    s = int(layer[p].argmax())
    codes = np.zeros(h * w, dtype=np.int8)
    for i in range(h * w - 1, -1, -1):
        profiles, back = history[i]
        p_index, prev_state, v = back[p][0][s], back[p][1][s], back[p][2][s]
        codes[i] = v
        p, s = profiles[p_index], int(prev_state)
    return codes.reshape(h, w), total
