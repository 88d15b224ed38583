"""A hill climber: each generation mutates the best body found so far."""

from __future__ import annotations

from typing import Sequence

from gdabench import Body, ConfigError, Designer, DesignerError, mutate, random_body, top_k


class HillClimber(Designer):
    def __init__(self, *, rate: float = 0.1, max_tries: int = 10_000, **kwargs):
        super().__init__(**kwargs)  # shape, population, budget, seed; sets self.rng
        rate = float(rate)
        if not 0 < rate <= 1:
            raise ConfigError(f"hill-climber: rate must be in (0, 1], got {rate}")
        self.rate, self.max_tries = rate, int(max_tries)
        self.best: tuple[Body, float] | None = None
        self.seen: set[str] = set()  # hashes of every body proposed: none may be proposed twice

    def ask(self) -> list[Body]:
        bodies: list[Body] = []
        for _ in range(self.max_tries):
            if self.best is None:
                child = random_body(self.rng, self.shape, exclude=self.seen)
            else:
                child = mutate(self.best[0], self.rng, self.rate)  # None if no valid child was found
            if child is not None and child.hash not in self.seen:
                self.seen.add(child.hash)
                bodies.append(child)
                if len(bodies) == self.population:
                    return bodies
        raise DesignerError(f"hill-climber: no new valid body in {self.max_tries} tries")

    def tell(self, bodies: Sequence[Body], rewards: Sequence[float]) -> None:
        pool, scores = list(bodies), list(rewards)  # rewards may be nan: not scored
        if self.best is not None:
            pool.append(self.best[0])
            scores.append(self.best[1])
        (body,), (reward,) = top_k(pool, scores, 1)
        self.best = (body, reward)
