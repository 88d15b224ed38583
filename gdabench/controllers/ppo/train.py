"""PPO training of a batch of bodies in lockstep, each scored as Evolution Gym 2.0 scores it.

Every body has its own policy, critic, Adam state, gradient clipping, minibatch order and random
streams; what the bodies share is the loop, so that one array step simulates all of them and one
batched matrix product serves all their networks.  A single body is the batch of one.  The loop is
stable-baselines3's PPO (what Evolution Gym 2.0 runs):

1. play the stochastic policies for ``n_steps`` steps in each body's ``n_envs`` environments;
2. if this rollout passed a multiple of the evaluation interval, evaluate the policies that
   collected it (SB3's callback evaluates at that step, and a policy only changes after the rollout);
3. advantages and value targets by TorchRL's functional GAE (the value of the last observation
   bootstraps a time-limit truncation, as SB3 does);
4. ``n_epochs`` passes over each body's rollout in minibatches of ``batch_size``, in an order drawn
   from the body's own generator, each one lockstep step (:mod:`~gdabench.controllers.ppo.update`);
5. after the last rollout, evaluate the final policies too.

A body's reward is its best mean evaluation score, and the policy that reached it is kept.  A body
whose parameters stop being finite is put back to its last finite policy and trained no further.

What is hand-written and why: the rollout loop and minibatching (TorchRL's collector and replay
buffer hold one policy; here each body draws from its own streams), the loss
(:mod:`~gdabench.controllers.ppo.update`) and the stacked networks
(:mod:`~gdabench.controllers.ppo.networks`).  GAE is TorchRL's.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass
from typing import Callable, Iterator, Sequence

import numpy as np
import torch
from torchrl.objectives.value.functional import generalized_advantage_estimate

from ...sdk import BodyBatch
from ...torch_runtime import torch_threads
from .config import PPOConfig
from .evaluation import as_input, evaluate_policies
from .networks import ActorCritic, Stacked
from .update import LockstepUpdate, LossSettings, Minibatch

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
    """What one body's training produced: its best policy and how it got there."""

    nets: ActorCritic
    #: the padding its networks were trained with (observations, actions): replays pad the same way
    padded: tuple[int, int]
    best: Evaluated
    best_index: int
    evaluations: list[Evaluated]
    timesteps: int
    #: per rollout, the mean over its minibatch steps of [PPO loss, its value term]
    losses: list[list[float]]
    unstable_episodes: int
    diverged: bool
    #: wall-clock seconds per phase (PHASES) and in ``total``, of the whole batch
    seconds: dict[str, float]
    #: CPU seconds of this process per phase (the machine may be shared: wall time is not all ours)
    cpu_seconds: dict[str, float]

    @property
    def reward(self) -> float:
        return self.best.mean


@contextlib.contextmanager
def deterministic_torch(threads: int) -> Iterator[None]:
    """Pin threads and deterministic kernels, restoring both after."""
    previous = torch.are_deterministic_algorithms_enabled(), torch.is_deterministic_algorithms_warn_only_enabled()
    with torch_threads(threads):
        torch.use_deterministic_algorithms(True, warn_only=True)
        try:
            yield
        finally:
            torch.use_deterministic_algorithms(previous[0], warn_only=previous[1])


def initial_networks(seed: int, n_obs: int, n_act: int, hidden: Sequence[int]) -> ActorCritic:
    """A body's networks as SB3 initialises them, from torch's global RNG seeded with ``seed``."""
    torch.manual_seed(seed)
    return ActorCritic(n_obs, n_act, hidden)


def streams(seed: int) -> tuple[torch.Generator, torch.Generator]:
    """A body's action sampler and minibatch order: independent generators derived from its seed."""
    sampling, order = np.random.SeedSequence(seed).generate_state(2, dtype=np.uint64)
    return torch.Generator().manual_seed(int(sampling)), torch.Generator().manual_seed(int(order))


def evaluation_generator(config: PPOConfig, seed: int, index: int) -> torch.Generator | None:
    """The action sampler of a body's evaluation ``index`` (None: deterministic evaluation)."""
    if config.deterministic_eval:
        return None
    return torch.Generator().manual_seed(seed * 1_000_003 + index)


def loss_settings(config: PPOConfig) -> LossSettings:
    return LossSettings(
        clip_range=config.clip_range,
        vf_coef=config.vf_coef,
        ent_coef=config.ent_coef,
        learning_rate=config.learning_rate,
        max_grad_norm=config.max_grad_norm,
    )


