"""Designers from the ecosystem: thin adapters from gdabench's ask/tell to other libraries' ask/tell.

Each adapter imports its library only when the designer is built (so ``gdabench list`` and
``gdabench info`` work without it) and refuses with the ``pip install 'gdabench[extra]'`` to run
when the library is missing.  The helpers here are what the adapters share: the import, the
body descriptors, and the penalty told for bodies that could not be scored.
"""

from __future__ import annotations

import importlib
import math
from types import ModuleType
from typing import Sequence

import numpy as np

from ...body import EMPTY, H_ACT, V_ACT, Body
from ...errors import ConfigError


def require(module: str, extra: str, designer: str) -> ModuleType:
    """Import ``module`` for ``designer``, or a ConfigError naming the extra that installs it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise ConfigError(
            f"designer {designer!r} needs {module.split('.')[0]} ({exc}): pip install 'gdabench[{extra}]'"
        ) from None


def descriptors(body: Body) -> tuple[float, float]:
    """(share of the grid that is filled, share of the filled voxels that are actuators), each in [0, 1]."""
    voxels = body.voxels
    filled = int(np.count_nonzero(voxels != EMPTY))
    muscle = int(np.count_nonzero((voxels == H_ACT) | (voxels == V_ACT)))
    return filled / voxels.size, muscle / max(filled, 1)


class RewardScale:
    """What the adapters tell an optimizer for a body without a score.

    A reward of ``nan`` (the evaluation failed) and an invalid proposal get the *penalty*: the
    worst reward seen so far minus the spread of the rewards seen (minus 1 while that spread is
    0), so it ranks below every real body without being infinite (which CMA-style optimizers
    cannot digest).  Before any reward is known the penalty is -1.
    """

    def __init__(self) -> None:
        self.low = math.inf
        self.high = -math.inf

    def observe(self, rewards: Sequence[float]) -> None:
        for r in rewards:
            if not math.isnan(r):
                self.low, self.high = min(self.low, float(r)), max(self.high, float(r))

    @property
    def penalty(self) -> float:
        if self.low == math.inf:
            return -1.0
        spread = self.high - self.low
        return self.low - (spread if spread > 0 else 1.0)

    def score(self, reward: float) -> float:
        """The reward itself, or the penalty for ``nan``."""
        return self.penalty if math.isnan(reward) else float(reward)
