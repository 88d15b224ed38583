"""Noise schedules of the forward diffusion process, indexed as the author's code indexes them.

Arrays have ``T`` entries, index ``t`` = 0..T-1.  ``alpha_bar[t]`` is the product of
``1 - beta`` over indices 0..t; training draws ``t`` uniformly from 1..T-1 and ancestral
sampling runs ``t`` = T-1 down to 1 (index 0 only enters the products), exactly as in the
thesis code.  The linear schedule (1e-4 -> 0.02 over T = 500) is the thesis's; the cosine
schedule of Nichol & Dhariwal (2021) is the improvement the thesis suggests in section 6.3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from ...errors import ConfigError

SCHEDULES = ("linear", "cosine")


@dataclass(frozen=True)
class NoiseSchedule:
    """Per-timestep constants of DDPM (float64 on the CPU; cast where they are used)."""

    betas: torch.Tensor

    @property
    def steps(self) -> int:
        return int(self.betas.shape[0])

    @property
    def alphas(self) -> torch.Tensor:
        return 1.0 - self.betas

    @property
    def alpha_bars(self) -> torch.Tensor:
        return torch.cumprod(self.alphas, dim=0)


def linear_schedule(steps: int, beta_start: float, beta_end: float) -> NoiseSchedule:
    """Betas evenly spaced from ``beta_start`` to ``beta_end`` (computed in float32 like torch.linspace
    in the thesis code, then widened)."""
    return NoiseSchedule(torch.linspace(beta_start, beta_end, steps, dtype=torch.float32).to(torch.float64))


def cosine_schedule(steps: int, terminal: float, offset: float = 0.008) -> NoiseSchedule:
    """Betas such that ``alpha_bar`` falls along cos^2 (Nichol & Dhariwal 2021) from 1 to ``terminal``.

    Noise is added slowly at the start and the end, so fewer steps are spent on nearly pure
    noise.  The original reaches alpha_bar = 0 with betas clipped at 0.999, which relies on
    clamping the sampler's estimates; the thesis sampler does not clamp, so the curve is
    rescaled to end at the linear schedule's noise level instead (largest beta about 0.04
    at T = 500).
    """
    f = lambda i: math.cos((i / steps + offset) / (1 + offset) * math.pi / 2) ** 2  # noqa: E731
    alpha_bars = [terminal + (1.0 - terminal) * f(i + 1) / f(0) for i in range(steps)]
    betas = [1.0 - alpha_bars[0]] + [1.0 - alpha_bars[i] / alpha_bars[i - 1] for i in range(1, steps)]
    return NoiseSchedule(torch.tensor(betas, dtype=torch.float64))


def make_schedule(kind: str, steps: int, beta_start: float, beta_end: float) -> NoiseSchedule:
    """The schedule called ``kind`` ('linear' or 'cosine'); bad values raise :class:`ConfigError`.

    The cosine schedule ends at the noise level of the linear one with the same arguments.
    """
    if steps < 2:
        raise ConfigError(f"gda: steps (T) must be at least 2, got {steps}")
    if kind not in SCHEDULES:
        raise ConfigError(f"gda: unknown schedule {kind!r}; choose one of {', '.join(SCHEDULES)}")
    if not 0.0 < beta_start <= beta_end < 1.0:
        raise ConfigError(f"gda: need 0 < beta_start <= beta_end < 1, got {beta_start} and {beta_end}")
    linear = linear_schedule(steps, beta_start, beta_end)
    if kind == "cosine":
        return cosine_schedule(steps, terminal=float(linear.alpha_bars[-1]))
    return linear
