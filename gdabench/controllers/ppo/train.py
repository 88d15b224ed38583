"""PPO training of one body on TorchRL, scored as Evolution Gym 2.0 scores it.

The loop is stable-baselines3's PPO (what Evolution Gym 2.0 runs) on TorchRL parts:

1. a :class:`torchrl.collectors.Collector` plays the stochastic policy for ``n_steps`` steps in
   each of ``n_envs`` environments;
2. if this rollout passed a multiple of the evaluation interval, the policy that collected it
   is evaluated (SB3's callback evaluates at that step, and the policy only changes after the
   rollout, so this is the same policy);
3. :class:`torchrl.objectives.value.GAE` computes advantages and value targets (the value of
   the last observation bootstraps a time-limit truncation, as SB3 does);
4. ``n_epochs`` passes over the rollout in minibatches of ``batch_size`` drawn without
   replacement from a TorchRL replay buffer, each one ClipPPOLoss step
   (:mod:`~gdabench.controllers.ppo.update`);
5. after the last rollout the final policy is evaluated too.

The reward of the body is the best mean evaluation score, and the policy that reached it is
kept.  Every random draw comes from the seed: network initialisation and action sampling from
``torch.manual_seed`` inside a forked RNG state (the caller's RNG is untouched), minibatches
from their own ``torch.Generator``.
"""

from __future__ import annotations

import contextlib
import copy
import logging
import time
from dataclasses import dataclass
from typing import Any, Callable, Iterator

import torch
from torchrl.collectors import Collector
from torchrl.data import LazyTensorStorage, ReplayBuffer
from torchrl.data.replay_buffers import SamplerWithoutReplacement
from torchrl.objectives.value import GAE

from ...torch_runtime import torch_threads
from .config import PPOConfig
from .envs import BodyEnvs, box_dims
from .evaluation import evaluate_policy
from .networks import ActorCritic
from .update import BATCH_KEYS, LossSettings, MinibatchUpdate

# TorchRL logs every storage it initialises at INFO level: once per rollout buffer, per body
logging.getLogger("torchrl").setLevel(logging.WARNING)


PHASES = ("collect", "update", "evaluate")


class PhaseClock:
    """Accumulates wall-clock and CPU seconds per named phase."""

    def __init__(self) -> None:
        self.wall = dict.fromkeys(PHASES, 0.0)
        self.cpu = dict.fromkeys(PHASES, 0.0)

    @contextlib.contextmanager
    def __call__(self, phase: str) -> Iterator[None]:
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.wall[phase] += time.perf_counter() - wall
            self.cpu[phase] += time.process_time() - cpu


@dataclass
class Evaluated:
    """One evaluation during training."""

    timesteps: int
    scores: list[float]

    @property
    def mean(self) -> float:
        return float(sum(self.scores) / len(self.scores))


@dataclass
class TrainResult:
    """What a training produced: the best policy and how it got there."""

    nets: ActorCritic
    best: Evaluated
    best_index: int
    evaluations: list[Evaluated]
    timesteps: int
    #: per rollout, the mean over its minibatch steps of [PPO loss (ClipPPOLoss's objective +
    #: value + entropy terms), its value term]
    losses: list[list[float]]
    unstable_episodes: int
    diverged: bool
    compiled: bool
    #: wall-clock seconds per phase (PHASES), of the first minibatch step (``warmup``: compiling
    #: happens there) and in ``total``
    seconds: dict[str, float]
    #: CPU seconds of this process per phase (the machine may be shared: wall time is not all ours)
    cpu_seconds: dict[str, float]

    @property
    def reward(self) -> float:
        return self.best.mean


@contextlib.contextmanager
def seeded_torch(seed: int, threads: int) -> Iterator[None]:
    """Seed torch's global RNG and pin threads and deterministic kernels, restoring all after."""
    previous_deterministic = torch.are_deterministic_algorithms_enabled()
    previous_warn = torch.is_deterministic_algorithms_warn_only_enabled()
    with torch.random.fork_rng(devices=[]), torch_threads(threads):
        torch.manual_seed(seed)
        torch.use_deterministic_algorithms(True, warn_only=True)
        try:
            yield
        finally:
            torch.use_deterministic_algorithms(previous_deterministic, warn_only=previous_warn)


def evaluation_generator(config: PPOConfig, seed: int, index: int, device: torch.device) -> torch.Generator | None:
    """The action sampler of evaluation ``index`` (None: deterministic evaluation)."""
    if config.deterministic_eval:
        return None
    return torch.Generator(device=device).manual_seed(seed * 1_000_003 + index)


