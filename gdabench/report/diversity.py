"""Diversity of what a designer proposes, generation by generation (thesis section 4.5).

The thesis sorted 100 samples of a trained model by eye into replicas and noisy reconstructions,
samples with the survivor's shape but other materials, and new shapes, and suggested measuring
the distance of each sample to the nearest survivor to do this automatically.  This module does
exactly that for every generation of every run, from the evaluations table alone:

* ``unique``: distinct bodies among the generation's proposals (all proposals count, also
  duplicates and invalid bodies: they are what the designer asked for);
* ``mean_pairwise_hamming``: mean number of differing voxels over all pairs of proposals;
* ``nearest_survivor_*``: Hamming distance of each proposal to the nearest *survivor of the
  previous generation*.  Designers keep different parents (the GDA and the thesis's GA keep the
  best 5, Evolution Gym's GA a shrinking share, CPPN-NEAT whole species), so survivors are
  defined the same way for all of them: the ``survivors`` best bodies evaluated in the run before
  this generation (ties: the earlier body).  Generation 0 has none.
* each proposal falls in one category by that distance: ``copy`` (distance 0), ``near-copy``
  (at most ``near_copy`` voxels differ: what a mutation or a noisy reconstruction does),
  ``new materials`` (farther, but its occupied voxels are exactly a survivor's: same shape,
  other voxel types) and ``novel shape`` (everything else).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd

from ..body import CATEGORIES, NEAR_COPY, categorize, hamming
from ..errors import RunDirectoryError
from ..stats.core import RUN_KEYS
from ..statuses import OK

#: survivors per generation in the thesis's GDA and simple-environment GA
SURVIVORS = 5
COLUMNS = [
    "proposals",
    "unique",
    "unique_share",
    "mean_pairwise_hamming",
    "nearest_survivor_mean",
    "nearest_survivor_median",
    *(f"share_{c.replace(' ', '_').replace('-', '_')}" for c in CATEGORIES),
]


def body_matrix(texts: Sequence[str]) -> np.ndarray:
    """Bodies in text form as an (n, H*W) int8 matrix of voxel codes."""
    flat = [t.replace("/", "") for t in texts]
    if not flat:
        return np.zeros((0, 0), dtype=np.int8)
    width = len(flat[0])
    if any(len(f) != width for f in flat):
        raise RunDirectoryError("bodies of different sizes in one run: cannot compare them voxel by voxel")
    codes = np.frombuffer("".join(flat).encode("ascii", errors="replace"), dtype=np.uint8).reshape(len(flat), width)
    if codes.size and (codes.min() < ord("0") or codes.max() > ord("4")):
        raise RunDirectoryError("malformed body text in the evaluations table (voxel codes must be 0-4)")
    return (codes - ord("0")).astype(np.int8)


def run_diversity(run: pd.DataFrame, survivors: int = SURVIVORS, near_copy: int = NEAR_COPY) -> pd.DataFrame:
    """One row per generation of one run (one designer, one seed)."""
    run = run.sort_values(["generation", "index"], kind="stable")
    bodies = body_matrix(run["body"].tolist())
    generation = run["generation"].to_numpy()
    reward = np.where(run["status"].to_numpy() == OK, run["reward"].to_numpy(dtype=float), np.nan)
    hashes = run["body_hash"].to_numpy()
    rows = []
    for g in np.unique(generation):
        here = generation == g
        props = bodies[here]
        n = len(props)
        pairs = hamming(props, props)[np.triu_indices(n, k=1)] if n > 1 else np.array([])
        row = {
            "generation": int(g),
            "proposals": n,
            "unique": len(set(hashes[here])),
            "mean_pairwise_hamming": float(pairs.mean()) if len(pairs) else np.nan,
        }
        row["unique_share"] = row["unique"] / n
        before = np.flatnonzero((generation < g) & ~np.isnan(reward))
        if len(before):
            best = before[np.argsort(-reward[before], kind="stable")[:survivors]]
            distance, category = categorize(props, bodies[best], near_copy)
            row["nearest_survivor_mean"] = float(distance.mean())
            row["nearest_survivor_median"] = float(np.median(distance))
            shares = np.bincount(category, minlength=len(CATEGORIES)) / n
        else:
            row["nearest_survivor_mean"] = row["nearest_survivor_median"] = np.nan
            shares = np.full(len(CATEGORIES), np.nan)
        row.update(zip(COLUMNS[-len(CATEGORIES) :], shares.tolist()))
        rows.append(row)
    return pd.DataFrame(rows, columns=["generation", *COLUMNS])


def diversity(evaluations: pd.DataFrame, survivors: int = SURVIVORS, near_copy: int = NEAR_COPY) -> pd.DataFrame:
    """Per (designer, seed, generation): unique bodies, pairwise and nearest-survivor distances, category shares."""
    parts = []
    for (designer, seed), run in evaluations.groupby(RUN_KEYS, sort=False):
        part = run_diversity(run, survivors, near_copy)
        part.insert(0, "seed", seed)
        part.insert(0, "designer", designer)
        parts.append(part)
    if not parts:
        return pd.DataFrame(columns=[*RUN_KEYS, "generation", *COLUMNS])
    return pd.concat(parts, ignore_index=True)