class _Best:
    """Each body's evaluations and the parameters of its best one."""

    def __init__(self, nets: Stacked):
        self.nets = nets
        self.evaluations: list[list[Evaluated]] = [[] for _ in range(nets.n_bodies)]
        self.index = [-1] * nets.n_bodies
        self.params = nets.snapshot()

    def add(self, timesteps: int, scores: list[list[float]]) -> None:
        improved = torch.zeros(self.nets.n_bodies, dtype=torch.bool, device=self.nets.log_std.device)
        for b, body_scores in enumerate(scores):
            history = self.evaluations[b]
            history.append(Evaluated(timesteps, body_scores))
            if self.index[b] < 0 or history[-1].mean > history[self.index[b]].mean:
                self.index[b] = len(history) - 1
                improved[b] = True
        with torch.no_grad():
            for saved, p in zip(self.params, self.nets.state):
                saved[improved] = p[improved]


def train(
    config: PPOConfig,
    make_batch: Callable[[int], BodyBatch],
    seeds: Sequence[int],
    *,
    pad: tuple[int, int] | None = None,
    device: torch.device | str = "cpu",
    on_rollout: Callable[[int], None] | None = None,
    initial: Sequence[ActorCritic | None] | None = None,
) -> list[TrainResult]:
    """Train PPO on the bodies of ``make_batch`` (body ``b`` from ``seeds[b]``); see the module docstring.

    ``make_batch(e)`` builds fresh environments, ``e`` per body.  ``pad`` (observations, actions) pads
    the networks beyond the batch's widest body, so that a body learns the same in any batch padded
    alike.  ``on_rollout(timesteps)`` is called after every rollout with each body's timesteps so far.
    ``initial[b]``, when given and not None, is body ``b``'s networks to start from instead of fresh ones
    (an inherited policy, :func:`~gdabench.controllers.ppo.layout.inherit`).
    """
    start = time.perf_counter()
    device = torch.device(device)
    clock = PhaseClock()
    # torch's global RNG is used only by network initialisation (seeded per body): the caller's is kept
    with torch.random.fork_rng(devices=[]), deterministic_torch(config.threads):
        batch = make_batch(config.n_envs)
        try:
            batch.seed(seeds)
            n_obs, n_act = pad or (max(batch.obs_sizes), max(batch.act_sizes))
            sizes = zip(seeds, batch.obs_sizes, batch.act_sizes)
            given = list(initial) if initial is not None else [None] * len(seeds)
            init = [
                g if g is not None else initial_networks(s, o, a, config.hidden) for g, (s, o, a) in zip(given, sizes)
            ]
            widest = max(n_obs, *batch.obs_sizes), max(n_act, *batch.act_sizes)
            nets = Stacked(init, *widest, device=device, normalize_obs=config.normalize_obs)
            run = _Training(config, nets, batch, seeds, clock, on_rollout)
            run.loop(make_batch)
        finally:
            batch.close()
        seconds = {**clock.wall, "total": time.perf_counter() - start}
        return [
            TrainResult(
                nets=nets.body(b, run.best.params),
                padded=(nets.n_obs, nets.n_act),
                best=run.best.evaluations[b][run.best.index[b]],
                best_index=run.best.index[b],
                evaluations=run.best.evaluations[b],
                timesteps=run.steps,
                losses=[row[b] for row in run.losses],
                unstable_episodes=int(run.unstable[b]),
                diverged=bool(run.diverged[b]),
                seconds=seconds,
                cpu_seconds=dict(clock.cpu),
            )
            for b in range(nets.n_bodies)
        ]