def loss_settings(config: PPOConfig) -> LossSettings:
    return LossSettings(
        clip_range=config.clip_range,
        vf_coef=config.vf_coef,
        ent_coef=config.ent_coef,
        learning_rate=config.learning_rate,
        max_grad_norm=config.max_grad_norm,
        hidden=config.hidden,
    )


def _dims(make_env: Callable[[], Any]) -> tuple[int, int]:
    env = make_env()
    try:
        return box_dims(env)
    finally:
        env.close()


def train(
    config: PPOConfig, make_env: Callable[[], Any], *, seed: int, device: torch.device, compiled: bool
) -> TrainResult:
    """Train PPO on the body behind ``make_env``; see the module docstring."""
    start = time.perf_counter()
    with seeded_torch(seed, config.threads):
        n_obs, n_act = _dims(make_env)
        nets = ActorCritic(n_obs, n_act, config.hidden).to(device)
        gae = GAE(gamma=config.gamma, lmbda=config.gae_lambda, value_network=nets.critic(), average_gae=False)
        update = MinibatchUpdate(nets, loss_settings(config), compiled=compiled)
        buffer = ReplayBuffer(
            storage=LazyTensorStorage(config.rollout_steps, device=device),
            sampler=SamplerWithoutReplacement(),
            generator=torch.Generator().manual_seed(seed),
            batch_size=config.rollout_steps,
        )
        envs = BodyEnvs(make_env, config.n_envs)
        envs.set_seed(seed)
        collector = Collector(
            envs,
            nets.sampler(),
            frames_per_batch=config.rollout_steps,
            total_frames=config.rollouts * config.rollout_steps,
            # on CPU no device at all: the collector then copies nothing between steps
            policy_device=None if device.type == "cpu" else device,
            env_device=None if device.type == "cpu" else "cpu",
            storing_device=None if device.type == "cpu" else device,
            auto_register_policy_transforms=False,  # the policy needs no transform
            track_traj_ids=False,  # PPO needs none (GAE reads the done flags)
        )
        evaluations: list[Evaluated] = []
        best_index, best_state = -1, None

        def evaluate(timesteps: int) -> None:
            nonlocal best_index, best_state
            generator = evaluation_generator(config, seed, len(evaluations), device)
            scores = evaluate_policy(
                nets,
                make_env,
                n_evals=config.n_evals,
                episode_end=config.episode_end,
                generator=generator,
                device=device,
            )
            evaluations.append(Evaluated(timesteps, scores))
            if best_index < 0 or evaluations[-1].mean > evaluations[best_index].mean:
                best_index, best_state = len(evaluations) - 1, copy.deepcopy(nets.state_dict())

        interval = config.evaluation_interval
        steps, diverged = 0, False
        losses: list[list[float]] = []
        clock = PhaseClock()
        rollouts = iter(collector)
        try:
            while True:
                with clock("collect"):
                    rollout = next(rollouts, None)
                if rollout is None:
                    break
                before, steps = steps, steps + rollout.numel()
                if steps // interval > before // interval:
                    with clock("evaluate"):
                        evaluate(steps)
                with clock("update"):
                    last_finite = copy.deepcopy(nets.state_dict())
                    with torch.no_grad():
                        gae(rollout)
                    buffer.empty()
                    buffer.extend(rollout.reshape(-1).select(*BATCH_KEYS))
                    total, count = torch.zeros(2, device=device), 0
                    for _ in range(config.n_epochs):
                        epoch = buffer.sample()  # the whole rollout in a random order
                        columns = [epoch[key].split(config.batch_size) for key in BATCH_KEYS]
                        for minibatch in zip(*columns):
                            total += update(*minibatch)
                            count += 1
                    losses.append((total / count).tolist())
                if not all(torch.isfinite(p).all() for p in nets.parameters()):
                    diverged = True  # the last finite policy gets its final evaluation
                    nets.load_state_dict(last_finite)
                    break
            with clock("evaluate"):
                evaluate(steps)
        finally:
            collector.shutdown()
            if not envs.is_closed:
                envs.close()
        assert best_state is not None, "the first evaluation sets it, and the last rollout is always evaluated"
        nets.load_state_dict(best_state)
    return TrainResult(
        nets=nets,
        best=evaluations[best_index],
        best_index=best_index,
        evaluations=evaluations,
        timesteps=steps,
        losses=losses,
        unstable_episodes=envs.unstable_episodes,
        diverged=diverged,
        compiled=compiled,
        seconds={**clock.wall, "warmup": update.first_seconds or 0.0, "total": time.perf_counter() - start},
        cpu_seconds=dict(clock.cpu),
    )

