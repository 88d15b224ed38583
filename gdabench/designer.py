"""The designer interface: ask for a generation of bodies, tell their rewards.

The harness owns evaluation, the budget, de-duplication, parallelism and logging; a designer
only proposes bodies and learns from rewards.  Its randomness comes from the
``numpy.random.SeedSequence`` it is given, and its whole state must survive ``pickle`` (the
harness checkpoints designers that way after every generation to resume killed runs).
"""

from __future__ import annotations

import abc
from typing import Any, Callable, Mapping, Sequence, TypeVar, cast

import numpy as np

from .body import DEFAULT_SHAPE, Body
from .errors import ConfigError

T = TypeVar("T")

#: a generation's size and a trial's evaluation budget where neither the designer's caller nor the experiment
#: says (the experiment's defaults too: :mod:`gdabench.experiment.config`)
DEFAULT_POPULATION = 25
DEFAULT_BUDGET = 1_000


class Designer(abc.ABC):
    """Base class of all designers (ask/tell).

    Rewards passed to :meth:`tell` are floats; ``nan`` marks a body that could not be scored
    (invalid, or its evaluation failed).  Use :func:`ranking_rewards` to sort such rewards.
    """

    def __init__(
        self,
        *,
        shape: tuple[int, int] = DEFAULT_SHAPE,
        population: int = DEFAULT_POPULATION,
        budget: int = DEFAULT_BUDGET,
        seed: np.random.SeedSequence | int | None = 0,
    ):
        if population < 1:
            raise ConfigError(f"population must be at least 1, got {population}")
        if budget < 1:
            raise ConfigError(f"budget must be at least 1, got {budget}")
        self.shape: tuple[int, int] = cast("tuple[int, int]", tuple(shape))
        self.population = int(population)
        self.budget = int(budget)
        self.seed_sequence = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        self.rng = np.random.default_rng(self.seed_sequence)

    @abc.abstractmethod
    def ask(self) -> list[Body]:
        """Propose the next generation of bodies to evaluate."""

    @abc.abstractmethod
    def tell(self, bodies: Sequence[Body], rewards: Sequence[float]) -> None:
        """Receive the rewards of the bodies returned by the last :meth:`ask` (same order)."""

    def lend_cores(self, borrow: Callable[[], bool]) -> None:  # noqa: B027 - optional hook, ignored by default
        """Offer this designer the run's spare CPU cores: ``borrow()`` is True once its trial holds
        one more core, which it keeps until the trial ends.  The harness calls this before a
        trial's first generation (fresh or resumed); a designer that cannot use a second core
        ignores it (the default)."""

    def proposal_info(self) -> list[Mapping[str, Any]]:
        """Extra result columns for each body of the last :meth:`ask` (e.g. how it was made).

        Return one mapping per body with scalar values, or an empty list for none.
        """
        return []

    def proposal_parents(self) -> list[Sequence[Body]]:
        """The bodies each body of the last :meth:`ask` came from, nearest first (optional).

        Return one sequence per body (empty for a body with no parent, e.g. a random one), or an empty
        list to say nothing (the default).  Parents are bodies this designer was told about in earlier
        generations; a controller that inherits (``ppo[init=parent]``) starts a child's policy from its
        first parent that was evaluated in the same trial.  See :func:`nearest_first`.
        """
        return []


def hamming(a: Body, b: Body) -> int:
    """Voxels in which two bodies of one shape differ."""
    return int(np.count_nonzero(np.asarray(a.voxels) != np.asarray(b.voxels)))


def nearest_first(child: Body, parents: Sequence[Body]) -> list[Body]:
    """``parents`` sorted by voxel (Hamming) distance to ``child``, ties in their given order."""
    return sorted(parents, key=lambda p: hamming(child, p))


def ranking_rewards(rewards: Sequence[float]) -> np.ndarray:
    """Rewards as floats with ``nan`` replaced by ``-inf``, ready for sorting."""
    r = np.asarray(rewards, dtype=float)
    return np.where(np.isnan(r), -np.inf, r)


def top_k(bodies: Sequence[T], rewards: Sequence[float], k: int) -> tuple[list[T], list[float]]:
    """The ``k`` best bodies (or anything rewards rank), best first; ties keep their input order (a stable sort)."""
    order = np.argsort(-ranking_rewards(rewards), kind="stable")[:k]
    return [bodies[i] for i in order], [float(rewards[i]) for i in order]
