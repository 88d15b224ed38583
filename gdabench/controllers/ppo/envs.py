"""The body's Gymnasium environments as one batched TorchRL environment.

``make_env`` (from the gdabench environment) builds a fresh Gymnasium env for the body;
:class:`BodyEnvs` holds ``n_envs`` of them (batch size ``[n_envs]``, stepped in turn in this
process) so that TorchRL's collector can play the policy in all of them at once.  It does what
SB3's PPO does around its vectorised env: actions from the unbounded Gaussian are clipped to
the action space (the actuator range [0.6, 1.6] on Walker-v0) on their way in, observations
become float32 (the networks' dtype), an env whose episode ended is reset at once, and a
time-limit truncation stays distinguishable from a termination, so that GAE bootstraps the
former.  It also counts episodes that ended because the simulation became unstable: the
environment scores those itself (Walker-v0: -3 and done), training goes on, and the count is
reported.

Why not TorchRL's ``GymWrapper`` and ``SerialEnv``: they work, but their generic per-step
bookkeeping costs more than the simulator's physics (GymWrapper about 0.15 ms a step;
SerialEnv of two envs about 0.3 ms per batched step more than this class, measured).
"""

from __future__ import annotations

from typing import Any, Callable, Sequence, cast

import gymnasium
import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Categorical, Composite, Unbounded
from torchrl.envs import EnvBase

#: the key a gdabench physics environment puts in ``info`` when its simulation became unstable
UNSTABLE_INFO_KEY = "unstable"
DONE_KEYS = ("done", "terminated", "truncated")


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


def clip_action(env: gymnasium.Env, action: np.ndarray) -> np.ndarray:
    """The action clipped into the env's Box action space."""
    space = cast(gymnasium.spaces.Box, env.action_space)  # box_dims checked it
    return np.clip(action, space.low, space.high)


class BodyEnvs(EnvBase):
    """``n`` Gymnasium envs of the body as one TorchRL env of batch size ``[n]`` (see the module docstring)."""

    def __init__(self, make_env: Callable[[], gymnasium.Env], n: int):
        super().__init__(batch_size=torch.Size([n]))
        self.gym_envs: list[gymnasium.Env] = []
        try:
            for _ in range(n):
                self.gym_envs.append(make_env())
        except BaseException:
            self.close_gym_envs()
            raise
        n_obs, n_act = box_dims(self.gym_envs[0])
        space = cast(gymnasium.spaces.Box, self.gym_envs[0].action_space)  # box_dims checked it
        self._low, self._high = space.low, space.high
        self.observation_spec = Composite(observation=Unbounded((n, n_obs), dtype=torch.float32), shape=(n,))
        self.action_spec = Unbounded((n, n_act), dtype=torch.float32)
        self.reward_spec = Unbounded((n, 1), dtype=torch.float32)
        flag = Categorical(2, (n, 1), dtype=torch.bool)
        self.done_spec = Composite(done=flag, terminated=flag.clone(), truncated=flag.clone(), shape=(n,))
        self.unstable_episodes = 0
        self._seeds: list[int | None] = [None] * n

    def _reset_one(self, i: int) -> np.ndarray:
        obs, _ = self.gym_envs[i].reset(seed=self._seeds[i])
        self._seeds[i] = None  # seed the first episode only, as Gymnasium intends
        return obs

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs: Any) -> TensorDictBase:
        """Resets every env, or those flagged in ``tensordict["_reset"]`` (TorchRL's partial
        reset; the other envs keep the observation and flags ``tensordict`` holds, if any)."""
        n = len(self.gym_envs)
        mask = None if tensordict is None else tensordict.get("_reset", None)
        flags = [True] * n if mask is None else mask.reshape(-1).tolist()
        kept = tensordict is not None and mask is not None and "observation" in tensordict.keys()
        previous = cast(TensorDictBase, tensordict)  # read only when kept
        n_obs = self.observation_spec["observation"].shape[-1]
        out = TensorDict(
            {
                "observation": previous.get("observation").clone() if kept else torch.zeros(n, n_obs),
                **{
                    key: previous.get(key).clone() if kept else torch.zeros(n, 1, dtype=torch.bool)
                    for key in DONE_KEYS
                },
            },
            batch_size=(n,),
        )
        for i in (i for i, flag in enumerate(flags) if flag):
            out.get("observation")[i] = torch.from_numpy(np.asarray(self._reset_one(i), dtype=np.float32))
            for key in DONE_KEYS:
                out.get(key)[i] = False
        return out

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        actions = tensordict.get("action").numpy(force=True)
        observations, rewards, terminated, truncated = [], [], [], []
        for env, action in zip(self.gym_envs, np.clip(actions, self._low, self._high)):
            obs, reward, term, trunc, info = env.step(action)
            if UNSTABLE_INFO_KEY in info:
                self.unstable_episodes += 1
            observations.append(obs)
            rewards.append(float(reward))
            terminated.append(bool(term))
            truncated.append(bool(trunc))
        n = len(self.gym_envs)
        ended, cut = torch.tensor(terminated).view(n, 1), torch.tensor(truncated).view(n, 1)
        return TensorDict(
            {
                "observation": _float32(observations),
                "reward": torch.tensor(rewards, dtype=torch.float32).view(n, 1),
                "done": ended | cut,
                "terminated": ended,
                "truncated": cut,
            },
            batch_size=(n,),
        )

    def step_and_maybe_reset(self, tensordict: TensorDictBase) -> tuple[TensorDictBase, TensorDictBase]:
        """What :meth:`EnvBase.step_and_maybe_reset` returns, for this env's fixed keys only.

        The collector calls this once per step; the generic version spends more time on key
        bookkeeping than the simulator spends on physics (a test checks that both agree).
        Returns ``tensordict`` with the step's result under ``"next"``, and the input of the
        next step: that result without the reward, where envs whose episode ended are reset
        (their first observation, done flags cleared)."""
        result = self._step(tensordict)
        tensordict.set("next", result)
        done = result.get("done").reshape(-1)
        if not done.any():
            return tensordict, result.exclude("reward")
        following = self._reset(result.exclude("reward").set("_reset", done))
        return tensordict, following

    def _set_seed(self, seed: int | None) -> None:
        """Env ``i`` plays its first episode from ``seed + i`` (as SB3 seeds a vectorised env)."""
        self._seeds = [None if seed is None else seed + i for i in range(len(self.gym_envs))]

    def close_gym_envs(self) -> None:
        for env in self.gym_envs:
            env.close()
        self.gym_envs = []

    def close(self, *, raise_if_closed: bool = True) -> None:
        self.close_gym_envs()
        super().close(raise_if_closed=raise_if_closed)


def _float32(observations: Sequence[np.ndarray]) -> torch.Tensor:
    return torch.from_numpy(np.stack(observations).astype(np.float32, copy=False))
