"""pyribs quality-diversity search as a designer: MAP-Elites (``ribs-map-elites``) and CMA-ME
(``ribs-cma-me``) on two body descriptors, the filled share of the grid and the actuator share of
the filled voxels.

pyribs searches real vectors, so a body is encoded as ``H * W * 5`` logits, one per voxel and
material; the body is the arg-max material of each voxel, repaired to be valid the same way every
time (a deterministic genotype -> body map, so an archived solution always means the same body):

1. if no voxel is filled, the voxel and material with the highest non-empty logit is filled;
2. only the largest 4-connected group of filled voxels is kept (the first one found, row by row,
   among equally large groups);
3. if that group has no actuator, the voxel of the group with the highest actuator logit becomes
   that actuator.

The archive is pyribs' ``GridArchive`` (``bins`` x ``bins`` cells over [0, 1] x [0, 1]), driven by
pyribs' ``Scheduler``: MAP-Elites with ``GaussianEmitter`` (an elite drawn uniformly plus Gaussian
noise of ``sigma``), CMA-ME with ``EvolutionStrategyEmitter`` (CMA-ES ranked by archive improvement,
restarting when it stops improving).

Each generation is one batch of the scheduler minus its repeats: a solution whose body was
evaluated before in the run is told that body's real reward without being proposed again, two
solutions of a batch with the same body share one evaluation, and a batch with no new body at all
is told at once and the next one asked (up to ``max_tries`` batches).  A generation can therefore
hold fewer than ``population`` bodies.  A reward of ``nan`` is told as the penalty of
:class:`~gdabench.designers.ecosystem.RewardScale`.
"""

from __future__ import annotations

from typing import Any, Literal, Mapping, Sequence

import numpy as np
from scipy import ndimage

from ...body import EMPTY, H_ACT, N_VOXEL_TYPES, V_ACT, Body
from ...designer import Designer
from ...errors import ConfigError, DesignerError
from . import RewardScale, descriptors, require


def decode(solution: np.ndarray, shape: tuple[int, int]) -> Body:
    """The valid body a vector of ``H * W * 5`` logits stands for (see the module's repair rule)."""
    logits = np.asarray(solution, dtype=float).reshape(*shape, N_VOXEL_TYPES)
    codes = logits.argmax(axis=-1).astype(np.int8)
    if not np.any(codes != EMPTY):
        cell, material = divmod(int(np.argmax(logits[..., 1:].reshape(-1, N_VOXEL_TYPES - 1))), N_VOXEL_TYPES - 1)
        codes.flat[cell] = material + 1
    labels, count = ndimage.label(codes != EMPTY)  # the default structure is 4-connectivity
    if count > 1:
        sizes = np.bincount(labels.ravel())[1:]
        codes[labels != int(np.argmax(sizes)) + 1] = EMPTY
    group = codes != EMPTY
    if not np.any((codes == H_ACT) | (codes == V_ACT)):
        actuator_logits = np.where(group[..., None], logits[..., [H_ACT, V_ACT]], -np.inf)
        cell, which = divmod(int(np.argmax(actuator_logits.reshape(-1, 2))), 2)
        codes.flat[cell] = (H_ACT, V_ACT)[which]
    return Body(codes)


