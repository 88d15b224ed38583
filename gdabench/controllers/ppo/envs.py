"""The body's Gymnasium environment as a TorchRL environment.

``make_env`` (from the gdabench environment) builds a fresh Gymnasium env for the body;
:class:`BodyEnv` lets TorchRL's collector step it.  It does what SB3's PPO does around the
env: actions from the unbounded Gaussian are clipped to the action space (the actuator range
[0.6, 1.6] on Walker-v0) on their way in, observations become float32 (the networks' dtype),
and a time-limit truncation stays distinguishable from a termination, so that GAE bootstraps
the former.  It also counts episodes that ended because the simulation became unstable: the
environment scores those itself (Walker-v0: -3 and done), training goes on, and the count is
reported.

TorchRL's generic ``GymWrapper`` works too, but its per-step bookkeeping cost about 0.15 ms a
step here, a sixth of a whole training step; this adapter does only what PPO needs.
"""

from __future__ import annotations

from typing import Any, Callable

import gymnasium
import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Categorical, Composite, Unbounded
from torchrl.envs import EnvBase, SerialEnv

#: the key a gdabench physics environment puts in ``info`` when its simulation became unstable
UNSTABLE_INFO_KEY = "unstable"


def box_dims(env: gymnasium.Env) -> tuple[int, int]:
    """(observation size, action size) of an env with flat Box spaces, or a one-line error."""
    obs, act = env.observation_space, env.action_space
    if not (isinstance(obs, gymnasium.spaces.Box) and isinstance(act, gymnasium.spaces.Box) and len(obs.shape) == 1 and len(act.shape) == 1):
        raise TypeError(f"ppo needs flat Box observation and action spaces, got {obs} and {act}")
    return int(obs.shape[0]), int(act.shape[0])


def clip_action(env: gymnasium.Env, action: np.ndarray) -> np.ndarray:
    """The action clipped into the env's Box action space."""
    return np.clip(action, env.action_space.low, env.action_space.high)


class BodyEnv(EnvBase):
    """One Gymnasium env for the body, stepped by TorchRL (see the module docstring)."""

    def __init__(self, env: gymnasium.Env):
        super().__init__(batch_size=torch.Size([]))
        self.gym_env = env
        n_obs, n_act = box_dims(env)
        self.observation_spec = Composite(observation=Unbounded((n_obs,), dtype=torch.float32))
        self.action_spec = Unbounded((n_act,), dtype=torch.float32)
        self.reward_spec = Unbounded((1,), dtype=torch.float32)
        flag = Categorical(2, (1,), dtype=torch.bool)
        self.done_spec = Composite(done=flag, terminated=flag.clone(), truncated=flag.clone())
        self.unstable_episodes = 0
        self._seed: int | None = None

    def _observation(self, obs: np.ndarray) -> torch.Tensor:
        return torch.as_tensor(np.asarray(obs, dtype=np.float32))

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs: Any) -> TensorDictBase:
        obs, _ = self.gym_env.reset(seed=self._seed)
        self._seed = None  # seed the first episode only, as Gymnasium intends
        no = torch.zeros(1, dtype=torch.bool)
        return TensorDict({"observation": self._observation(obs), "done": no, "terminated": no.clone(), "truncated": no.clone()})

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        action = clip_action(self.gym_env, tensordict["action"].detach().cpu().numpy())
        obs, reward, terminated, truncated, info = self.gym_env.step(action)
        if UNSTABLE_INFO_KEY in info:
            self.unstable_episodes += 1
        terminated, truncated = bool(terminated), bool(truncated)
        return TensorDict(
            {
                "observation": self._observation(obs),
                "reward": torch.tensor([reward], dtype=torch.float32),
                "done": torch.tensor([terminated or truncated]),
                "terminated": torch.tensor([terminated]),
                "truncated": torch.tensor([truncated]),
            }
        )

    def _set_seed(self, seed: int | None) -> None:
        self._seed = seed

    def close(self, *, raise_if_closed: bool = True) -> None:
        self.gym_env.close()
        super().close(raise_if_closed=raise_if_closed)


class TrainingEnvs:
    """``n`` copies of the body's environment as one TorchRL env (a SerialEnv when n > 1)."""

    def __init__(self, make_env: Callable[[], gymnasium.Env], n: int, *, seed: int):
        self.envs: list[BodyEnv] = []

        def make() -> BodyEnv:
            env = BodyEnv(make_env())
            self.envs.append(env)
            return env

        self.env: EnvBase = make() if n == 1 else SerialEnv(n, make)
        self.env.set_seed(seed)

    @property
    def unstable_episodes(self) -> int:
        return sum(env.unstable_episodes for env in self.envs)

    def close(self) -> None:
        if not self.env.is_closed:
            self.env.close()
