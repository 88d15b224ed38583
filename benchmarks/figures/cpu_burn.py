"""Stand-in for a physics environment: a fixed amount of pure-Python CPU work per body.

Used by ``bench_scale.py`` to measure parallel speed-up until a real physics environment
(``walker`` with the ``open-loop`` controller) is installed.  The work is a fixed number of
loop iterations, not a fixed time, so a slower (or shared) CPU makes every evaluation slower
and the speed-up measures real throughput.  The reward is the sum of the voxel codes; the
``cpu_seconds`` column says how much CPU the evaluation got, which on a shared machine is
less than its wall time.
"""

from __future__ import annotations

import time

import numpy as np

from gdabench import Environment, Evaluation


class CpuBurn(Environment):
    def __init__(self, *, iterations: int = 1_000_000, **kw):
        super().__init__(**kw)
        self.iterations = int(iterations)

    def evaluate(self, body, *, seed, controller=None, workdir=None):
        start, x = time.process_time(), seed
        for _ in range(self.iterations):
            x = (x * 1103515245 + 12345) & 0x7FFFFFFF
        return Evaluation(
            float(np.asarray(body.voxels, dtype=np.int64).sum()), {"cpu_seconds": time.process_time() - start}
        )