class RibsMapElites(Designer):
    """MAP-Elites or CMA-ME from pyribs over filled share x actuator share.

    Parameters:
        emitter: gaussian (MAP-Elites: Gaussian noise on uniformly drawn elites) or cma (CMA-ME: improvement-ranked
            CMA-ES)
        bins: archive cells per descriptor (bins x bins cells)
        sigma: standard deviation of the Gaussian noise (gaussian) or CMA-ES's initial step size (cma), on the logits
        emitters: number of emitters; the population is split between them
        max_tries: scheduler batches asked in one generation before giving up when none holds a new body
    """

    def __init__(
        self,
        *,
        emitter: Literal["gaussian", "cma"] = "gaussian",
        bins: int = 5,
        sigma: float = 0.5,
        emitters: int = 1,
        max_tries: int = 1000,
        **kwargs: Any,
    ):
        super().__init__(**kwargs)
        name = "ribs-cma-me" if emitter == "cma" else "ribs-map-elites"
        if emitter not in ("gaussian", "cma"):
            raise ConfigError(f"{name}: emitter must be gaussian or cma, got {emitter!r}")
        if bins < 1:
            raise ConfigError(f"{name}: bins must be at least 1, got {bins}")
        if not sigma > 0:
            raise ConfigError(f"{name}: sigma must be positive, got {sigma}")
        if not 1 <= emitters <= self.population:
            raise ConfigError(
                f"{name}: emitters must be between 1 and the population ({self.population}), got {emitters}"
            )
        if max_tries < 1:
            raise ConfigError(f"{name}: max_tries must be at least 1, got {max_tries}")
        require("ribs", "ribs", name)
        from ribs.archives import GridArchive
        from ribs.emitters import EvolutionStrategyEmitter, GaussianEmitter
        from ribs.schedulers import Scheduler

        self.name, self.emitter, self.bins, self.sigma, self.max_tries = (
            name,
            emitter,
            int(bins),
            float(sigma),
            int(max_tries),
        )
        dim = int(np.prod(self.shape)) * N_VOXEL_TYPES
        seeds = [int(s.generate_state(1)[0]) for s in self.seed_sequence.spawn(1 + emitters)]
        archive = GridArchive(
            solution_dim=dim, dims=(self.bins, self.bins), ranges=((0.0, 1.0), (0.0, 1.0)), seed=seeds[0]
        )
        sizes = [self.population // emitters + (i < self.population % emitters) for i in range(emitters)]
        x0 = np.zeros(dim)
        made: list[Any]
        if emitter == "gaussian":
            made = [
                GaussianEmitter(archive, sigma=self.sigma, x0=x0, batch_size=b, seed=s)
                for b, s in zip(sizes, seeds[1:])
            ]
        else:
            made = [
                EvolutionStrategyEmitter(archive, x0=x0, sigma0=self.sigma, ranker="2imp", batch_size=b, seed=s)
                for b, s in zip(sizes, seeds[1:])
            ]
        self.scheduler = Scheduler(archive, made)
        self.scale = RewardScale()
        self.known: dict[str, float] = {}  # hash -> reward of every body evaluated in this run
        self._batch: list[Body] = []  # the body of every solution of the scheduler's open batch
        self._proposed: list[Body] = []

    @property
    def archive(self) -> Any:
        """pyribs' GridArchive of the run so far."""
        return self.scheduler.archive

    def ask(self) -> list[Body]:
        for _ in range(self.max_tries):
            self._batch = [decode(x, self.shape) for x in self.scheduler.ask()]
            new: dict[str, Body] = {}
            for body in self._batch:
                if body.hash not in self.known:
                    new.setdefault(body.hash, body)
            if new:
                self._proposed = list(new.values())
                return self._proposed
            self._tell_batch()  # nothing new: the scheduler hears the known rewards and tries again
        raise DesignerError(f"{self.name}: {self.max_tries} scheduler batches in a row held no new body")

    def tell(self, bodies: Sequence[Body], rewards: Sequence[float]) -> None:
        rewards = [float(r) for r in rewards]
        self.scale.observe(rewards)
        for body, reward in zip(bodies, rewards):
            self.known[body.hash] = reward
        self._tell_batch()

    def _tell_batch(self) -> None:
        objective = np.array([self.scale.score(self.known[b.hash]) for b in self._batch])
        measures = np.array([descriptors(b) for b in self._batch])
        self.scheduler.tell(objective, measures)
        self._batch = []

    def proposal_info(self) -> list[Mapping[str, Any]]:
        """``filled_share`` and ``actuator_share``: the descriptors that place a body in the archive."""
        return [dict(zip(("filled_share", "actuator_share"), descriptors(b))) for b in self._proposed]
