"""Evolution Gym's genetic algorithm (``examples/ga``), as an ask/tell designer.

Faithful to the reference implementation:

* generation 0: ``population`` unique valid bodies from Evolution Gym's random sampler;
* survivors: the best ``max(2, ceil(population * pct))`` of the previous survivors plus the new
  children, with ``pct = 0.6 * (budget - evaluations - 1) / (budget - 1)`` falling linearly
  from 60% to 0%; survivors keep their reward and are never re-evaluated;
* children: a copy of a uniformly chosen survivor whose voxels each mutate with probability
  ``mutation_rate`` to a draw from the sampler's distribution; the mutation is repeated on the
  same child (up to ``attempts`` times) until it is valid, and the child is kept only if no
  body like it was proposed before; there is no crossover.

``survivors=5`` gives the thesis's variant for the ``simple`` environment (a fixed number of
survivors instead of the schedule).
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

from ..body import Body, mutate, random_body
from ..designer import Designer, top_k
from ..errors import ConfigError, DesignerError

SURVIVAL_HIGH = 0.6  # Evolution Gym's get_percent_survival_evals: 60% -> 0%


class GeneticAlgorithm(Designer):
    """Mutation-only GA with Evolution Gym's survivor schedule (or a fixed survivor count).

    Parameters:
        survivors: bodies kept each generation; None follows Evolution Gym's 60% -> 0% schedule (the thesis used 5
            on simple)
        mutation_rate: probability that a child's voxel is redrawn
        attempts: mutations of one child tried until it is valid and new
        max_tries: children drawn per generation before the designer gives up
    """

    def __init__(
        self,
        *,
        survivors: int | None = None,
        mutation_rate: float = 0.1,
        attempts: int = 50,
        max_tries: int = 100_000,
        **kwargs: Any,
    ):
        super().__init__(**kwargs)
        if survivors is not None:
            if not 1 <= survivors < self.population:
                raise ConfigError(
                    f"ga: survivors must be between 1 and population - 1 = {self.population - 1} "
                    f"(children need room), got {survivors}"
                )
        elif self.population < 3:
            raise ConfigError(
                f"ga: the survivor schedule keeps at least 2 bodies, so population must be at least 3, got "
                f"{self.population}"
            )
        if not 0.0 < mutation_rate <= 1.0:
            raise ConfigError(f"ga: mutation_rate must be in (0, 1], got {mutation_rate}")
        if attempts < 1:
            raise ConfigError(f"ga: attempts must be at least 1, got {attempts}")
        if max_tries < 1:
            raise ConfigError(f"ga: max_tries must be at least 1, got {max_tries}")
        self.fixed_survivors = survivors
        self.mutation_rate = float(mutation_rate)
        self.attempts = int(attempts)
        self.max_tries = int(max_tries)
        self.evaluations = 0  # bodies proposed and told, counted as Evolution Gym counts them
        self.survivors: list[tuple[Body, float]] = []
        self._seen: set[str] = set()
        self._parents: list[str] = []
        self._parent_bodies: list[Body | None] = []

    # -- schedule ----------------------------------------------------------------------------
    def survivor_count(self, evaluations: int) -> int:
        """Number of survivors kept once ``evaluations`` bodies have been evaluated."""
        if self.fixed_survivors is not None:
            return self.fixed_survivors
        pct = SURVIVAL_HIGH * (self.budget - evaluations - 1) / (self.budget - 1) if self.budget > 1 else 0.0
        return min(self.population - 1, max(2, math.ceil(self.population * pct)))

    # -- ask/tell ----------------------------------------------------------------------------
    def ask(self) -> list[Body]:
        remaining = self.budget - self.evaluations
        if not self.survivors:
            bodies = [
                self._remember(random_body(self.rng, self.shape, exclude=self._seen))
                for _ in range(min(self.population, remaining))
            ]
            self._parents = [""] * len(bodies)
            self._parent_bodies = [None] * len(bodies)
            return bodies
        wanted = min(self.population - len(self.survivors), remaining)
        children: list[Body] = []
        self._parents = []
        self._parent_bodies = []
        for _ in range(self.max_tries):
            if len(children) == wanted:
                return children
            parent = self.survivors[int(self.rng.integers(len(self.survivors)))][0]
            child = mutate(parent, self.rng, self.mutation_rate, self.attempts)
            if child is not None and child.hash not in self._seen:
                children.append(self._remember(child))
                self._parents.append(parent.hash)
                self._parent_bodies.append(parent)
        if len(children) == wanted:
            return children
        raise DesignerError(f"ga: no new valid child found in {self.max_tries} tries (is the body space exhausted?)")

    def tell(self, bodies: Sequence[Body], rewards: Sequence[float]) -> None:
        self.evaluations += len(bodies)
        pool = [b for b, _ in self.survivors] + list(bodies)
        scores = [r for _, r in self.survivors] + [float(r) for r in rewards]
        kept_bodies, kept_rewards = top_k(pool, scores, self.survivor_count(self.evaluations))
        self.survivors = list(zip(kept_bodies, kept_rewards))

    def proposal_info(self) -> list[Mapping[str, Any]]:
        return [{"parent": p} for p in self._parents]

    def proposal_parents(self) -> list[Sequence[Body]]:
        """A child's parent is the survivor it was mutated from (no crossover); generation 0 has none."""
        return [() if p is None else (p,) for p in self._parent_bodies]

    def _remember(self, body: Body) -> Body:
        self._seen.add(body.hash)
        return body
