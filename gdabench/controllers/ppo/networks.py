"""The actor-critic: stable-baselines3's default ``MlpPolicy``, one per body, stacked for a batch.

Like SB3's policy for a Box action space: two separate tanh MLPs (64, 64) for the policy and the
value, a linear action head giving the Gaussian's mean, a state-independent log standard deviation
initialised to 0, and orthogonal initialisation (gain sqrt(2) for hidden layers, 0.01 for the
action head, 1 for the value head; zero biases).  The Gaussian is unbounded; samples are clipped
to the actuator range on their way into the environment, and the unclipped sample is what PPO's
ratio uses (SB3's convention).

:class:`ActorCritic` is one body's networks: initialised from the body's seed, saved and reloaded.
:class:`Stacked` holds a batch's networks as tensors with a leading body axis, padded to the widest
observation and action (zero weights on padded inputs, padded actions masked out of every
log-probability and entropy, so their weights get no gradient and stay zero): one batched matrix
product per layer serves every body, and a body's numbers never mix with another's.
"""

from __future__ import annotations

import math
from typing import Sequence

import torch
from torch import nn

HALF_LOG_2PI = 0.5 * math.log(2 * math.pi)
#: observation normalisation as stable-baselines3's ``VecNormalize`` (Evolution Gym 1.0): clip, epsilon,
#: and the count its running statistics start from
OBS_CLIP, OBS_EPS, OBS_COUNT0 = 10.0, 1e-8, 1e-4
#: every body's slice of every stacked tensor starts on a 64-byte boundary (16 floats): the CPU's
#: matrix kernels round differently at other offsets, and a body's numbers would then depend on its
#: place in the batch
ALIGN = 16