class _Training:
    """The state of one lockstep training (see :func:`train`)."""

    def __init__(
        self,
        config: PPOConfig,
        nets: Stacked,
        batch: BodyBatch,
        seeds: Sequence[int],
        clock: PhaseClock,
        on_rollout: Callable[[int], None] | None,
    ):
        self.config, self.nets, self.batch, self.seeds, self.clock = config, nets, batch, list(seeds), clock
        self.on_rollout = on_rollout
        self.update = LockstepUpdate(nets, loss_settings(config))
        generators = [streams(s) for s in seeds]
        self.sampling = [g for g, _ in generators]
        self.order = [g for _, g in generators]
        self.best = _Best(nets)
        self.steps = 0
        self.losses: list[list[list[float]]] = []
        self.unstable = np.zeros(nets.n_bodies, dtype=np.int64)
        self.diverged = torch.zeros(nets.n_bodies, dtype=torch.bool, device=nets.log_std.device)

    def evaluate(self, make_batch: Callable[[int], BodyBatch]) -> None:
        index = len(self.best.evaluations[0])
        generators = [evaluation_generator(self.config, s, index) for s in self.seeds]
        with self.clock("evaluate"):
            scores = evaluate_policies(
                self.nets, make_batch, n_evals=self.config.n_evals, episode_end=self.config.episode_end,
                generators=generators,
            )
            self.best.add(self.steps, scores)

    def loop(self, make_batch: Callable[[int], BodyBatch]) -> None:
        config, interval = self.config, self.config.evaluation_interval
        obs = self.batch.reset()
        for rollout_index in range(config.rollouts):
            if config.lr_schedule == "linear":  # Evolution Gym 1.0: from the learning rate down to 0
                self.update.set_learning_rate(config.learning_rate * (1 - rollout_index / config.rollouts))
            with self.clock("collect"):
                rollout, obs = self.collect(obs)
            before, self.steps = self.steps, self.steps + config.rollout_steps
            if self.steps // interval > before // interval:
                self.evaluate(make_batch)
            with self.clock("update"):
                self.learn(rollout)
            if self.on_rollout is not None:
                self.on_rollout(self.steps)
            if self.diverged.all():
                break
        self.evaluate(make_batch)

    def collect(self, obs: np.ndarray) -> tuple[dict[str, torch.Tensor], np.ndarray]:
        """``n_steps`` steps of every environment; tensors ``(T, B, E, ...)``."""
        nets, T, E = self.nets, self.config.n_steps, self.config.n_envs
        per_body = np.repeat(np.arange(nets.n_bodies), E)
        keys = ("obs", "action", "log_prob", "reward", "next_obs", "done", "terminated")
        out: dict[str, list[torch.Tensor]] = {k: [] for k in keys}
        for _ in range(T):
            x = as_input(obs, nets, E, learn=True)
            action, log_prob = nets.act(x, self.sampling)
            step = self.batch.step(action.reshape(len(obs), -1).cpu().numpy().astype(np.float64))
            np.add.at(self.unstable, per_body[step.unstable], 1)
            for key, value in (
                ("obs", x), ("action", action), ("log_prob", log_prob),
                ("reward", torch.from_numpy(step.reward.astype(np.float32)).view(nets.n_bodies, E)),
                ("next_obs", as_input(step.next_obs, nets, E)),
                ("done", torch.from_numpy(step.done).view(nets.n_bodies, E)),
                ("terminated", torch.from_numpy(step.terminated).view(nets.n_bodies, E)),
            ):
                out[key].append(value)
            obs = step.obs
        return {k: torch.stack(v) for k, v in out.items()}, obs

    def learn(self, rollout: dict[str, torch.Tensor]) -> None:
        config, nets = self.config, self.nets
        B = nets.n_bodies
        T, _, E = rollout["reward"].shape
        device = nets.log_std.device

        def per_body(t: torch.Tensor) -> torch.Tensor:  # (T, B, E, ...) -> (B, E * T, ...), env-major
            return t.transpose(0, 1).transpose(1, 2).reshape(B, E * T, *t.shape[3:]).to(device)

        obs, next_obs = per_body(rollout["obs"]), per_body(rollout["next_obs"])
        with torch.no_grad():
            value, next_value = nets.value(obs), nets.value(next_obs)

            def trajectories(t: torch.Tensor) -> torch.Tensor:  # (B, E * T) -> (B * E, T, 1) for GAE
                return t.reshape(B * E, T, 1)

            advantage, _ = generalized_advantage_estimate(
                config.gamma, config.gae_lambda, trajectories(value), trajectories(next_value),
                trajectories(per_body(rollout["reward"])), trajectories(per_body(rollout["done"])),
                trajectories(per_body(rollout["terminated"])),
            )
            advantage = advantage.reshape(B, E * T)
        actions, log_probs = per_body(rollout["action"]), per_body(rollout["log_prob"])
        samples = Minibatch(obs, actions, log_probs, advantage, advantage + value)
        last_finite = nets.snapshot()
        rows = torch.arange(B, device=device).unsqueeze(1)
        total = torch.zeros(B, 2, device=device)
        count = 0
        for _ in range(config.n_epochs):
            order = torch.stack([torch.randperm(E * T, generator=g) for g in self.order]).to(device)
            for chunk in order.split(config.batch_size, dim=1):
                parts = (getattr(samples, f)[rows, chunk] for f in Minibatch.__dataclass_fields__)
                total += self.update(Minibatch(*parts))
                count += 1
                if self.diverged.any():  # frozen bodies stay where they diverged
                    nets.restore(last_finite, self.diverged)
        self.losses.append((total / count).tolist())
        broken = ~nets.finite() & ~self.diverged
        if broken.any():
            nets.restore(last_finite, broken)  # the last finite policy gets the remaining evaluations
            self.diverged |= broken
