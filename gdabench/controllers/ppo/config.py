"""PPO settings: Evolution Gym 2.0's hyperparameters as defaults, checked once at configuration.

Evolution Gym 2.0 trains every body with stable-baselines3's PPO and these values
(``examples/ppo/args.py``): learning rate 2.5e-4, 128 steps per rollout, minibatches of 4,
4 epochs, gamma 0.99, GAE lambda 0.95, value coefficient 0.5, entropy coefficient 0.01, clip
0.1, gradient norm 0.5, one environment, 1e6 timesteps, one evaluation episode every 1e5
timesteps and at the end. The budget too is Evolution Gym's (:data:`DEFAULT_TIMESTEPS`): no smaller budget
ranked the thesis author's bodies as 1e6 does (docs/benchmarks/thesis-budget.md).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from ...errors import ConfigError

#: Evolution Gym 2.0's budget per body
FAITHFUL_TIMESTEPS = 1_000_000
#: the default budget per body: the smallest of 12,500, 50,000, 200,000 and 1e6 timesteps whose rewards rank a
#: sample of the thesis author's walker bodies as 1e6 does (the rule of docs/benchmarks/thesis-budget.md)
DEFAULT_TIMESTEPS = FAITHFUL_TIMESTEPS
#: Evolution Gym 2.0 evaluates every 1e5 of its 1e6 steps: ten evaluations per training
EVALUATIONS_PER_TRAINING = 10
#: the most of any count (timesteps, steps per rollout, ...): 1,000 times Evolution Gym's budget per body,
#: weeks of training; more is a typo that would run for ever
MAX_COUNT = 1_000_000_000
#: how an evaluation episode is scored (see :func:`gdabench.controllers.ppo.evaluation.episode_score`)
EPISODE_ENDS = ("evogym2", "full")
#: the learning rate over a training: constant (Evolution Gym 2.0) or decaying linearly to 0 (1.0)
LR_SCHEDULES = ("constant", "linear")
#: where a body's networks start: fresh (Evolution Gym, the thesis) or from its nearest parent's trained ones
INITS = ("scratch", "parent")


@dataclass(frozen=True)
class PPOConfig:
    """Every setting of one PPO training (names follow stable-baselines3's)."""

    timesteps: int = DEFAULT_TIMESTEPS
    learning_rate: float = 2.5e-4
    n_steps: int = 128
    batch_size: int = 4
    n_epochs: int = 4
    gamma: float = 0.99
    gae_lambda: float = 0.95
    vf_coef: float = 0.5
    ent_coef: float = 0.01
    clip_range: float = 0.1
    max_grad_norm: float = 0.5
    n_envs: int = 1
    #: timesteps between evaluations; None = timesteps / 10 (Evolution Gym 2.0: 1e5 of 1e6)
    eval_interval: int | None = None
    n_evals: int = 1
    deterministic_eval: bool = False
    episode_end: str = "evogym2"
    hidden: tuple[int, ...] = (64, 64)
    lr_schedule: str = "constant"
    normalize_obs: bool = False
    #: scratch (fresh networks per body, Evolution Gym's) or parent (a child starts from its nearest parent's
    #: trained policy, mapped by voxel: :mod:`~gdabench.controllers.ppo.layout`)
    init: str = "scratch"
    device: str = "cpu"
    threads: int = 1

    def __post_init__(self) -> None:
        for name in ("timesteps", "n_steps", "batch_size", "n_epochs", "n_envs", "n_evals", "threads"):
            object.__setattr__(self, name, _positive_int(name, getattr(self, name)))
        if self.eval_interval is not None:
            object.__setattr__(self, "eval_interval", _positive_int("eval_interval", self.eval_interval))
        for name in ("learning_rate", "gamma", "gae_lambda", "vf_coef", "ent_coef", "clip_range", "max_grad_norm"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ConfigError(f"ppo: {name} must be a number, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.learning_rate <= 0:
            raise ConfigError(f"ppo: learning_rate must be positive, got {self.learning_rate}")
        for name in ("gamma", "gae_lambda"):
            if not 0 <= getattr(self, name) <= 1:
                raise ConfigError(f"ppo: {name} must be within [0, 1], got {getattr(self, name)}")
        for name in ("vf_coef", "ent_coef"):
            if getattr(self, name) < 0:
                raise ConfigError(f"ppo: {name} must be non-negative, got {getattr(self, name)}")
        if not 0 < self.clip_range < 1:
            raise ConfigError(f"ppo: clip_range must be within (0, 1), got {self.clip_range}")
        if self.max_grad_norm <= 0:
            raise ConfigError(f"ppo: max_grad_norm must be positive, got {self.max_grad_norm}")
        if self.timesteps < self.rollout_steps:
            raise ConfigError(
                f"ppo: timesteps={self.timesteps} is less than one rollout (n_steps x n_envs = {self.rollout_steps}); "
                f"use at least {self.rollout_steps}"
            )
        if self.batch_size > self.rollout_steps:
            raise ConfigError(
                f"ppo: batch_size={self.batch_size} exceeds one rollout (n_steps x n_envs = {self.rollout_steps})"
            )
        if self.episode_end not in EPISODE_ENDS:
            raise ConfigError(f"ppo: episode_end must be one of {', '.join(EPISODE_ENDS)}, got {self.episode_end!r}")
        if self.lr_schedule not in LR_SCHEDULES:
            raise ConfigError(f"ppo: lr_schedule must be one of {', '.join(LR_SCHEDULES)}, got {self.lr_schedule!r}")
        if self.init not in INITS:
            raise ConfigError(f"ppo: init must be one of {', '.join(INITS)}, got {self.init!r}")
        if not isinstance(self.normalize_obs, bool):
            raise ConfigError(f"ppo: normalize_obs must be true or false, got {self.normalize_obs!r}")
        hidden = (self.hidden,) if isinstance(self.hidden, int) else tuple(self.hidden)
        if not hidden or any(isinstance(h, bool) or not isinstance(h, int) or h < 1 for h in hidden):
            raise ConfigError(f"ppo: hidden must be a list of positive layer widths, got {self.hidden!r}")
        object.__setattr__(self, "hidden", hidden)
        if not isinstance(self.device, str) or not self.device:
            raise ConfigError(f"ppo: device must be a name such as cpu or cuda, got {self.device!r}")

    @property
    def rollout_steps(self) -> int:
        """Environment steps collected between two updates (SB3's n_steps x n_envs)."""
        return self.n_steps * self.n_envs

    @property
    def rollouts(self) -> int:
        """Rollouts trained: like stable-baselines3, whole rollouts until ``timesteps`` is reached."""
        return math.ceil(self.timesteps / self.rollout_steps)

    @property
    def evaluation_interval(self) -> int:
        return self.eval_interval or max(1, self.timesteps // EVALUATIONS_PER_TRAINING)

    def as_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["hidden"] = list(self.hidden)
        return data


def _positive_int(name: str, value: Any) -> int:
    """``value`` as an int (``1e5`` from the command line is accepted) of at most :data:`MAX_COUNT`, or a
    one-line error."""
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or value != int(value)
        or value < 1
    ):
        raise ConfigError(f"ppo: {name} must be a positive integer, got {value!r}")
    if value > MAX_COUNT:
        raise ConfigError(f"ppo: {name} must be an integer from 1 to {MAX_COUNT:,}, got {float(value):g}")
    return int(value)
