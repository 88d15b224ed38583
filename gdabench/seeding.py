"""Every random choice of a run flows from its seed through these derivations.

* the designer's stream is ``SeedSequence(seed, spawn_key=(0,))``: designers that start from
  Evolution Gym's random sampler (ga, gda, random) therefore share their first generation
  under the same seed, which pairs the comparison (common random numbers);
* an evaluation's seed depends only on the run's seed and the body's hash, so a body scores
  the same whichever designer proposed it, in whatever order or process it is evaluated;
* a re-evaluation's seed (the ``j``-th further training of a trial's final best body) depends on
  the run's seed, the body's hash and ``j``, from a stream of its own: never the evaluation's seed.
"""

from __future__ import annotations

import numpy as np

DESIGNER_STREAM = 0
EVALUATION_STREAM = 1
REEVALUATION_STREAM = 2


def designer_seed(seed: int) -> np.random.SeedSequence:
    return np.random.SeedSequence(seed, spawn_key=(DESIGNER_STREAM,))


def evaluation_seed(seed: int, body_hash: str) -> int:
    """A 32-bit seed for evaluating the body with this hash in a run with this seed."""
    ss = np.random.SeedSequence(seed, spawn_key=(EVALUATION_STREAM, int(body_hash, 16)))
    return int(ss.generate_state(1, dtype=np.uint32)[0])


def reevaluation_seed(seed: int, body_hash: str, replicate: int) -> int:
    """A 32-bit seed for the ``replicate``-th re-evaluation (1, 2, ...) of the body with this hash."""
    ss = np.random.SeedSequence(seed, spawn_key=(REEVALUATION_STREAM, int(body_hash, 16), replicate))
    return int(ss.generate_state(1, dtype=np.uint32)[0])
