"""Environments of several bodies x E environments each, stepped as one batch.

A controller that learns many bodies at once (``ppo`` trains a batch in lockstep) needs the simulation
as a :class:`BodyBatch`: environment ``i`` belongs to body ``i // envs_per_body``;
observations and actions are padded to the batch's widest; ``step`` clips actions into the action
space on their way in (stable-baselines3's convention: the Gaussian is unbounded), and an environment
whose episode ended is reset at once, its next observation the new episode's first.  A time-limit
truncation stays distinguishable from a termination, so that GAE bootstraps the former.

Two kinds:

* :class:`GymBodies`: Gymnasium environments, one per body and environment, stepped in turn (any
  environment with flat Box spaces: the pymunk walker, Evolution Gym, a plugin's);
* :class:`ArrayBodies`: an array simulator that steps every environment in one call (the voxel
  engine's :class:`~gdabench.envs.voxel.batch.TaskBatch`), with the episode's time limit and
  resets added here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol, Sequence, cast

import gymnasium
import numpy as np

#: the key a gdabench physics environment puts in ``info`` when its simulation became unstable
UNSTABLE_INFO_KEY = "unstable"
#: a safety net for Gymnasium environments without a time limit (Evolution Gym's episodes last 500 steps)
MAX_EPISODE_STEPS = 10_000


@dataclass(frozen=True)
class Transition:
    """One step of every environment of a batch (rows: environments)."""

    #: the observation the step reached (for an ended episode: its last one, which GAE bootstraps from)
    next_obs: np.ndarray
    reward: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    #: the episode ended because the simulation became unstable (the environment scored it)
    unstable: np.ndarray
    #: what the policy sees next: ``next_obs``, or a new episode's first observation where one ended
    obs: np.ndarray

    @property
    def done(self) -> np.ndarray:
        return self.terminated | self.truncated


class BodyBatch(Protocol):
    """Environments of several bodies, body-major, stepped together (see the module docstring)."""

    envs_per_body: int
    #: per body: its observation and action sizes (the rest of a padded row is zeros)
    obs_sizes: list[int]
    act_sizes: list[int]

    def seed(self, seeds: Sequence[int]) -> None:
        """Seed the first episodes, body ``b``'s from ``seeds[b]`` (training batches only)."""

    def reset(self) -> np.ndarray:
        """Every environment at the start of an episode; returns the observations ``(N, max obs)``."""

    def step(self, actions: np.ndarray) -> Transition:
        """Step every environment with ``(N, A)`` padded, unclipped actions (``A`` at least the widest body's)."""

    def close(self) -> None: ...


def box_dims(env: gymnasium.Env) -> tuple[int, int]:
    """(observation size, action size) of an env with flat Box spaces, or a one-line error."""
    obs, act = env.observation_space, env.action_space
    if not (
        isinstance(obs, gymnasium.spaces.Box)
        and isinstance(act, gymnasium.spaces.Box)
        and len(obs.shape) == 1
        and len(act.shape) == 1
    ):
        raise TypeError(f"ppo needs flat Box observation and action spaces, got {obs} and {act}")
    return int(obs.shape[0]), int(act.shape[0])


def _padded(rows: Sequence[np.ndarray], width: int) -> np.ndarray:
    out = np.zeros((len(rows), width))
    for i, row in enumerate(rows):
        out[i, : len(row)] = row
    return out


