"""One policy for every body: a shared MLP over each voxel's ModularEvoGym observation.

Each voxel's token is its modular row (4 corner x's, 4 corner y's: :mod:`.observation`), its material as a
one-hot vector, and the task's other observations (centre-of-mass velocity...), which every voxel of the body
sees.  A tanh MLP (SB3's sizes and orthogonal initialisation) maps a token to the Gaussian mean of the voxel's
actuation; a second one maps it to a value, averaged over the body's voxels.  The log standard deviation is
one shared number.  Weights do not depend on the body, so one network drives any body of the shape: the
"shared MLP over voxels" of MetaMorph without its attention, on CuCo's modular observations.

:class:`SharedBatch` puts the network behind the interface :func:`~gdabench.controllers.ppo.evaluation.
evaluate_policies` and the rollout loop use (bodies on a leading axis, actions padded per body).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import torch
from torch import nn

from ..ppo.networks import HALF_LOG_2PI, mlp
from .observation import PER_VOXEL, ModularView

MATERIALS = 5


class SharedPolicy(nn.Module):
    """The shared actor-critic (what is trained, carried between generations and saved)."""

    def __init__(self, n_other: int, hidden: Sequence[int] = (64, 64)):
        super().__init__()
        self.n_other, self.hidden = int(n_other), tuple(int(h) for h in hidden)
        width = PER_VOXEL - 1 + MATERIALS + self.n_other
        self.mean = mlp(width, self.hidden, 1, out_gain=0.01)
        self.value = mlp(width, self.hidden, 1, out_gain=1.0)
        self.log_std = nn.Parameter(torch.zeros(1))


def fresh_policy(n_other: int, hidden: Sequence[int], seed: int) -> SharedPolicy:
    """A shared policy initialised from ``seed`` alone (on one thread, the caller's RNG kept)."""
    from ..ppo.train import deterministic_torch

    with torch.random.fork_rng(devices=[]), deterministic_torch(1):
        torch.manual_seed(seed)
        return SharedPolicy(n_other, hidden)


class SharedBatch:
    """B bodies' views of one :class:`SharedPolicy` (the interface of :class:`~gdabench.controllers.ppo.networks.
    Stacked` that rollouts and evaluations use)."""

    def __init__(self, policy: SharedPolicy, views: Sequence[ModularView], n_obs: int):
        self.policy, self.views = policy, list(views)
        self.n_obs = int(n_obs)
        self.act_sizes = [len(v.actuator) for v in views]
        n_act = max(self.act_sizes)
        voxels = len(views[0].material)
        # a missing corner reads column n_obs, a zero appended to every observation
        self.index = torch.tensor(np.stack([np.where(v.index >= 0, v.index, self.n_obs) for v in views]))
        self.materials = torch.nn.functional.one_hot(
            torch.tensor(np.stack([v.material for v in views])), MATERIALS
        ).float()
        self.filled = torch.tensor(np.stack([v.material != 0 for v in views])).float()
        self.other = torch.tensor(np.stack([v.other for v in views]))
        self.actuator = torch.zeros(len(views), n_act, dtype=torch.long)
        self.act_mask = torch.zeros(len(views), n_act)
        for b, v in enumerate(views):
            self.actuator[b, : len(v.actuator)] = torch.tensor(v.actuator)
            self.act_mask[b, : len(v.actuator)] = 1.0
        self.voxels = voxels

    @property
    def n_bodies(self) -> int:
        return len(self.views)

    @property
    def log_std(self) -> torch.Tensor:
        """Per body and action ``(B, A)`` (one shared number)."""
        return self.policy.log_std.expand(self.n_bodies, self.act_mask.shape[1])

    def observe(self, x: torch.Tensor, learn: bool = False) -> torch.Tensor:
        return x

    def tokens(self, obs: torch.Tensor) -> torch.Tensor:
        """Voxel tokens ``(B, n, V, width)`` for flat observations ``(B, n, O)``."""
        B, n, _ = obs.shape
        padded = torch.cat([obs, obs.new_zeros(B, n, 1)], dim=2)
        corners = torch.gather(padded, 2, self.index.view(B, 1, -1).expand(B, n, -1)).view(B, n, self.voxels, 8)
        corners = corners * self.filled.view(B, 1, -1, 1)
        other = torch.gather(obs, 2, self.other.view(B, 1, -1).expand(B, n, -1))
        return torch.cat(
            [
                corners,
                self.materials.unsqueeze(1).expand(B, n, -1, -1),
                other.unsqueeze(2).expand(B, n, self.voxels, -1),
            ],
            dim=3,
        )

    def mean(self, obs: torch.Tensor) -> torch.Tensor:
        """The Gaussian's mean ``(B, n, A)``: each actuator's voxel's output (zero on padded actions)."""
        per_voxel = self.policy.mean(self.tokens(obs))[..., 0]  # (B, n, V)
        B, n, _ = per_voxel.shape
        picked = torch.gather(per_voxel, 2, self.actuator.view(B, 1, -1).expand(B, n, -1))
        return picked * self.act_mask.unsqueeze(1)

    def value(self, obs: torch.Tensor) -> torch.Tensor:
        """State values ``(B, n)``: the mean over the body's voxels."""
        per_voxel = self.policy.value(self.tokens(obs))[..., 0]
        weights = self.filled / self.filled.sum(1, keepdim=True)
        return (per_voxel * weights.unsqueeze(1)).sum(2)

    def log_prob(self, actions: torch.Tensor, mean: torch.Tensor) -> torch.Tensor:
        log_std = self.log_std.unsqueeze(1)
        z = (actions - mean) * torch.exp(-log_std)
        return -((0.5 * z.square() + log_std + HALF_LOG_2PI) * self.act_mask.unsqueeze(1)).sum(-1)

    def entropy(self) -> torch.Tensor:
        return ((0.5 + HALF_LOG_2PI + self.log_std) * self.act_mask).sum(-1)

    @torch.no_grad()
    def act(self, obs: torch.Tensor, generators: Sequence[torch.Generator | None]) -> tuple[torch.Tensor, torch.Tensor]:
        """As :meth:`~gdabench.controllers.ppo.networks.Stacked.act`: body ``b`` draws ``n`` x its action count."""
        mean = self.mean(obs)
        noise = torch.zeros(mean.shape)
        for b, generator in enumerate(generators):
            if generator is not None:
                noise[b, :, : self.act_sizes[b]] = torch.randn((mean.shape[1], self.act_sizes[b]), generator=generator)
        actions = mean + self.log_std.exp().unsqueeze(1) * noise
        log_prob = -((0.5 * noise.square() + self.log_std.unsqueeze(1) + HALF_LOG_2PI) * self.act_mask.unsqueeze(1))
        return actions, log_prob.sum(-1)
