"""``nk``: an NK-style landscape over voxels whose ruggedness is dialled with one number, K.

Voxel ``i`` (row-major order) contributes ``f_i(x_{i-K}, ..., x_i)`` in [0, 1): an independent
random number for every combination of its own code and the codes of the K voxels before it in
row-major order (positions before the first voxel count as empty).  The reward is
``100 * mean_i f_i``.

* ``k=0``: every voxel counts on its own, so the landscape is smooth: changing one voxel at a
  time climbs to the optimum (when the best body ignoring validity is valid, as for table
  seeds 0-5 and about three seeds in four; otherwise validity adds some ruggedness near the top).
* growing K: changing one voxel redraws K+1 contributions, so local optima multiply;
  ``k = voxels - 1`` is a fully random landscape.

The tables are fixed by ``table_seed`` alone (not by the run's seed), so every run of every
designer faces the same landscape.  Entry ``c`` of voxel ``i``'s table is output ``c`` of a
SplitMix64 stream keyed by word ``i`` of ``SeedSequence(table_seed)``: the tables exist without
being stored, so any K works.

The optimum is the best *valid* body.  It is computed exactly by dynamic programming along the
row-major line (:mod:`gdabench.envs.nk_optimum`) whenever that is affordable: on 5x5 bodies
for K <= 5 (0.5 s), and up to K = 8 (2 s) when the best body ignoring validity happens
to be valid.  Otherwise the optimum is reported as unknown (None); :attr:`NKLandscape.upper_bound`
then still gives, when affordable, the best reward of any body, valid or not.
"""

from __future__ import annotations

import functools

import numpy as np

from ..body import Body, invalid_reason
from . import nk_optimum
from .landscape import Landscape

A = nk_optimum.A
#: largest K whose window codes (5^(K+1) values) fit the 64-bit arithmetic used here
MAX_K = 26
#: the exact optimum is computed when its DP stores at most this many (profile, state) cells
#: (about 13 bytes each) and steps through at most this many profiles (about 50 us each)
MAX_DP_CELLS = 10_000_000
MAX_DP_PROFILES = 50_000

_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


def _splitmix_uniform(key: np.uint64 | np.ndarray, counters: np.ndarray) -> np.ndarray:
    """Outputs ``counters`` of the SplitMix64 stream(s) keyed by ``key``, as floats in [0, 1)."""
    z = key + (np.asarray(counters, dtype=np.uint64) + np.uint64(1)) * _GAMMA  # wraps mod 2^64
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) * 2.0**-53


class NKLandscape(Landscape):
    """Reward = 100 * mean over voxels of a random function of the voxel and the K before it.

    Parameters:
        k: how many preceding voxels each voxel's contribution depends on (0 smooth, more rugged)
        table_seed: seed of the contribution tables (the landscape itself; not the run's seed)
    """

    name = "nk"

    def __init__(self, *, shape: tuple[int, int] = (5, 5), k: int = 2, table_seed: int = 0):
        super().__init__(shape=shape)
        n = self.shape[0] * self.shape[1]
        self.n_voxels = n
        self.k = self._int_param("k", k, 0, min(n - 1, MAX_K))
        self.table_seed = self._int_param("table_seed", table_seed, 0)
        self._keys = np.random.SeedSequence(self.table_seed).generate_state(n, dtype=np.uint64)

    # -- reward ------------------------------------------------------------------------------------
    def contributions(self, voxels: np.ndarray) -> np.ndarray:
        """``f_i`` of every voxel, for a batch of grids (..., H, W) -> (..., H*W)."""
        grids = np.asarray(voxels, dtype=np.int64)
        flat = grids.reshape(grids.shape[:-2] + (self.n_voxels,))
        padded = np.concatenate([np.zeros(flat.shape[:-1] + (self.k,), dtype=np.int64), flat], axis=-1)
        codes = np.zeros_like(flat)
        for j in range(self.k + 1):
            codes = codes * A + padded[..., j : j + self.n_voxels]
        return _splitmix_uniform(self._keys, codes)  # keys broadcast over the voxel axis

    def score_batch(self, voxels: np.ndarray) -> np.ndarray:
        """Rewards of a batch of grids (..., H, W), valid or not (for analysis and tests)."""
        return 100.0 * self.contributions(voxels).mean(axis=-1)

    def score(self, voxels: np.ndarray) -> float:
        return float(self.score_batch(voxels))

    def table(self, i: int) -> np.ndarray:
        """Voxel ``i``'s contributions for all ``5^(K+1)`` window codes."""
        return _splitmix_uniform(self._keys[i], np.arange(A ** (self.k + 1)))

    # -- optimum -----------------------------------------------------------------------------------
    def _affordable(self, valid: bool) -> bool:
        profiles = nk_optimum.profile_count(self.shape, MAX_DP_PROFILES) if valid else self.n_voxels
        return profiles is not None and profiles * A**self.k <= MAX_DP_CELLS

    @functools.cached_property
    def _best_any(self) -> Body | None:
        if not self._affordable(valid=False):
            return None
        codes, _ = nk_optimum.best_body(self.shape, self.k, self.table, valid=False)  # type: ignore[misc]
        return Body(codes)

    @functools.cached_property
    def optimum_body(self) -> Body | None:
        """The best valid body, or None when it is too costly to compute exactly."""
        best = self._best_any
        if best is not None and invalid_reason(best.voxels) is None:
            return best  # the unconstrained optimum happens to be valid
        if not self._affordable(valid=True):
            return None
        found = nk_optimum.best_body(self.shape, self.k, self.table, valid=True)
        assert found is not None, "a single actuator voxel is always a valid body"
        return Body(found[0])

    @property
    def optimum(self) -> float | None:
        body = self.optimum_body
        return None if body is None else self.score(np.asarray(body.voxels))

    @property
    def upper_bound(self) -> float | None:
        """Best reward of any body, valid or not: >= the optimum (None when too costly)."""
        best = self._best_any
        return None if best is None else self.score(np.asarray(best.voxels))