def aligned(n: int) -> int:
    return -(-n // ALIGN) * ALIGN


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


class ActorCritic(nn.Module):
    """The trainable parameters of one body's controller (what is saved and reloaded)."""

    obs_mean: torch.Tensor
    obs_var: torch.Tensor
    obs_count: torch.Tensor

    def __init__(self, n_obs: int, n_act: int, hidden: Sequence[int] = (64, 64)):
        super().__init__()
        self.n_obs, self.n_act, self.hidden = int(n_obs), int(n_act), tuple(int(h) for h in hidden)
        self.mean = mlp(self.n_obs, self.hidden, self.n_act, out_gain=0.01)
        self.log_std = nn.Parameter(torch.zeros(self.n_act))
        self.value = mlp(self.n_obs, self.hidden, 1, out_gain=1.0)
        # running observation statistics (used only with normalize_obs; saved with the policy)
        self.register_buffer("obs_mean", torch.zeros(self.n_obs))
        self.register_buffer("obs_var", torch.ones(self.n_obs))
        self.register_buffer("obs_count", torch.tensor(OBS_COUNT0, dtype=torch.float64))

    def dims(self) -> dict[str, object]:
        return {"n_obs": self.n_obs, "n_act": self.n_act, "hidden": list(self.hidden)}


def _linears(net: nn.Sequential) -> list[nn.Linear]:
    return [m for m in net if isinstance(m, nn.Linear)]


class Stacked:
    """Networks of B bodies as stacked, padded tensors (see the module docstring); every width is
    rounded up to :data:`ALIGN`.

    ``params`` are leaf tensors (the optimiser's); each layer's weight is ``(B, in, out)``.
    """

    def __init__(
        self,
        nets: Sequence[ActorCritic],
        n_obs: int,
        n_act: int,
        device: torch.device | str = "cpu",
        normalize_obs: bool = False,
    ):
        hidden = nets[0].hidden
        if any(n.hidden != hidden for n in nets):
            raise ValueError("every body of a batch needs the same hidden layers")
        if any(n.n_obs > n_obs or n.n_act > n_act for n in nets):
            raise ValueError(f"a body is wider than the padding ({n_obs} observations, {n_act} actions)")
        n_obs, n_act = aligned(n_obs), aligned(n_act)
        self.hidden, self.n_obs, self.n_act = hidden, n_obs, n_act
        self.obs_sizes = [n.n_obs for n in nets]
        self.act_sizes = [n.n_act for n in nets]
        widths = [n_obs, *(aligned(h) for h in hidden)]
        self.mean_layers = self._stack([_linears(n.mean) for n in nets], widths, n_act, device)
        # the value is column 0; the others stay zero (no gradient reaches them)
        self.value_layers = self._stack([_linears(n.value) for n in nets], widths, ALIGN, device)
        self.log_std = torch.zeros(len(nets), n_act, device=device)
        self.act_mask = torch.zeros(len(nets), n_act, device=device)
        for b, net in enumerate(nets):
            self.log_std[b, : net.n_act] = net.log_std.detach()
            self.act_mask[b, : net.n_act] = 1.0
        self.log_std.requires_grad_(True)
        self.params = [p for layer in self.mean_layers + self.value_layers for p in layer] + [self.log_std]
        self.normalize_obs = normalize_obs
        self.obs_mean = torch.zeros(len(nets), n_obs, device=device)
        self.obs_var = torch.ones(len(nets), n_obs, device=device)
        self.obs_count = torch.tensor([float(n.obs_count) for n in nets], dtype=torch.float64, device=device)
        for b, net in enumerate(nets):
            self.obs_mean[b, : net.n_obs] = net.obs_mean
            self.obs_var[b, : net.n_obs] = net.obs_var
        #: what a snapshot holds: the parameters, then the observation statistics
        self.state = [*self.params, self.obs_mean, self.obs_var, self.obs_count]

    @staticmethod
    def _stack(
        per_body: list[list[nn.Linear]], widths: list[int], n_out: int, device: torch.device | str
    ) -> list[tuple[torch.Tensor, torch.Tensor]]:
        layers = []
        for i, (n_in, out) in enumerate(zip(widths, [*widths[1:], n_out])):
            weight = torch.zeros(len(per_body), n_in, out, device=device)
            bias = torch.zeros(len(per_body), out, device=device)
            for b, linears in enumerate(per_body):
                w = linears[i].weight.detach()
                weight[b, : w.shape[1], : w.shape[0]] = w.T  # padded inputs and outputs keep zero weights
                bias[b, : w.shape[0]] = linears[i].bias.detach()
            layers.append((weight.requires_grad_(True), bias.requires_grad_(True)))
        return layers

    @property
    def n_bodies(self) -> int:
        return len(self.obs_sizes)

    @staticmethod
    def _forward(layers: list[tuple[torch.Tensor, torch.Tensor]], x: torch.Tensor) -> torch.Tensor:
        for i, (weight, bias) in enumerate(layers):
            x = torch.baddbmm(bias.unsqueeze(1), x, weight)
            if i < len(layers) - 1:
                x = torch.tanh(x)
        return x

    @torch.no_grad()
    def observe(self, x: torch.Tensor, learn: bool = False) -> torch.Tensor:
        """Observations ``(B, n, O)`` as the networks take them: normalised per body when ``normalize_obs``,
        after folding them into the running statistics when ``learn`` (``VecNormalize``'s update: each
        body's ``n`` observations are one batch)."""
        if not self.normalize_obs:
            return x
        if learn:
            n = x.shape[1]
            batch_mean, batch_var = x.mean(1), x.var(1, unbiased=False)
            total = self.obs_count + n
            delta = batch_mean - self.obs_mean
            ratio = (n / total).float().unsqueeze(1)
            m2 = self.obs_var * (self.obs_count / total).float().unsqueeze(1) + batch_var * ratio
            self.obs_var.copy_(m2 + delta.square() * ratio * (self.obs_count / total).float().unsqueeze(1))
            self.obs_mean.add_(delta * ratio)
            self.obs_count.copy_(total)
        z = (x - self.obs_mean.unsqueeze(1)) / torch.sqrt(self.obs_var.unsqueeze(1) + OBS_EPS)
        return torch.clamp(z, -OBS_CLIP, OBS_CLIP)

    def mean(self, obs: torch.Tensor) -> torch.Tensor:
        """The Gaussian's mean ``(B, n, A)`` for observations ``(B, n, O)``."""
        return self._forward(self.mean_layers, obs)

    def value(self, obs: torch.Tensor) -> torch.Tensor:
        """State values ``(B, n)``."""
        return self._forward(self.value_layers, obs)[..., 0]

    def log_prob(self, actions: torch.Tensor, mean: torch.Tensor) -> torch.Tensor:
        """Log-probabilities ``(B, n)`` of ``actions`` under the Gaussians at ``mean``."""
        z = (actions - mean) * torch.exp(-self.log_std).unsqueeze(1)
        return -((0.5 * z.square() + self.log_std.unsqueeze(1) + HALF_LOG_2PI) * self.act_mask.unsqueeze(1)).sum(-1)

    def entropy(self) -> torch.Tensor:
        """Each body's Gaussian's entropy ``(B,)`` (state-independent)."""
        return ((0.5 + HALF_LOG_2PI + self.log_std) * self.act_mask).sum(-1)

    @torch.no_grad()
    def act(self, obs: torch.Tensor, generators: Sequence[torch.Generator | None]) -> tuple[torch.Tensor, torch.Tensor]:
        """Actions ``(B, n, A)`` for observations ``(B, n, O)`` and their log-probabilities ``(B, n)``.

        Body ``b`` samples from ``generators[b]`` (``n`` x its own action count per call, so its stream
        does not depend on the padding), or plays its mean where that is None.
        """
        mean = self.mean(obs)
        noise = torch.zeros(mean.shape, dtype=mean.dtype)  # drawn on the CPU: the same streams on any device
        for b, generator in enumerate(generators):
            if generator is not None:
                size = (mean.shape[1], self.act_sizes[b])
                noise[b, :, : self.act_sizes[b]] = torch.randn(size, generator=generator)
        noise = noise.to(mean.device)
        actions = torch.addcmul(mean, self.log_std.exp().unsqueeze(1), noise)
        log_prob = -((0.5 * noise.square() + self.log_std.unsqueeze(1) + HALF_LOG_2PI) * self.act_mask.unsqueeze(1))
        return actions, log_prob.sum(-1)

    def snapshot(self) -> list[torch.Tensor]:
        """A copy of every parameter and observation statistic (to restore bodies from, see :meth:`restore`)."""
        return [p.detach().clone() for p in self.state]

    @torch.no_grad()
    def restore(self, saved: list[torch.Tensor], bodies: torch.Tensor) -> None:
        """Put the parameters and statistics of ``bodies`` (a boolean mask) back to ``saved``."""
        for p, s in zip(self.state, saved):
            p[bodies] = s[bodies]

    @torch.no_grad()
    def finite(self) -> torch.Tensor:
        """Which bodies' parameters are all finite ``(B,)``."""
        return torch.stack([torch.isfinite(p).flatten(1).all(1) for p in self.params]).all(0)

    @torch.no_grad()
    def body(self, b: int, params: list[torch.Tensor] | None = None) -> ActorCritic:
        """Body ``b``'s networks unpadded (from ``params``, a :meth:`snapshot`, when given)."""
        values = params if params is not None else self.state
        net = ActorCritic(self.obs_sizes[b], self.act_sizes[b], self.hidden)
        n_layers = len(self.hidden) + 1
        for layers, offset in ((_linears(net.mean), 0), (_linears(net.value), 2 * n_layers)):
            for i, linear in enumerate(layers):
                weight, bias = values[offset + 2 * i][b], values[offset + 2 * i + 1][b]
                linear.weight.copy_(weight[: linear.in_features, : linear.out_features].T)
                linear.bias.copy_(bias[: linear.out_features])
        log_std, obs_mean, obs_var, obs_count = values[len(self.params) - 1 :]
        net.log_std.copy_(log_std[b, : net.n_act])
        net.obs_mean.copy_(obs_mean[b, : net.n_obs])
        net.obs_var.copy_(obs_var[b, : net.n_obs])
        net.obs_count.copy_(obs_count[b])
        return net
