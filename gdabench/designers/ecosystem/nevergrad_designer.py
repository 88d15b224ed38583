"""nevergrad's optimizers as a designer: ``nevergrad[optimizer=DiscreteOnePlusOne]``.

A body is nevergrad's discrete parametrization ``Choice([0, 1, 2, 3, 4], repetitions=H*W,
deterministic=True)``: one voxel code per cell, row-major, each the arg-max of that cell's five
weights.  (With nevergrad's default, ``deterministic=False``, every proposal draws all voxels from
the softmax of the weights, which stay near uniform: the (1+1) optimizers then propose nearly
random bodies and measured no better than random search.)  The optimizer is built with the run's
budget and ``num_workers = population``, so it is asked for a whole generation before it is told.

What nevergrad proposes is not always a body gdabench may evaluate, and its loss is told for
everything it proposed:

* an invalid body (no actuator, not connected) is told the penalty (see
  :class:`~gdabench.designers.ecosystem.RewardScale`) at once and another one is asked for;
* a body evaluated before in the run is told its real reward again (nevergrad sees a noiseless
  repeat) and another one is asked for;
* a body proposed twice in one generation is evaluated once and both proposals get its reward;
* after ``max_tries`` asks in one generation the remaining places are filled with Evolution Gym's
  random sampler, and nevergrad is told those bodies as points it did not ask for (optimizers
  that cannot take such points simply do not hear of them).

nevergrad minimises, so it is told ``-reward``; a reward of ``nan`` is told as the penalty.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from ...body import N_VOXEL_TYPES, Body, invalid_reason, random_body
from ...designer import Designer
from ...errors import ConfigError
from . import RewardScale, require

#: the discrete optimizers the documentation suggests; any other name in
#: ``nevergrad.optimizers.registry`` is accepted too
SUGGESTED = (
    "NGOpt",
    "DiscreteOnePlusOne",
    "PortfolioDiscreteOnePlusOne",
    "DiscreteLenglerOnePlusOne",
    "DoubleFastGADiscreteOnePlusOne",
    "RecombiningPortfolioDiscreteOnePlusOne",
    "DiscreteBSOOnePlusOne",
    "DiscreteDE",
)


class NevergradDesigner(Designer):
    """A nevergrad optimizer over the voxel codes, asked and told once per body.

    Parameters:
        optimizer: name in nevergrad's optimizer registry, e.g. NGOpt, DiscreteOnePlusOne, PortfolioDiscreteOnePlusOne
        max_tries: asks in one generation before its remaining places are filled by the random sampler
    """

    def __init__(self, *, optimizer: str = "NGOpt", max_tries: int = 10_000, **kwargs: Any):
        super().__init__(**kwargs)
        if max_tries < 1:
            raise ConfigError(f"nevergrad: max_tries must be at least 1, got {max_tries}")
        ng = require("nevergrad", "nevergrad", "nevergrad")
        if optimizer not in ng.optimizers.registry:
            raise ConfigError(
                f"nevergrad: unknown optimizer {optimizer!r}; choose one of {', '.join(SUGGESTED)} "
                "(or any other name in nevergrad.optimizers.registry)"
            )
        self.optimizer_name = optimizer
        self.max_tries = int(max_tries)
        parametrization = ng.p.Choice(
            list(range(N_VOXEL_TYPES)), repetitions=int(np.prod(self.shape)), deterministic=True
        )
        # every random choice nevergrad makes comes from the parametrization's random state
        parametrization.random_state = np.random.RandomState(self.seed_sequence.spawn(1)[0].generate_state(1)[0])
        self.optimizer = ng.optimizers.registry[optimizer](
            parametrization=parametrization, budget=self.budget, num_workers=self.population
        )
        self._tell_not_asked_error = ng.errors.TellNotAskedNotSupportedError
        self.scale = RewardScale()
        self.known: dict[str, float] = {}  # hash -> reward of every body evaluated in this run
        self._pending: list[tuple[Any, int]] = []  # (candidate, index of its body in the last ask)
        self._origin: list[str] = []
        self.evaluations = 0

    def ask(self) -> list[Body]:
        wanted = max(1, min(self.population, self.budget - self.evaluations))
        bodies: list[Body] = []
        index: dict[str, int] = {}
        self._pending, self._origin = [], []
        for _ in range(self.max_tries):
            if len(bodies) == wanted:
                break
            candidate = self.optimizer.ask()
            voxels = np.asarray(candidate.value, dtype=np.int8).reshape(self.shape)
            if invalid_reason(voxels) is not None:
                self.optimizer.tell(candidate, -self.scale.penalty)
                continue
            body = Body(voxels)
            if body.hash in self.known:
                self.optimizer.tell(candidate, -self.scale.score(self.known[body.hash]))
            elif body.hash in index:
                self._pending.append((candidate, index[body.hash]))
            else:
                index[body.hash] = len(bodies)
                self._pending.append((candidate, len(bodies)))
                bodies.append(body)
                self._origin.append("optimizer")
        while len(bodies) < wanted:  # nevergrad keeps proposing what is known or invalid
            body = random_body(self.rng, self.shape, exclude=self.known.keys() | index.keys())
            index[body.hash] = len(bodies)
            candidate = self.optimizer.parametrization.spawn_child(new_value=tuple(int(v) for v in body.voxels.ravel()))
            self._pending.append((candidate, len(bodies)))
            bodies.append(body)
            self._origin.append("sampler")
        return bodies

    def tell(self, bodies: Sequence[Body], rewards: Sequence[float]) -> None:
        rewards = [float(r) for r in rewards]
        self.evaluations += len(bodies)
        self.scale.observe(rewards)
        for body, reward in zip(bodies, rewards):
            self.known[body.hash] = reward
        for candidate, i in self._pending:
            try:
                self.optimizer.tell(candidate, -self.scale.score(rewards[i]))
            except self._tell_not_asked_error:
                pass  # a sampler body this optimizer cannot learn from
        self._pending = []

    def proposal_info(self) -> list[Mapping[str, Any]]:
        """``origin``: ``optimizer`` for nevergrad's proposals, ``sampler`` for the random fill-ins."""
        return [{"origin": o} for o in self._origin]
