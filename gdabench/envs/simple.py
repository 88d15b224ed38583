"""The thesis's ``simple`` environment: reward = sum of the voxel codes."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..body import V_ACT, Body
from ..environment import Controller, Environment


class SumOfVoxels(Environment):
    """Reward is the sum of the codes, so a block of vertical actuators (code 4) is optimal.

    Only one body of each shape reaches the optimum (100 for 5x5), and ever fewer bodies reach
    ever higher rewards, which is what made it a hard target for the GA in the thesis.
    """

    def evaluate(
        self, body: Body, *, seed: int, controller: Controller | None = None, workdir: Path | None = None
    ) -> float:
        return float(np.asarray(body.voxels, dtype=np.int64).sum())

    @property
    def optimum(self) -> float:
        return float(V_ACT * self.shape[0] * self.shape[1])
