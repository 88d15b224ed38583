"""What a generation's draw loop collects: the first new bodies it meets, or shares by category.

The designer draws passes of candidates and offers each pass's new valid bodies (None for the
rest) to a quota until it is full or the sample budget is spent; a quota says how many bodies
it still misses and how many candidates of a pass it used.
"""

from __future__ import annotations

import math
from typing import Protocol, Sequence

import numpy as np

from ...body import Body, categorize


class Quota(Protocol):
    def missing(self) -> int:
        """Bodies still wanted."""

    def offer(self, candidates: Sequence[Body | None]) -> int:
        """Take what is wanted of one pass (None: a candidate that is invalid or not new); how
        many candidates count as drawn."""

    def bodies(self) -> list[Body]:
        """What was collected, in the order it is proposed."""


class FirstNew:
    """The first ``wanted`` new bodies in sampling order; drawing stops at the last of them."""

    def __init__(self, wanted: int):
        self.wanted = wanted
        self._bodies: list[Body] = []

    def missing(self) -> int:
        return self.wanted - len(self._bodies)

    def offer(self, candidates: Sequence[Body | None]) -> int:
        for drawn, body in enumerate(candidates, 1):
            if body is not None:
                self._bodies.append(body)
                if not self.missing():
                    return drawn
        return len(candidates)

    def bodies(self) -> list[Body]:
        return list(self._bodies)


class ByCategory:
    """``wanted`` new bodies whose categories relative to ``survivors`` (near-copy, new materials,
    novel shape; :func:`gdabench.body.categorize`) meet ``shares``.

    Whole passes are sorted into their category until its quota is full; when the sample budget
    leaves a quota short, the surplus of the other categories fills it, in sampling order.
    """

    def __init__(self, shares: Sequence[float], wanted: int, survivors: np.ndarray):
        self.wanted, self.survivors = wanted, survivors
        self.quotas = share_counts(shares, wanted)
        self.buckets: list[list[Body]] = [[] for _ in self.quotas]
        self.surplus: list[Body] = []

    def missing(self) -> int:
        return sum(q - len(b) for b, q in zip(self.buckets, self.quotas))

    def offer(self, candidates: Sequence[Body | None]) -> int:
        fresh = [body for body in candidates if body is not None]
        if fresh:
            _, category = categorize(np.stack([b.voxels for b in fresh]), self.survivors)
            for body, c in zip(fresh, category):
                k = max(int(c), 1) - 1  # a copy of a prior's body (survivors were seen) counts as a near-copy
                (self.buckets[k] if len(self.buckets[k]) < self.quotas[k] else self.surplus).append(body)
        return len(candidates)

    def bodies(self) -> list[Body]:
        accepted = [b for bucket in self.buckets for b in bucket]
        return accepted + self.surplus[: self.wanted - len(accepted)]


def share_counts(shares: Sequence[float], n: int) -> list[int]:
    """``n`` split by ``shares`` into whole counts (largest remainders; ties to the earlier share)."""
    exact = [share * n for share in shares]
    counts = [math.floor(e) for e in exact]
    for i in sorted(range(len(exact)), key=lambda i: counts[i] - exact[i])[: n - sum(counts)]:
        counts[i] += 1
    return counts
