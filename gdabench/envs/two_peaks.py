"""``two-peaks``: the thesis author's second test reward, a narrow global peak and a wide decoy.

With the 5x5 body flattened row-major into a 25-vector ``x`` of Evolution Gym codes::

    reward = max(100 - 10 * ||x - p1||, 50 - 3 * ||x - p2||)

The peak at ``p1`` (100) falls off fast, the one at ``p2`` (50) slowly, so a designer that
follows the average slope is drawn to ``p2``.  Both peaks are valid bodies.  The formula is
defined for 5x5 bodies only.
"""

from __future__ import annotations

import numpy as np

from ..body import Body
from ..errors import ConfigError
from .landscape import Landscape

P1 = Body.from_text("04044/11433/20002/20003/44443")
P2 = Body.from_text("03200/13400/34301/32201/00411")
SHAPE = (5, 5)


class TwoPeaks(Landscape):
    """Global optimum 100 at ``P1``; a deceptive local optimum 50 at ``P2``."""

    name = "two-peaks"

    def __init__(self, *, shape: tuple[int, int] = SHAPE):
        super().__init__(shape=shape)
        if self.shape != SHAPE:
            raise ConfigError(
                f"two-peaks is defined for 5x5 bodies only (its peaks are 5x5 bodies), got --shape {self._shape_text()}"
            )
        self._p1 = np.asarray(P1.voxels, dtype=float).ravel()
        self._p2 = np.asarray(P2.voxels, dtype=float).ravel()

    def score(self, voxels: np.ndarray) -> float:
        x = np.asarray(voxels, dtype=float).ravel()
        return float(max(100.0 - 10.0 * np.linalg.norm(x - self._p1), 50.0 - 3.0 * np.linalg.norm(x - self._p2)))

    @property
    def optimum(self) -> float:
        return 100.0
