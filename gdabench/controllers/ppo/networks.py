"""The actor-critic: stable-baselines3's default ``MlpPolicy`` rebuilt as TorchRL modules.

Like SB3's policy for a Box action space: two separate tanh MLPs (64, 64) for the policy and
the value, a linear action head giving the Gaussian's mean, a state-independent log standard
deviation initialised to 0, and orthogonal initialisation (gain sqrt(2) for hidden layers,
0.01 for the action head, 1 for the value head; zero biases).  The Gaussian is unbounded;
samples are clipped to the actuator range [0.6, 1.6] on their way into the environment, and
the unclipped sample is what PPO's ratio uses (SB3's convention).
"""

from __future__ import annotations

import math
from typing import Sequence

import torch
from tensordict.nn import TensorDictModule
from torch import nn
from torchrl.modules import ProbabilisticActor, ValueOperator
from torchrl.modules.distributions import IndependentNormal

OBSERVATION, LOC, SCALE = "observation", "loc", "scale"
ACTION, LOG_PROB = "action", "action_log_prob"
HALF_LOG_2PI = 0.5 * math.log(2 * math.pi)


def mlp(n_in: int, hidden: Sequence[int], n_out: int, out_gain: float) -> nn.Sequential:
    """tanh MLP with SB3's orthogonal initialisation."""
    layers: list[nn.Module] = []
    width = n_in
    for h in hidden:
        layers += [_orthogonal(nn.Linear(width, h), math.sqrt(2)), nn.Tanh()]
        width = h
    layers.append(_orthogonal(nn.Linear(width, n_out), out_gain))
    return nn.Sequential(*layers)


def _orthogonal(layer: nn.Linear, gain: float) -> nn.Linear:
    nn.init.orthogonal_(layer.weight, gain=gain)
    nn.init.zeros_(layer.bias)
    return layer


class GaussianHead(nn.Module):
    """Observation -> (mean, standard deviation) of a diagonal Gaussian over the actions."""

    def __init__(self, n_obs: int, n_act: int, hidden: Sequence[int]):
        super().__init__()
        self.mean = mlp(n_obs, hidden, n_act, out_gain=0.01)
        self.log_std = nn.Parameter(torch.zeros(n_act))

    def forward(self, observation: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        loc = self.mean(observation)
        return loc, self.log_std.exp().expand_as(loc)


class _GaussianSampler(nn.Module):
    """Draws an action from the head's Gaussian (torch's global RNG) and its log-probability."""

    def __init__(self, head: GaussianHead):
        super().__init__()
        self.head = head

    def forward(self, observation: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        loc = self.head.mean(observation)
        noise = torch.randn_like(loc)
        log_std = self.head.log_std
        log_prob = -(0.5 * noise.square() + log_std + HALF_LOG_2PI).sum(-1)
        return loc + log_std.exp() * noise, log_prob


class ActorCritic(nn.Module):
    """The trainable parameters of one body's controller (what is saved and reloaded)."""

    def __init__(self, n_obs: int, n_act: int, hidden: Sequence[int] = (64, 64)):
        super().__init__()
        self.n_obs, self.n_act, self.hidden = int(n_obs), int(n_act), tuple(int(h) for h in hidden)
        self.policy = GaussianHead(self.n_obs, self.n_act, self.hidden)
        self.value = mlp(self.n_obs, self.hidden, 1, out_gain=1.0)

    def dims(self) -> dict[str, object]:
        return {"n_obs": self.n_obs, "n_act": self.n_act, "hidden": list(self.hidden)}

    def actor(self) -> ProbabilisticActor:
        """The policy as a TorchRL actor: writes ``action`` and its ``action_log_prob``."""
        return ProbabilisticActor(
            TensorDictModule(self.policy, in_keys=[OBSERVATION], out_keys=[LOC, SCALE]),
            in_keys=[LOC, SCALE],
            distribution_class=IndependentNormal,
            return_log_prob=True,
        )

    def sampler(self) -> TensorDictModule:
        """The same stochastic policy for collecting rollouts, without building distribution
        objects: writes ``action`` and ``action_log_prob`` as :meth:`actor` would."""
        return TensorDictModule(_GaussianSampler(self.policy), in_keys=[OBSERVATION], out_keys=[ACTION, LOG_PROB])

    def critic(self) -> ValueOperator:
        """The value function as a TorchRL module: writes ``state_value``."""
        return ValueOperator(self.value, in_keys=[OBSERVATION])

    @torch.no_grad()
    def act(self, observation: torch.Tensor, generator: torch.Generator | None = None) -> torch.Tensor:
        """The mean action, or a sample when ``generator`` is given (evaluation episodes)."""
        loc, scale = self.policy(observation)
        if generator is None:
            return loc
        return loc + scale * torch.randn(loc.shape, generator=generator, device=loc.device, dtype=loc.dtype)
