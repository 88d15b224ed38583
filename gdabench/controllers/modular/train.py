"""PPO on a generation's pooled experience: one :class:`~.policy.SharedPolicy` learns every body at once.

The loop is :mod:`gdabench.controllers.ppo.train`'s (stable-baselines3's PPO, Evolution Gym 2.0's settings) with
one network instead of one per body: every body's ``n_envs`` environments step together on the lockstep engine;
GAE per environment (TorchRL's); then ``n_epochs`` passes over the pooled rollout in minibatches of
``batch_size`` samples *per body* (so a generation makes as many Adam steps per rollout as one body's PPO),
advantages normalised over the minibatch, one gradient-norm clip, one Adam.  Every body's ``timesteps`` are
spent, so the generation's env steps equal per-body ``ppo``'s.  Each body is evaluated with the shared policy
at the same moments as ``ppo`` evaluates; its reward is its best mean evaluation score.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
import torch
from torchrl.objectives.value.functional import generalized_advantage_estimate

from ...sdk import BodyBatch
from ..ppo.config import PPOConfig
from ..ppo.evaluation import as_input, evaluate_policies
from ..ppo.train import Evaluated, deterministic_torch, evaluation_generator, streams
from ..ppo.update import ADAM_BETAS, ADAM_EPS, ADVANTAGE_EPS
from .observation import ModularView
from .policy import SharedBatch, SharedPolicy


@dataclass
class PooledResult:
    """What a pooled training produced: per body its evaluations and best one; the policy at each evaluation."""

    evaluations: list[list[Evaluated]]
    best_index: list[int]
    #: the shared policy's state at each evaluation (a body's best policy is ``states[best_index[b]]``)
    states: list[dict[str, torch.Tensor]]
    final: SharedPolicy
    timesteps: int

    def reward(self, b: int) -> float:
        return self.evaluations[b][self.best_index[b]].mean


def train_pooled(
    config: PPOConfig,
    policy: SharedPolicy,
    make_batch: Callable[[int], BodyBatch],
    views: Sequence[ModularView],
    seeds: Sequence[int],
    seed: int,
) -> PooledResult:
    """Train ``policy`` (changed in place) on the bodies of ``make_batch``; body ``b`` seeds its environments
    and action noise from ``seeds[b]``, the minibatch order comes from ``seed``."""
    with torch.random.fork_rng(devices=[]), deterministic_torch(config.threads):
        batch = make_batch(config.n_envs)
        try:
            batch.seed(seeds)
            obs = batch.reset()
            nets = SharedBatch(policy, views, obs.shape[1])  # the batch's width: padded as the environment pads
            optimizer = torch.optim.Adam(policy.parameters(), lr=config.learning_rate, betas=ADAM_BETAS, eps=ADAM_EPS)
            sampling = [streams(s)[0] for s in seeds]
            order = torch.Generator().manual_seed(int(seed))
            result = PooledResult([[] for _ in seeds], [-1] * len(seeds), [], policy, 0)
            interval, steps = config.evaluation_interval, 0
            for rollout_index in range(config.rollouts):
                if config.lr_schedule == "linear":
                    for group in optimizer.param_groups:
                        group["lr"] = config.learning_rate * (1 - rollout_index / config.rollouts)
                rollout, obs = _collect(config, nets, batch, obs, sampling)
                before, steps = steps, steps + config.rollout_steps
                if steps // interval > before // interval:
                    _evaluate(config, nets, make_batch, seeds, steps, result)
                _learn(config, nets, optimizer, rollout, order)
            _evaluate(config, nets, make_batch, seeds, steps, result)
            result.timesteps = steps
            return result
        finally:
            batch.close()


def _collect(
    config: PPOConfig, nets: SharedBatch, batch: BodyBatch, obs: np.ndarray, sampling: list[torch.Generator]
) -> tuple[dict[str, torch.Tensor], np.ndarray]:
    B, E = nets.n_bodies, config.n_envs
    out: dict[str, list[torch.Tensor]] = {
        k: [] for k in ("obs", "action", "log_prob", "reward", "next_obs", "done", "terminated")
    }
    for _ in range(config.n_steps):
        x = as_input(obs, nets, E)  # type: ignore[arg-type]
        action, log_prob = nets.act(x, sampling)
        step = batch.step(action.reshape(len(obs), -1).numpy().astype(np.float64))
        for key, value in (
            ("obs", x),
            ("action", action),
            ("log_prob", log_prob),
            ("reward", torch.from_numpy(step.reward.astype(np.float32)).view(B, E)),
            ("next_obs", as_input(step.next_obs, nets, E)),  # type: ignore[arg-type]
            ("done", torch.from_numpy(step.done).view(B, E)),
            ("terminated", torch.from_numpy(step.terminated).view(B, E)),
        ):
            out[key].append(value)
        obs = step.obs
    return {k: torch.stack(v) for k, v in out.items()}, obs


def _learn(
    config: PPOConfig,
    nets: SharedBatch,
    optimizer: torch.optim.Optimizer,
    rollout: dict[str, torch.Tensor],
    order: torch.Generator,
) -> None:
    B = nets.n_bodies
    T, _, E = rollout["reward"].shape

    def per_body(t: torch.Tensor) -> torch.Tensor:  # (T, B, E, ...) -> (B, E * T, ...), env-major
        return t.transpose(0, 1).transpose(1, 2).reshape(B, E * T, *t.shape[3:])

    obs, next_obs = per_body(rollout["obs"]), per_body(rollout["next_obs"])
    with torch.no_grad():
        value, next_value = nets.value(obs), nets.value(next_obs)

        def trajectories(t: torch.Tensor) -> torch.Tensor:
            return t.reshape(B * E, T, 1)

        advantage, _ = generalized_advantage_estimate(
            config.gamma,
            config.gae_lambda,
            trajectories(value),
            trajectories(next_value),
            trajectories(per_body(rollout["reward"])),
            trajectories(per_body(rollout["done"])),
            trajectories(per_body(rollout["terminated"])),
        )
        advantage = advantage.reshape(B, E * T)
    returns = advantage + value
    actions, old_log_prob = per_body(rollout["action"]), per_body(rollout["log_prob"])
    rows = torch.arange(B).unsqueeze(1)
    for _ in range(config.n_epochs):
        permutation = torch.stack([torch.randperm(E * T, generator=order) for _ in range(B)])
        for chunk in permutation.split(config.batch_size, dim=1):
            adv = advantage[rows, chunk]
            if adv.numel() > 1:
                adv = (adv - adv.mean()) / (adv.std() + ADVANTAGE_EPS)
            o = obs[rows, chunk]
            ratio = torch.exp(nets.log_prob(actions[rows, chunk], nets.mean(o)) - old_log_prob[rows, chunk])
            clipped = torch.clamp(ratio, 1 - config.clip_range, 1 + config.clip_range)
            policy_loss = -torch.min(adv * ratio, adv * clipped).mean()
            value_loss = (returns[rows, chunk] - nets.value(o)).square().mean()
            loss = policy_loss - config.ent_coef * nets.entropy().mean() + config.vf_coef * value_loss
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(nets.policy.parameters(), config.max_grad_norm)
            optimizer.step()


def _evaluate(
    config: PPOConfig,
    nets: SharedBatch,
    make_batch: Callable[[int], BodyBatch],
    seeds: Sequence[int],
    steps: int,
    result: PooledResult,
) -> None:
    index = len(result.states)
    generators = [evaluation_generator(config, s, index) for s in seeds]
    with torch.no_grad():
        scores = evaluate_policies(
            nets,  # type: ignore[arg-type]
            make_batch,
            n_evals=config.n_evals,
            episode_end=config.episode_end,
            generators=generators,
        )
    result.states.append(copy.deepcopy(nets.policy.state_dict()))
    for b, body_scores in enumerate(scores):
        history = result.evaluations[b]
        history.append(Evaluated(steps, body_scores))
        if result.best_index[b] < 0 or history[-1].mean > history[result.best_index[b]].mean:
            result.best_index[b] = len(history) - 1
