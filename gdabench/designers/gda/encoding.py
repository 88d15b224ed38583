"""How bodies become model inputs and back (thesis section 4.2).

Voxel types are put on one value axis in the order empty < soft < horizontal < vertical <
rigid (the acyclic "option 2" of the thesis), so neighbouring values are similar materials.
Model codes 0..4 are scaled from [-0.5, 4.5] to [-1, 1]: each code owns an interval of width
0.4 (codes sit at -0.8, -0.4, 0, 0.4, 0.8), so uniform random values on [-1, 1] decode to
every type equally often (scaling [0, 4] onto [-1, 1] instead would halve the share of the two
end types).  Decoding inverts the scaling, clips to [0, 4] and rounds.  Standard Gaussian
values, the diffusion model's starting point, fall outside [-0.6, 0.6] more than half of the
time, so they decode to the end types (empty, rigid) about 27% each.
"""

from __future__ import annotations

import numpy as np

#: Evolution Gym code (0 empty, 1 rigid, 2 soft, 3 horizontal, 4 vertical) -> model code
EVOGYM_TO_MODEL = np.array([0, 4, 1, 2, 3], dtype=np.int8)
#: model code -> Evolution Gym code
MODEL_TO_EVOGYM = np.argsort(EVOGYM_TO_MODEL).astype(np.int8)
LOW, HIGH = -0.5, 4.5  # the code range mapped onto [-1, 1]
N_CODES = len(EVOGYM_TO_MODEL)


def encode(voxels: np.ndarray) -> np.ndarray:
    """Evolution Gym codes (any shape) -> float32 model values in [-1, 1]."""
    codes = EVOGYM_TO_MODEL[np.asarray(voxels, dtype=np.intp)].astype(np.float32)
    return (2.0 * (codes - LOW) / (HIGH - LOW) - 1.0).astype(np.float32)


def decode(values: np.ndarray) -> np.ndarray:
    """Model values (any real numbers) -> int8 Evolution Gym codes: unscale, clip, round, map back."""
    codes = (np.asarray(values, dtype=np.float64) + 1.0) * (HIGH - LOW) / 2.0 + LOW
    return MODEL_TO_EVOGYM[np.rint(np.clip(codes, 0, N_CODES - 1)).astype(np.intp)]


def published_reencoding(voxels: np.ndarray, times: int = 1) -> np.ndarray:
    """The body the author's code trains on after re-encoding a survivor in place ``times`` times.

    The published code maps each survivor's array to model codes *in place* before training,
    so a body that survives several generations is trained on as ``EVOGYM_TO_MODEL`` applied
    again and again (a 4-cycle 1 -> 4 -> 3 -> 2 -> 1 on the non-empty codes) while it keeps its
    first score.  Used only by the ``published_reencoding`` option; it returns a new array.
    """
    out = np.asarray(voxels, dtype=np.int8)
    for _ in range(times % 4):
        out = EVOGYM_TO_MODEL[out]
    return out.copy()
