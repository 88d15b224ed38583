"""The ``ppo`` controller: train PPO on the body, report the best evaluation, keep the policy.

``PPO(**params)`` takes every :class:`~gdabench.controllers.ppo.config.PPOConfig` field as a
keyword (``-C timesteps=1e6 -C n_envs=4`` on the command line) and checks them at once, so bad
settings fail before a run starts.  ``evaluate`` trains (see
:mod:`~gdabench.controllers.ppo.train`) and saves the best policy in the body's work directory;
when that directory already holds a policy trained with the same settings and seed, it is
replayed instead of trained again: that is how ``gdabench report`` and ``gdabench replay``
animate a body, and how a resumed run skips bodies it already trained.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import torch

from ...batched import box_dims
from ...environment import Bodies, Controller, Evaluation
from ...errors import ConfigError
from ...sdk import BodyBatch, GymBodies, config_signature, report_progress
from ...torch_runtime import resolve_device
from .config import PPOConfig
from .evaluation import evaluate_policies
from .layout import Layout, inherit, layout_of
from .networks import ActorCritic, Stacked
from .policy_file import SavedPolicy, load_policy, readable_policy, save_policy
from .train import TrainResult, deterministic_torch, evaluation_generator, initial_networks, train

#: settings that change how fast a policy is trained, not what it becomes
RUNTIME_SETTINGS = ("device", "threads")


class PPO(Controller):
    """Evolution Gym 2.0's PPO, one policy per body: stable-baselines3's loss written out, TorchRL's GAE
    (parameters: every PPOConfig field).

    Parameters:
        timesteps: environment steps of training per body (Evolution Gym 2.0: 1e6; default 50,000)
        learning_rate: Adam's learning rate
        n_steps: steps per rollout
        batch_size: minibatch size
        n_epochs: passes over each rollout
        gamma: discount factor
        gae_lambda: GAE's lambda
        vf_coef: value loss weight
        ent_coef: entropy bonus weight
        clip_range: PPO's clip range
        max_grad_norm: gradient norm clip
        n_envs: environments stepped together
        eval_interval: timesteps between evaluations (default: timesteps / 10)
        n_evals: episodes per evaluation
        deterministic_eval: evaluate the policy's mean action instead of sampling
        episode_end: how an evaluation episode is scored: evogym2 (drops the last step's reward) or full
        hidden: sizes of the hidden layers of policy and value networks
        lr_schedule: constant (Evolution Gym 2.0) or linear (decays to 0 over the training, Evolution Gym 1.0)
        normalize_obs: normalise observations by running statistics per body (Evolution Gym 1.0)
        init: scratch (fresh networks, Evolution Gym's) or parent (a child starts from its nearest parent's trained
            policy, mapped by voxel; docs/controllers/ppo-inherit.md)
        device: cpu, cuda, cuda:N or auto
        threads: torch threads per training
    """

    #: a generation's bodies are learned together in lockstep (:func:`.train.train`); a body learns the same
    #: in any batch, so the batch size changes speed and memory, never results
    bodies_at_once = 32

    def __init__(self, **params: Any):
        try:
            self.config = PPOConfig(**params)
        except TypeError as exc:  # an unknown keyword
            raise ConfigError(f"ppo: {exc}") from None
        self.device = resolve_device(self.config.device, "ppo")
        #: children start from their parents' policies (the harness hands their work directories on)
        self.inherits = self.config.init == "parent"
        #: policies trained by this process, by work directory, so that a child reads its parent's without
        #: loading it (the files on disk are the same bytes)
        self._kept: dict[str, Inheritable] = {}

    def fingerprint(self, seed: int, parent: str | None = None) -> dict[str, Any]:
        """What determines the trained policy: a saved policy with the same fingerprint is reused.  With
        ``init=parent`` it names the parent it started from (its work directory's name, the body's hash)."""
        settings = {k: v for k, v in self.config.as_dict().items() if k not in RUNTIME_SETTINGS}
        if not self.inherits:
            del settings["init"]  # scratch policies keep the fingerprint they had before init existed
            return {"settings": settings, "seed": int(seed)}
        return {"settings": settings, "seed": int(seed), "parent": parent}

    evaluate = Controller.evaluate_alone

    def evaluate_bodies(
        self, bodies: Bodies, *, seeds: Sequence[int], workdirs: Sequence[Path | None]
    ) -> list[Evaluation | BaseException]:
        """Bodies with a policy saved by the same settings and seed replay it; the others train together,
        in lockstep (see :mod:`~gdabench.controllers.ppo.train`), each saving its best policy.  With
        ``init=parent`` a body starts from the first of its parents (``bodies.parents``) that left a policy
        trained with the same settings, mapped by voxel (:mod:`~gdabench.controllers.ppo.layout`)."""
        parents: list[tuple[Path, Inheritable] | None] = [None] * len(bodies)
        if self.inherits and bodies.parents is not None:
            parents = [self._parent(p) for p in bodies.parents]
        # parents unknown (a report replaying one body): any saved policy of these settings and seed is the body's
        known = bodies.parents is not None
        out: list[Evaluation | BaseException | None] = [
            self._saved(make_env, seed, workdir, _name(parent), known)
            for make_env, seed, workdir, parent in zip(bodies.make_envs, seeds, workdirs, parents)
        ]
        todo = [i for i, result in enumerate(out) if result is None]
        layouts: dict[int, Layout] = {}
        start: dict[int, ActorCritic] = {}
        for i in todo if self.inherits else ():
            try:
                layouts[i], fresh = self._fresh(bodies.make_envs[i], seeds[i])
                parent = parents[i]
                if parent is not None:
                    start[i] = inherit(fresh, layouts[i], parent[1].nets, parent[1].layout)
            except Exception as exc:  # noqa: BLE001 - this body's failure, not the batch's
                out[i] = exc
        todo = [i for i in todo if out[i] is None]
        for i, result in zip(todo, self._train(bodies, todo, seeds, start)):
            if isinstance(result, BaseException):
                out[i] = result
                continue
            workdir = workdirs[i]
            meta = self._meta(result, seeds[i], _name(parents[i]))
            if i in layouts:
                meta["layout"] = layouts[i].as_json()
            if workdir is not None:
                save_policy(workdir, result.nets, meta)
                if self.inherits:
                    self._keep(workdir, Inheritable(result.nets, layouts[i], meta["trained_with"]["settings"]))
            out[i] = Evaluation(result.reward, self._info(result, len(todo), i in start))
        return [r for r in out if r is not None]

    def _saved(
        self, make_env: Callable[[], Any], seed: int, workdir: Path | None, parent: str | None = None,
        parent_known: bool = True,
    ) -> Evaluation | BaseException | None:
        """The replayed score of a policy saved for these settings, seed (and parent, where known), or None."""
        if workdir is None or not readable_policy(workdir):
            return None
        try:
            saved = load_policy(workdir, self.device)
            trained_with, expected = dict(saved.meta.get("trained_with") or {}), self.fingerprint(seed, parent)
            if not parent_known:
                trained_with.pop("parent", None)
                expected.pop("parent", None)
            if trained_with != expected:
                return None
            if self.inherits and "layout" in saved.meta:
                self._keep(workdir, _inheritable(load_policy(workdir, "cpu")))
            return Evaluation(replay_policy(saved, make_env), {"replayed": 1})
        except Exception as exc:  # noqa: BLE001 - this body's failure, not the batch's
            return exc

    def _parent(self, workdirs: Sequence[Path]) -> tuple[Path, Inheritable] | None:
        """The first of ``workdirs`` holding a policy trained with these settings (in memory or on disk)."""
        settings = self.fingerprint(0)["settings"]
        for workdir in workdirs:
            kept = self._kept.get(str(workdir))
            if kept is None and readable_policy(workdir):
                saved = load_policy(workdir, "cpu")
                kept = _inheritable(saved) if "layout" in saved.meta else None
            if kept is not None and kept.settings == settings:
                return workdir, kept
        return None

    def _keep(self, workdir: Path, policy: Inheritable) -> None:
        """Remember a policy children may start from (the most recent :data:`KEPT_POLICIES`)."""
        self._kept[str(workdir)] = policy
        while len(self._kept) > KEPT_POLICIES:
            del self._kept[next(iter(self._kept))]

    def _fresh(self, make_env: Callable[[], Any], seed: int) -> tuple[Layout, ActorCritic]:
        """A body's layout and the networks it would start from scratch (what :func:`.train.train` makes)."""
        env = make_env()
        try:
            layout = layout_of(env)
            n_obs, n_act = box_dims(env)
        finally:
            env.close()
        # as train() makes them: its threads (orthogonal initialisation's QR rounds by thread count), its RNG kept
        with torch.random.fork_rng(devices=[]), deterministic_torch(self.config.threads):
            return layout, initial_networks(seed, n_obs, n_act, self.config.hidden)

    def _train(
        self, bodies: Bodies, indices: list[int], seeds: Sequence[int], start: dict[int, ActorCritic] | None = None
    ) -> list[TrainResult | BaseException]:
        """Train the bodies ``indices`` in one batch; if the batch fails, each alone, so that only a
        failing body's entry is an error."""
        if not indices:
            return []

        def batch(part: list[int]) -> Callable[[int], BodyBatch]:
            if bodies.make_batch is not None:
                return lambda n: bodies.make_batch(part, n)  # type: ignore[misc]
            return lambda n: GymBodies([bodies.make_envs[i] for i in part], n)

        def run(part: list[int]) -> list[TrainResult]:
            return train(
                self.config, batch(part), [seeds[i] for i in part], pad=bodies.pad, device=self.device,
                on_rollout=_progress_notes(len(part), self.config.rollouts * self.config.rollout_steps),
                initial=[start.get(i) for i in part] if start else None,
            )

        try:
            return list(run(indices))
        except Exception:
            if len(indices) == 1:
                raise
        out: list[TrainResult | BaseException] = []
        for i in indices:
            try:
                out += run([i])
            except Exception as exc:  # noqa: BLE001 - this body's failure, not the batch's
                out.append(exc)
        return out

    def _meta(self, result: TrainResult, seed: int, parent: str | None = None) -> dict[str, Any]:
        return {
            "trained_with": self.fingerprint(seed, parent),
            "reward": result.reward,
            "best_evaluation": result.best_index,
            "evaluations": [{"timesteps": e.timesteps, "scores": e.scores} for e in result.evaluations],
            "timesteps": result.timesteps,
            "unstable_episodes": result.unstable_episodes,
            "diverged": result.diverged,
            "padded": list(result.padded),
            "seconds": result.seconds,
        }

    def _info(self, result: TrainResult, batch: int, inherited: bool = False) -> dict[str, Any]:
        """Result columns; the batch's training time is shared equally among its bodies."""
        extra = {"ppo_inherited": int(inherited)} if self.inherits else {}
        return {
            **extra,
            "env_steps": result.timesteps,
            "ppo_best_at": result.best.timesteps,
            "ppo_unstable_episodes": result.unstable_episodes,
            "ppo_diverged": int(result.diverged),
            "ppo_batch": batch,
            "ppo_train_seconds": round((result.seconds["collect"] + result.seconds["update"]) / batch, 3),
            "ppo_eval_seconds": round(result.seconds["evaluate"] / batch, 3),
            "replayed": 0,
        }


@dataclass(frozen=True)
class Inheritable:
    """A trained policy a child may start from: its networks (on the CPU), its layout and its settings."""

    nets: ActorCritic
    layout: Layout
    settings: dict[str, Any]


#: trained policies a process keeps in memory for children (a few generations' worth; older ones are read back)
KEPT_POLICIES = 256


def _inheritable(saved: SavedPolicy) -> Inheritable:
    return Inheritable(saved.nets, Layout.from_json(saved.meta["layout"]), saved.meta["trained_with"]["settings"])


def _name(parent: tuple[Path, Inheritable] | None) -> str | None:
    """How a child's fingerprint names its parent: the parent's work directory's name (the body's hash)."""
    return None if parent is None else parent[0].name


def _progress_notes(bodies: int, timesteps: int) -> Callable[[int], None]:
    """A training's ``on_rollout``: its timesteps and speed for the progress display, every 2 s at most."""
    start = last = time.perf_counter()

    def note(steps: int) -> None:
        nonlocal last
        now = time.perf_counter()
        if now - last >= 2.0 or steps >= timesteps:
            last = now
            rate = bodies * steps / max(now - start, 1e-9)
            who = f"{bodies} bodies" if bodies > 1 else "1 body"
            report_progress(f"{steps:,}/{timesteps:,} timesteps, {rate:,.0f} env steps/s: {who} learning")

    return note


# the harness reads a factory's keyword parameters from its signature: expose PPOConfig's fields
PPO.__init__.__signature__ = config_signature(PPOConfig)  # type: ignore[attr-defined]


def replay_policy(saved: SavedPolicy, make_env: Callable[[], Any]) -> float:
    """Play the saved policy's winning evaluation again in environments from ``make_env``.

    Returns its mean score; it equals the reward the body was scored with as long as the
    environment has not changed.  Episodes pass through ``make_env``'s environments, so a
    recording wrapper there (``Environment.render_frames``) can draw them.
    """
    config = PPOConfig(**saved.meta["trained_with"]["settings"])
    seed = saved.meta["trained_with"]["seed"]
    device = next(saved.nets.parameters()).device
    with deterministic_torch(config.threads):
        n_obs, n_act = saved.meta["padded"]
        nets = Stacked([saved.nets], n_obs, n_act, device=device, normalize_obs=config.normalize_obs)
        [scores] = evaluate_policies(
            nets,
            lambda n: GymBodies([make_env], n),
            n_evals=config.n_evals,
            episode_end=config.episode_end,
            generators=[evaluation_generator(config, seed, saved.meta["best_evaluation"])],
        )
    return float(sum(scores) / len(scores))


def replay(workdir: Path, make_env: Callable[[], Any], device: str = "cpu") -> float:
    """Replay the policy saved in ``workdir`` (see :func:`replay_policy`); returns its score."""
    return replay_policy(load_policy(workdir, resolve_device(device, "ppo")), make_env)
