"""The ``modular-ppo`` controller: one policy for a whole generation, carried on to the next.

A generation's new bodies reach :meth:`ModularPPO.evaluate_bodies` in one call (``bodies_at_once`` above any
population; the harness refuses execution options that would split it, :attr:`Controller.learns_across_bodies`).
They learn together: one :class:`~.policy.SharedPolicy` on ModularEvoGym's per-voxel observations, trained with
PPO on their pooled experience (:func:`~.train.train_pooled`), starting from the policy the trial's previous
generation left (a fresh one seeded from the generation's seeds for the first).  Each body's reward is its best
evaluation under the shared policy, as ``ppo`` scores a body.

What is kept, so that a resumed run gives the same numbers:

* per body, in its work directory: the shared policy's state at the body's best evaluation and what it was
  trained with (``modular_policy.pt`` / ``.json``), so a report or ``gdabench replay`` plays the body again and a
  resumed run replays a body of a finished generation instead of training it again;
* per trial, in ``<trial folder>/modular-ppo/<settings hash>/``: the policy each generation ended with and the
  bodies it learnt from (``chain.json``, written after the bodies' files).  A generation the chain does not
  list (killed while training or saving) is trained again from the policy it started from.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np
import torch

from ... import faults
from ...environment import Bodies, Controller, Evaluation
from ...sdk import BodyBatch, GymBodies, atomic_write_bytes
from ..ppo.evaluation import evaluate_policies
from ..ppo.train import deterministic_torch, evaluation_generator
from .config import NOT_SHARED, SIGNATURE, modular_config
from .observation import ModularView, modular_view
from .policy import SharedBatch, SharedPolicy, fresh_policy
from .train import train_pooled

WEIGHTS_FILE, META_FILE = "modular_policy.pt", "modular_policy.json"
#: the trial's folder of carried policies (beside its bodies' folders, which are named by body hash)
CHAIN_FOLDER = "modular-ppo"
FORMAT = 1


class ModularPPO(Controller):
    """One shared per-voxel policy (ModularEvoGym's observations) learns a generation's bodies together with PPO,
    carried from generation to generation (parameters: ppo's, less init, normalize_obs and device).

    Parameters:
        timesteps: environment steps of training per body (the generation trains bodies x timesteps in all)
        learning_rate: Adam's learning rate
        n_steps: steps per rollout
        batch_size: minibatch size per body (a minibatch holds this many samples of every body)
        n_epochs: passes over each rollout
        gamma: discount factor
        gae_lambda: GAE's lambda
        vf_coef: value loss weight
        ent_coef: entropy bonus weight
        clip_range: PPO's clip range
        max_grad_norm: gradient norm clip
        n_envs: environments per body stepped together
        eval_interval: timesteps between evaluations (default: timesteps / 10)
        n_evals: episodes per evaluation
        deterministic_eval: evaluate the policy's mean action instead of sampling
        episode_end: how an evaluation episode is scored: evogym2 (drops the last step's reward) or full
        hidden: sizes of the hidden layers of the shared per-voxel networks
        lr_schedule: constant or linear (decays to 0 over each generation's training)
        threads: torch threads per training
    """

    #: a generation learns together: the harness hands all its new bodies in one call
    bodies_at_once = 1_000_000
    learns_across_bodies = True

    def __init__(self, **params: Any):
        self.config = modular_config(**params)
        #: the policy each chain (by its folder) carries, as on disk, so that it is not read back: (generations, state)
        self._carried: dict[str | None, tuple[int, dict[str, torch.Tensor]]] = {}

    @property
    def settings(self) -> dict[str, Any]:
        """What determines a training (runtime settings aside)."""
        return {k: v for k, v in self.config.as_dict().items() if k not in (*NOT_SHARED, "threads")}

    evaluate = Controller.evaluate_alone

    def evaluate_bodies(
        self, bodies: Bodies, *, seeds: Sequence[int], workdirs: Sequence[Path | None]
    ) -> list[Evaluation | BaseException]:
        """Bodies of a generation the trial's chain lists replay their saved policy; the others are a new
        generation, trained together from the policy the chain carries."""
        chain = Chain.of(workdirs, self.settings)
        out: list[Evaluation | BaseException | None] = [
            self._saved(make_env, seed, workdir, chain)
            for make_env, seed, workdir in zip(bodies.make_envs, seeds, workdirs)
        ]
        todo = [i for i, result in enumerate(out) if result is None]
        if todo:
            try:
                trained: Sequence[Evaluation | BaseException] = self._train(bodies, todo, seeds, workdirs, chain)
            except Exception as exc:  # noqa: BLE001 - the generation learns together: it fails together
                trained = [exc] * len(todo)
            for i, result in zip(todo, trained):
                out[i] = result
        return [r for r in out if r is not None]

    def _saved(
        self, make_env: Callable[[], Any], seed: int, workdir: Path | None, chain: Chain
    ) -> Evaluation | BaseException | None:
        """The replayed evaluation of a body whose generation the chain lists, or None."""
        if workdir is None or not (workdir / META_FILE).is_file() or not (workdir / WEIGHTS_FILE).is_file():
            return None
        try:
            meta = json.loads((workdir / META_FILE).read_text())
            if meta.get("format") != FORMAT or meta.get("trained_with") != {"settings": self.settings, "seed": seed}:
                return None
            if workdir.name not in chain.bodies(int(meta["generation"])):
                return None  # saved by a generation that did not finish saving: trained again
            state = torch.load(workdir / WEIGHTS_FILE, map_location="cpu", weights_only=True)
            reward = replay_state(self.config, state, meta, make_env, seed)
            return Evaluation(reward, meta["info"])
        except Exception as exc:  # noqa: BLE001 - this body's failure, not the batch's
            return exc

    def _start(self, chain: Chain) -> tuple[int, dict[str, torch.Tensor] | None]:
        """Generations the chain has learnt and the policy the last one left (None before the first)."""
        done = chain.generations()
        if done == 0:
            return 0, None
        kept = self._carried.get(chain.key)
        if kept is not None and kept[0] == done:
            return kept
        return done, chain.state(done)

    def _train(
        self, bodies: Bodies, todo: list[int], seeds: Sequence[int], workdirs: Sequence[Path | None], chain: Chain
    ) -> list[Evaluation]:
        views = [_view(bodies.make_envs[i]) for i in todo]
        body_seeds = [int(seeds[i]) for i in todo]
        done, state = self._start(chain)
        seed = generation_seed(body_seeds, done)
        policy = fresh_policy(len(views[0].other), self.config.hidden, seed)
        if state is not None:
            policy.load_state_dict(state)

        def make_batch(n: int) -> BodyBatch:
            if bodies.make_batch is not None:
                return bodies.make_batch(todo, n)
            return GymBodies([bodies.make_envs[i] for i in todo], n)

        start = time.perf_counter()
        result = train_pooled(self.config, policy, make_batch, views, body_seeds, seed)
        seconds = time.perf_counter() - start
        generation = done + 1
        out = []
        for b, i in enumerate(todo):
            best = result.best_index[b]
            info = {
                "env_steps": result.timesteps,
                "modular_generation": generation,
                "modular_bodies": len(todo),
                "modular_best_at": result.evaluations[b][best].timesteps,
                "modular_train_seconds": round(seconds / len(todo), 3),
                "replayed": 0,
            }
            workdir = workdirs[i]
            if workdir is not None:
                meta = {
                    "format": FORMAT,
                    "trained_with": {"settings": self.settings, "seed": body_seeds[b]},
                    "generation": generation,
                    "reward": result.reward(b),
                    "best_evaluation": best,
                    "evaluations": [{"timesteps": e.timesteps, "scores": e.scores} for e in result.evaluations[b]],
                    "info": info,
                }
                _save(workdir, result.states[best], meta)
                faults.point("modular-ppo-saved")
            out.append(Evaluation(result.reward(b), info))
        final = {k: v.detach().clone() for k, v in result.final.state_dict().items()}
        names = [w.name for w in (workdirs[i] for i in todo) if w is not None]
        if chain.folder is not None:
            chain.add(generation, final, names)
            self._carried[chain.key] = (generation, final)
        return out


# the harness reads a factory's keyword parameters from its signature
ModularPPO.__init__.__signature__ = SIGNATURE  # type: ignore[attr-defined]


def generation_seed(seeds: Sequence[int], done: int) -> int:
    """A generation's seed (fresh weights, minibatch order): from its bodies' evaluation seeds and its place."""
    return int(np.random.SeedSequence([*(int(s) for s in seeds), done]).generate_state(1, dtype=np.uint32)[0])


@dataclass(frozen=True)
class Chain:
    """The policies a trial carried from generation to generation, on disk (``folder`` None: bodies without work
    directories, e.g. a re-evaluation, learn from a fresh policy and leave nothing to carry on)."""

    folder: Path | None

    @classmethod
    def of(cls, workdirs: Sequence[Path | None], settings: dict[str, Any]) -> Chain:
        """The chain of the trial whose bodies' folders are ``workdirs`` (they share a parent), for ``settings``."""
        parents = {Path(w).parent for w in workdirs if w is not None}
        if len(parents) > 1:
            raise ValueError("modular-ppo: a generation's work directories must share one trial folder")
        if not parents:
            return cls(None)
        digest = hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:12]
        return cls(parents.pop() / CHAIN_FOLDER / digest)

    @property
    def key(self) -> str | None:
        return None if self.folder is None else str(self.folder)

    def _record(self) -> list[list[str]]:
        """Per generation learnt, the names of its bodies' work directories."""
        if self.folder is None:
            return []
        try:
            return list(json.loads((self.folder / "chain.json").read_text())["generations"])
        except FileNotFoundError:
            return []

    def generations(self) -> int:
        return len(self._record())

    def bodies(self, generation: int) -> list[str]:
        record = self._record()
        return record[generation - 1] if 1 <= generation <= len(record) else []

    def state(self, generation: int) -> dict[str, torch.Tensor]:
        assert self.folder is not None
        return torch.load(self.folder / f"generation-{generation:04d}.pt", map_location="cpu", weights_only=True)

    def add(self, generation: int, state: dict[str, torch.Tensor], names: list[str]) -> None:
        """Record generation ``generation`` (the next one) as learnt: its final policy, then the record."""
        assert self.folder is not None
        self.folder.mkdir(parents=True, exist_ok=True)
        record = self._record()[: generation - 1]
        _atomic_torch(self.folder / f"generation-{generation:04d}.pt", state)
        text = json.dumps({"format": FORMAT, "generations": [*record, names]}, indent=1)
        atomic_write_bytes(self.folder / "chain.json", text.encode())


def _view(make_env: Callable[[], Any]) -> ModularView:
    env = make_env()
    try:
        return modular_view(env)
    finally:
        env.close()


def _atomic_torch(path: Path, state: dict[str, torch.Tensor]) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    torch.save(state, tmp)
    tmp.replace(path)


def _save(workdir: Path, state: dict[str, torch.Tensor], meta: dict[str, Any]) -> None:
    """A body's best policy and what it was trained with (weights first: the JSON says they are complete)."""
    workdir.mkdir(parents=True, exist_ok=True)
    _atomic_torch(workdir / WEIGHTS_FILE, state)
    atomic_write_bytes(workdir / META_FILE, json.dumps(meta, indent=1, sort_keys=True).encode())


def replay_state(
    config: Any, state: dict[str, torch.Tensor], meta: dict[str, Any], make_env: Callable[[], Any], seed: int
) -> float:
    """Play a body's winning evaluation again with the shared policy's state at it; its mean score."""
    view = _view(make_env)
    policy = SharedPolicy(len(view.other), config.hidden)
    policy.load_state_dict(state)
    env = make_env()
    try:
        n_obs = int(env.observation_space.shape[0])
    finally:
        env.close()
    with torch.random.fork_rng(devices=[]), deterministic_torch(config.threads), torch.no_grad():
        nets = SharedBatch(policy, [view], n_obs)
        [scores] = evaluate_policies(
            nets,  # type: ignore[arg-type]
            lambda n: GymBodies([make_env], n),
            n_evals=config.n_evals,
            episode_end=config.episode_end,
            generators=[evaluation_generator(config, seed, int(meta["best_evaluation"]))],
        )
    return float(sum(scores) / len(scores))
