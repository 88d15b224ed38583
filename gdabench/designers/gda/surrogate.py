"""A cheap reward model for choosing which diffusion samples to evaluate (thesis section 6.3).

The thesis proposes filtering the samples instead of evaluating the first ones that happen
to be new.  With ``pool=N`` the designer draws N new bodies from the trained model and
proposes those a ridge regression, fitted to every body evaluated so far, rates best: the
diffusion model decides *where* to look (bodies like the survivors), the regression decides
*which* of them to pay for.  Features are one-hot voxel types ("this voxel should be that
type") plus the count of each type in the body ("more of that type helps anywhere"); the ridge
penalty makes the few count features carry what they can, so a handful of evaluated bodies
already gives a useful model.  On ``simple``, whose reward is a sum over voxels, the model is
almost exact, so expect a smaller gain on physics tasks.
"""

from __future__ import annotations

import numpy as np

from .encoding import N_CODES


def features(voxels: np.ndarray) -> np.ndarray:
    """(n, H, W) codes -> (n, H * W * 5) voxel-type indicators followed by the 5 type counts."""
    flat = np.asarray(voxels, dtype=np.intp).reshape(len(voxels), -1)
    one_hot = np.zeros((flat.shape[0], flat.shape[1] * N_CODES))
    one_hot[np.arange(flat.shape[0])[:, None], np.arange(flat.shape[1]) * N_CODES + flat] = 1.0
    counts = one_hot.reshape(flat.shape[0], flat.shape[1], N_CODES).sum(axis=1)
    return np.concatenate([one_hot, counts], axis=1)


def ridge_predictor(voxels: np.ndarray, rewards: np.ndarray, penalty: float = 1.0):
    """Fit ``reward ~ features(body) @ w + c`` with an L2 penalty on ``w``; return a function scoring new bodies.

    Rewards that are not finite (failed evaluations) are left out.
    """
    rewards = np.asarray(rewards, dtype=float)
    keep = np.isfinite(rewards)
    x, y = features(np.asarray(voxels)[keep]), rewards[keep]
    offset = float(y.mean()) if len(y) else 0.0
    gram = x.T @ x + penalty * np.eye(x.shape[1])
    weights = np.linalg.solve(gram, x.T @ (y - offset))
    return lambda bodies: features(bodies) @ weights + offset
