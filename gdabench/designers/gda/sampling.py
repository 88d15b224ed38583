"""Drawing encoded bodies from a trained noise predictor.

* :func:`ancestral_sample` is the thesis's sampler (DDPM Algorithm 2): start from Gaussian
  noise and apply ``x <- (x - beta_t / sqrt(1 - alpha_bar_t) * eps) / sqrt(alpha_t) + sqrt(beta_t) z``
  for t = T-1 .. 1, with no noise in the last step and no clamping.
* :func:`ddim_sample` is the DDIM sampler (Song et al. 2021) on a subsequence of the
  timesteps: the same trained model, far fewer network evaluations.

Every item of a batch is an independent draw, so how many are drawn per pass changes the cost,
never the distribution of what is accepted.  All the noise of a pass is drawn up front from
the given generator, the per-step constants are Python floats, and the update runs in place.
"""

from __future__ import annotations

import math
from typing import Callable

import torch

from .model import UNet
from .schedule import NoiseSchedule

SAMPLERS = ("ddpm", "ddim")


@torch.inference_mode()
def ancestral_sample(
    model: UNet,
    schedule: NoiseSchedule,
    n: int,
    shape: tuple[int, int],
    generator: torch.Generator,
    device: torch.device,
    temperature: float = 1.0,
    forward: Callable[[torch.Tensor, torch.Tensor], torch.Tensor] | None = None,
) -> torch.Tensor:
    """``n`` samples (n, 1, H, W) by ancestral sampling over t = T-1 .. 1 (T-1 network calls).

    ``temperature`` scales the noise added at each step (1 = the thesis sampler); below 1 the
    chain drifts towards the modes of what the model learnt, e.g. the voxel-wise consensus
    of the survivors.  ``forward`` replaces ``model.forward_features`` (e.g. compiled).
    """
    x = torch.randn((n, 1, *shape), generator=generator).to(device)
    return denoise(model, schedule, x, schedule.steps - 1, generator, temperature, forward)


@torch.inference_mode()
def denoise(
    model: UNet,
    schedule: NoiseSchedule,
    x: torch.Tensor,
    start: int,
    generator: torch.Generator,
    temperature: float = 1.0,
    forward: Callable[[torch.Tensor, torch.Tensor], torch.Tensor] | None = None,
) -> torch.Tensor:
    """Ancestral steps from ``x`` at timestep ``start`` down to t = 1 (``start`` network calls);
    ``x`` is updated in place and returned.  From T-1 this is the thesis sampler; from an earlier
    timestep it completes a partly noised body (the interpolation crossover's second half)."""
    model.eval()
    betas, alphas, alpha_bars = schedule.betas.tolist(), schedule.alphas.tolist(), schedule.alpha_bars.tolist()
    z = torch.randn((max(start - 1, 0), *x.shape), generator=generator).to(x.device)  # for t = start .. 2
    feats = model.time_features(torch.arange(schedule.steps, device=x.device))  # all T: the same rounding as from T-1
    forward = forward or model.forward_features
    for t in range(start, 0, -1):
        eps = forward(x, feats[t : t + 1])
        x.sub_(eps, alpha=(1.0 - alphas[t]) / math.sqrt(1.0 - alpha_bars[t])).mul_(1.0 / math.sqrt(alphas[t]))
        if t > 1:
            x.add_(z[start - t], alpha=temperature * math.sqrt(betas[t]))
    return x


def noised(schedule: NoiseSchedule, x0: torch.Tensor, t: int, generator: torch.Generator) -> torch.Tensor:
    """``x0`` diffused forward to timestep ``t``: ``sqrt(ab_t) x0 + sqrt(1 - ab_t) z``."""
    ab = float(schedule.alpha_bars[t])
    return math.sqrt(ab) * x0 + math.sqrt(1.0 - ab) * torch.randn(x0.shape, generator=generator).to(x0.device)


def ddim_timesteps(T: int, steps: int) -> list[int]:
    """``steps`` timesteps evenly spread over 1..T-1, descending (always from T-1 down to 1)."""
    steps = max(1, min(steps, T - 1))
    if steps == 1:
        return [T - 1]
    return sorted({round(1 + i * (T - 2) / (steps - 1)) for i in range(steps)}, reverse=True)


@torch.inference_mode()
def ddim_sample(
    model: UNet,
    schedule: NoiseSchedule,
    n: int,
    shape: tuple[int, int],
    generator: torch.Generator,
    device: torch.device,
    steps: int = 50,
    eta: float = 1.0,
    temperature: float = 1.0,
    forward: Callable[[torch.Tensor, torch.Tensor], torch.Tensor] | None = None,
) -> torch.Tensor:
    """``n`` samples by DDIM over ``steps`` timesteps, ending at index 0 like the thesis sampler.

    From x_t the noise estimate gives ``x0 = (x_t - sqrt(1 - ab_t) eps) / sqrt(ab_t)``; the next
    point at timestep s is ``sqrt(ab_s) x0 + sqrt(1 - ab_s - sigma^2) eps + sigma z`` with
    ``sigma = eta sqrt((1 - ab_s) / (1 - ab_t) (1 - ab_t / ab_s))``.  ``eta = 1`` is ancestral
    sampling on the shorter chain (the DDPM posterior variance, slightly below the thesis's
    sigma^2 = beta); ``eta = 0`` is deterministic, and with models trained as briefly as GDA's
    it collapses most draws onto a few degenerate bodies (measured: 5-10% of draws near the
    training body against about 50% for eta = 1), so 1 is the default.  ``temperature``
    scales sigma and ``forward`` replaces the network as in :func:`ancestral_sample`.
    """
    model.eval()
    alpha_bars = schedule.alpha_bars.tolist()
    ts = ddim_timesteps(schedule.steps, steps)
    x = torch.randn((n, 1, *shape), generator=generator).to(device)
    z = torch.randn((len(ts), n, 1, *shape), generator=generator).to(device)
    feats = model.time_features(torch.tensor(ts, device=device))
    forward = forward or model.forward_features
    for i, t in enumerate(ts):
        ab_t = alpha_bars[t]
        ab_s = alpha_bars[ts[i + 1]] if i + 1 < len(ts) else alpha_bars[0]
        eps = forward(x, feats[i : i + 1])
        x0 = (x - math.sqrt(1.0 - ab_t) * eps) / math.sqrt(ab_t)
        last = i + 1 == len(ts)
        sigma = 0.0 if last else eta * math.sqrt(max((1.0 - ab_s) / (1.0 - ab_t) * (1.0 - ab_t / ab_s), 0.0))
        x = math.sqrt(ab_s) * x0 + math.sqrt(max(1.0 - ab_s - sigma**2, 0.0)) * eps
        if sigma > 0:
            x.add_(z[i], alpha=temperature * sigma)
    return x
