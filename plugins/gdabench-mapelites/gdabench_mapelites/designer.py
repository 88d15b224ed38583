"""MAP-Elites over two body features: how many voxels a body has and how much of it is muscle.

Instead of one population climbing one peak, MAP-Elites keeps the best body found in every
cell of a feature grid and breeds from randomly chosen cells, so small and large, passive and
muscular bodies are all explored.  Mutation is Evolution Gym's (``gdabench.body.mutate``), so
differences to the ``ga`` designer come from the archive alone.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from gdabench import ConfigError, Designer, DesignerError
from gdabench.body import H_ACT, V_ACT, Body, mutate, random_body


class MapElites(Designer):
    def __init__(self, *, bins: int = 5, mutation_rate: float = 0.1, max_tries: int = 100_000, **kwargs: Any):
        super().__init__(**kwargs)
        if bins < 1:
            raise ConfigError(f"map-elites: bins must be at least 1, got {bins}")
        self.bins, self.mutation_rate, self.max_tries = int(bins), float(mutation_rate), int(max_tries)
        self.archive: dict[tuple[int, int], tuple[Body, float]] = {}
        self._seen: set[str] = set()
        self._cells: list[tuple[int, int]] = []

    def cell(self, body: Body) -> tuple[int, int]:
        """Grid cell of a body: (filled share, actuator share of the filled voxels), each in `bins` bins."""
        voxels = body.voxels
        filled = int(np.count_nonzero(voxels))
        muscle = int(np.isin(voxels, (H_ACT, V_ACT)).sum())
        size_bin = min(self.bins - 1, (filled - 1) * self.bins // voxels.size)
        muscle_bin = min(self.bins - 1, muscle * self.bins // max(filled, 1))
        return size_bin, muscle_bin

    def ask(self) -> list[Body]:
        wanted = self.population
        bodies: list[Body] = []
        elites = [body for body, _ in self.archive.values()]
        for _ in range(self.max_tries):
            if len(bodies) == wanted:
                break
            if elites:
                child = mutate(elites[int(self.rng.integers(len(elites)))], self.rng, self.mutation_rate)
            else:
                child = random_body(self.rng, self.shape, exclude=self._seen)
            if child is not None and child.hash not in self._seen:
                self._seen.add(child.hash)
                bodies.append(child)
        else:
            raise DesignerError(f"map-elites: no new valid body in {self.max_tries} tries")
        self._cells = [self.cell(b) for b in bodies]
        return bodies

    def tell(self, bodies: Sequence[Body], rewards: Sequence[float]) -> None:
        for body, reward in zip(bodies, rewards):
            if np.isnan(reward):
                continue
            cell = self.cell(body)
            if cell not in self.archive or reward > self.archive[cell][1]:
                self.archive[cell] = (body, float(reward))

    def proposal_info(self) -> list[Mapping[str, Any]]:
        return [{"cell_size": c[0], "cell_muscle": c[1]} for c in self._cells]
