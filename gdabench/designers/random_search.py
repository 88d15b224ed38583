"""Random search: the baseline every designer has to beat."""

from __future__ import annotations

from typing import Any, Sequence

from ..body import Body, random_body
from ..designer import Designer


class RandomSearch(Designer):
    """Each generation is ``population`` new valid bodies from Evolution Gym's sampler."""

    def __init__(self, **kwargs: Any):
        super().__init__(**kwargs)
        self._seen: set[str] = set()

    def ask(self) -> list[Body]:
        bodies = []
        for _ in range(self.population):
            body = random_body(self.rng, self.shape, exclude=self._seen)
            self._seen.add(body.hash)
            bodies.append(body)
        return bodies

    def tell(self, bodies: Sequence[Body], rewards: Sequence[float]) -> None:
        """Random search ignores rewards."""
