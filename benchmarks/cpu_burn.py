"""Stand-in for a physics environment: a fixed amount of pure-Python CPU work per body.

Used by ``bench_scale.py`` to measure parallel speed-up until a real physics environment
(``walker`` with the ``open-loop`` controller) is installed.  The work is a fixed number of
loop iterations, not a fixed time, so a slower (or shared) CPU makes every evaluation slower
and the speed-up measures real throughput.  The reward is the sum of the voxel codes.
"""

from __future__ import annotations

import numpy as np

from gdabench import Environment


class CpuBurn(Environment):
    def __init__(self, *, iterations: int = 1_000_000, **kw):
        super().__init__(**kw)
        self.iterations = int(iterations)

    def evaluate(self, body, *, seed, controller=None, workdir=None):
        x = seed
        for _ in range(self.iterations):
            x = (x * 1103515245 + 12345) & 0x7FFFFFFF
        return float(np.asarray(body.voxels, dtype=np.int64).sum())
