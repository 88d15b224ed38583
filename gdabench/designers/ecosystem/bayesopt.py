"""Bayesian optimisation on BoTorch, the kind of baseline Evolution Gym compares against (``bo``).

* **Generation 0** is ``population`` bodies from Evolution Gym's random sampler (the same bodies
  ``ga`` and ``random`` start from under the same seed).
* **Model**: a BoTorch ``SingleTaskGP`` (its default kernel and priors, outcomes standardised) on
  the flattened one-hot encoding of the voxel codes (``H * W * 5`` inputs), refitted every
  generation by maximising the marginal likelihood (``fit_iters`` L-BFGS iterations).  To keep a
  generation within seconds it sees at most ``max_train`` bodies: the best half of them and a
  random draw from the rest.
* **Candidates**: ``candidates`` new valid bodies, half fresh from the random sampler and half
  mutations (Evolution Gym's, ``mutation_rate``) of the ``elites`` best bodies so far.
* **Batch acquisition**: Thompson sampling, BoTorch's ``MaxPosteriorSampling`` without replacement:
  ``population`` draws of the GP's joint posterior over the candidates, each picking its best one,
  so the generation is diverse without an inner optimisation loop.

Every candidate is valid and new in the run, so nothing is repaired or refused.  A reward of
``nan`` enters the model as the penalty of :class:`~gdabench.designers.ecosystem.RewardScale`.
Torch's random draws come from a generator seeded from the designer's stream (the process's
global torch state is left alone), and torch runs on ``threads`` threads during a generation.
"""

from __future__ import annotations

import contextlib
from typing import Any, Iterator, Sequence

import numpy as np

from ...body import N_VOXEL_TYPES, Body, mutate, random_body
from ...designer import Designer, ranking_rewards
from ...errors import ConfigError
from . import RewardScale, require