class GymBodies:
    """``envs_per_body`` Gymnasium environments of each body, from ``make_envs[b]()``."""

    def __init__(self, make_envs: Sequence[Callable[[], gymnasium.Env]], envs_per_body: int = 1):
        self.envs_per_body = envs_per_body
        self.envs: list[gymnasium.Env] = []
        try:
            for make_env in make_envs:
                self.envs += [make_env() for _ in range(envs_per_body)]
        except BaseException:
            self.close()
            raise
        dims = [box_dims(env) for env in self.envs[::envs_per_body]]
        self.obs_sizes = [o for o, _ in dims]
        self.act_sizes = [a for _, a in dims]
        spaces = [cast(gymnasium.spaces.Box, env.action_space) for env in self.envs]
        self._low = _padded([s.low for s in spaces], max(self.act_sizes))
        self._high = _padded([s.high for s in spaces], max(self.act_sizes))
        self._seeds: list[int | None] = [None] * len(self.envs)
        self._t = np.zeros(len(self.envs), dtype=np.int64)

    def seed(self, seeds: Sequence[int]) -> None:
        """Environment ``e`` of body ``b`` plays its first episode from ``seeds[b] + e`` (as SB3 seeds a
        vectorised env)."""
        self._seeds = [int(seeds[i // self.envs_per_body]) + i % self.envs_per_body for i in range(len(self.envs))]

    def _reset_one(self, i: int) -> np.ndarray:
        obs, _ = self.envs[i].reset(seed=self._seeds[i])
        self._seeds[i] = None  # seed the first episode only, as Gymnasium intends
        self._t[i] = 0
        return np.asarray(obs, dtype=np.float64)

    def reset(self) -> np.ndarray:
        return _padded([self._reset_one(i) for i in range(len(self.envs))], max(self.obs_sizes))

    def step(self, actions: np.ndarray) -> Transition:
        n = len(self.envs)
        clipped = np.clip(actions[:, : self._low.shape[1]], self._low, self._high)
        next_obs, obs = [], []
        reward, terminated, truncated, unstable = (np.zeros(n), np.zeros(n, bool), np.zeros(n, bool), np.zeros(n, bool))
        for i, env in enumerate(self.envs):
            o, r, term, trunc, info = env.step(clipped[i, : self.act_sizes[i // self.envs_per_body]])
            self._t[i] += 1
            trunc = bool(trunc) or (not term and self._t[i] >= MAX_EPISODE_STEPS)
            reward[i], terminated[i], truncated[i] = float(r), bool(term), trunc
            unstable[i] = UNSTABLE_INFO_KEY in info
            o = np.asarray(o, dtype=np.float64)
            next_obs.append(o)
            obs.append(self._reset_one(i) if term or trunc else o)
        width = max(self.obs_sizes)
        return Transition(_padded(next_obs, width), reward, terminated, truncated, unstable, _padded(obs, width))

    def close(self) -> None:
        for env in self.envs:
            env.close()
        self.envs = []


class ArraySimulator(Protocol):
    """What :class:`ArrayBodies` needs of an array simulator (see :class:`~gdabench.envs.voxel.batch.TaskBatch`)."""

    @property
    def done(self) -> np.ndarray: ...

    @property
    def obs_sizes(self) -> list[int]: ...

    @property
    def act_sizes(self) -> list[int]: ...

    @property
    def action_bounds(self) -> tuple[float, float]: ...

    def seed(self, seeds: Sequence[int | None]) -> None: ...

    def reset(self, mask: np.ndarray | None = None) -> np.ndarray: ...

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]: ...


class ArrayBodies:
    """An array simulator's environments with episodes: truncated after ``max_episode_steps`` steps
    and reset in the step they end."""

    def __init__(self, simulator: ArraySimulator, envs_per_body: int, max_episode_steps: int):
        self.simulator = simulator
        self.envs_per_body = envs_per_body
        self.obs_sizes, self.act_sizes = simulator.obs_sizes, simulator.act_sizes
        self.max_episode_steps = max_episode_steps
        self._t = np.zeros(len(simulator.done), dtype=np.int64)

    def seed(self, seeds: Sequence[int]) -> None:
        """Environment ``e`` of body ``b`` draws its tasks' set-ups from ``seeds[b] + e`` (as :class:`GymBodies`)."""
        n = self.envs_per_body
        self.simulator.seed([int(seeds[i // n]) + i % n for i in range(len(self._t))])

    def reset(self) -> np.ndarray:
        self._t[:] = 0
        return self.simulator.reset()

    def step(self, actions: np.ndarray) -> Transition:
        low, high = self.simulator.action_bounds
        next_obs, reward, terminated, unstable = self.simulator.step(np.clip(actions, low, high))
        self._t += 1
        truncated = ~terminated & (self._t >= self.max_episode_steps)
        ended = terminated | truncated
        obs = next_obs
        if ended.any():
            obs = np.where(ended[:, None], self.simulator.reset(ended), next_obs)
            self._t[ended] = 0
        return Transition(next_obs, reward, terminated, truncated, unstable, obs)

    def close(self) -> None:
        pass

