"""Checkerboard: the share of neighbouring voxel pairs whose codes differ, 0-100."""

from __future__ import annotations

import numpy as np

from gdabench import Body, Environment


class Checkerboard(Environment):
    def evaluate(self, body: Body, *, seed: int, controller=None, workdir=None) -> float:
        v = body.voxels
        differ = np.count_nonzero(v[1:, :] != v[:-1, :]) + np.count_nonzero(v[:, 1:] != v[:, :-1])
        pairs = v[1:, :].size + v[:, 1:].size
        return 100.0 * differ / pairs if pairs else 0.0

    @property
    def optimum(self) -> float:
        return 100.0  # e.g. alternating horizontal and vertical actuators: valid, every pair differs