class BayesianOptimization(Designer):
    """Gaussian-process Bayesian optimisation over one-hot bodies, Thompson-sampled batches.

    Parameters:
        candidates: bodies the acquisition chooses from each generation (half random, half mutated elites)
        elites: best bodies whose mutations make up half of the candidates
        mutation_rate: probability that a voxel of a mutated candidate is redrawn
        max_train: bodies the GP is fitted on (the best half and a random draw of the rest)
        fit_iters: L-BFGS iterations of the marginal-likelihood fit per generation
        threads: torch threads while a generation is chosen; null leaves torch's setting alone
    """

    def __init__(
        self,
        *,
        candidates: int = 1000,
        elites: int = 10,
        mutation_rate: float = 0.1,
        max_train: int = 250,
        fit_iters: int = 50,
        threads: int | None = 1,
        **kwargs: Any,
    ):
        super().__init__(**kwargs)
        if candidates < self.population:
            raise ConfigError(f"bo: candidates must be at least the population ({self.population}), got {candidates}")
        if elites < 1:
            raise ConfigError(f"bo: elites must be at least 1, got {elites}")
        if not 0.0 < mutation_rate <= 1.0:
            raise ConfigError(f"bo: mutation_rate must be in (0, 1], got {mutation_rate}")
        if max_train < 2:
            raise ConfigError(f"bo: max_train must be at least 2, got {max_train}")
        if fit_iters < 1:
            raise ConfigError(f"bo: fit_iters must be at least 1, got {fit_iters}")
        if threads is not None and threads < 1:
            raise ConfigError(f"bo: threads must be at least 1, got {threads}")
        require("botorch", "bo", "bo")
        self.candidates, self.elites, self.mutation_rate = int(candidates), int(elites), float(mutation_rate)
        self.max_train, self.fit_iters, self.threads = int(max_train), int(fit_iters), threads
        self.scale = RewardScale()
        self.bodies: list[Body] = []
        self.rewards: list[float] = []
        self._seen: set[str] = set()

    # -- ask/tell ----------------------------------------------------------------------------
    def ask(self) -> list[Body]:
        wanted = max(1, min(self.population, self.budget - len(self.bodies)))
        if not self.bodies:
            return [self._remember(random_body(self.rng, self.shape, exclude=self._seen)) for _ in range(wanted)]
        pool = self._candidate_pool()
        chosen = self._thompson(pool, wanted)
        return [self._remember(pool[i]) for i in chosen]

    def tell(self, bodies: Sequence[Body], rewards: Sequence[float]) -> None:
        rewards = [float(r) for r in rewards]
        self.scale.observe(rewards)
        self.bodies.extend(bodies)
        self.rewards.extend(rewards)

    # -- the pieces --------------------------------------------------------------------------
    def _candidate_pool(self) -> list[Body]:
        """``candidates`` valid bodies not proposed before: mutated elites, then random ones."""
        order = np.argsort(-ranking_rewards(self.rewards), kind="stable")[: self.elites]
        elites = [self.bodies[i] for i in order]
        pool: dict[str, Body] = {}
        for _ in range(20 * self.candidates):
            if len(pool) >= self.candidates // 2:
                break
            child = mutate(elites[int(self.rng.integers(len(elites)))], self.rng, self.mutation_rate)
            if child is not None and child.hash not in self._seen:
                pool.setdefault(child.hash, child)
        while len(pool) < self.candidates:
            body = random_body(self.rng, self.shape, exclude=self._seen | pool.keys())
            pool[body.hash] = body
        return list(pool.values())

    def _training_set(self) -> tuple[list[Body], list[float]]:
        """At most ``max_train`` of the bodies told so far: the best half and a random draw of the rest."""
        scores = [self.scale.score(r) for r in self.rewards]
        if len(scores) <= self.max_train:
            return self.bodies, scores
        order = np.argsort(-np.asarray(scores), kind="stable")
        best = order[: self.max_train // 2]
        rest = self.rng.choice(order[self.max_train // 2 :], size=self.max_train - len(best), replace=False)
        keep = np.concatenate([best, np.sort(rest)])
        return [self.bodies[i] for i in keep], [scores[i] for i in keep]

    def _thompson(self, pool: list[Body], q: int) -> list[int]:
        """Indices of ``q`` distinct candidates, each the best of one joint posterior draw."""
        import torch
        from botorch.fit import fit_gpytorch_mll
        from botorch.generation.sampling import MaxPosteriorSampling
        from botorch.models import SingleTaskGP
        from botorch.models.transforms import Standardize
        from gpytorch.mlls import ExactMarginalLogLikelihood

        # one torch thread: a small GP runs tens of times faster than on two busy cores
        from ...torch_runtime import torch_threads

        bodies, scores = self._training_set()
        torch_seed = int(self.rng.integers(2**63 - 1))
        with torch_threads(self.threads), torch.random.fork_rng(), _quiet():
            torch.manual_seed(torch_seed)
            x = one_hot(bodies)
            y = torch.tensor(scores, dtype=torch.float64).unsqueeze(-1)
            model = SingleTaskGP(x, y, outcome_transform=Standardize(m=1))
            fit_gpytorch_mll(
                ExactMarginalLogLikelihood(model.likelihood, model),
                optimizer_kwargs={"options": {"maxiter": self.fit_iters}},
            )
            choices = one_hot(pool)
            with torch.no_grad():
                picked = MaxPosteriorSampling(model, replacement=False)(choices, num_samples=q)
        rows = {tuple(r): i for i, r in enumerate(choices.to(torch.int8).tolist())}
        return [rows[tuple(r)] for r in picked.to(torch.int8).tolist()]

    def _remember(self, body: Body) -> Body:
        self._seen.add(body.hash)
        return body


def one_hot(bodies: Sequence[Body]) -> Any:
    """(n, H*W*5) float64 tensor: one indicator per voxel and material."""
    import torch

    codes = torch.as_tensor(np.stack([b.voxels for b in bodies]).reshape(len(bodies), -1), dtype=torch.long)
    return torch.nn.functional.one_hot(codes, N_VOXEL_TYPES).reshape(len(bodies), -1).to(torch.float64)


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """BoTorch warns about every fit that stops at ``fit_iters``; that stop is deliberate."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield
