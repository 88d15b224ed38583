"""Training the noise predictor on a generation's survivors (thesis Algorithm 1).

Faithful to the author's loop: the survivors, repeated to a dataset of 64 items, are shuffled
every epoch and cut into batches of 5 (12 batches of 5 and one of 4); each item gets a timestep
``t ~ U{1..T-1}`` and Gaussian noise, and AdamW (lr 1e-3, PyTorch's default weight decay 0.01)
minimises the MSE between the true and the predicted noise.

What makes it fast is not the arithmetic but the overhead around it (a step is a few
milliseconds of tiny kernels): all parameters and gradients live in two flat buffers, so the
optimizer is one fused kernel over 90,833 numbers instead of ~80 small updates; each epoch's
shuffle, timesteps, noise and noisy inputs are drawn and computed in a handful of batched
operations; the time features of every timestep are tabulated once.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import torch
import torch.nn.functional as F

from .model import UNet, reset_parameters
from .runtime import native_convolutions
from .schedule import NoiseSchedule


@dataclass(frozen=True)
class TrainResult:
    """What one training run did: epochs run, mean loss of the last epoch, wall time."""

    epochs: int
    loss: float
    seconds: float


def repeat_to(data: torch.Tensor, size: int) -> torch.Tensor:
    """The survivors repeated in order and cut to ``size`` items, as the author's dataset is."""
    reps = -(-size // data.shape[0])
    return data.repeat(reps, *([1] * (data.dim() - 1)))[:size]


class Trainer:
    """One U-Net with flat parameter and gradient buffers and its AdamW optimizer.

    :meth:`reset` makes the model fresh (new random weights, new optimizer state) without
    allocating a new one; :meth:`fit` trains it.  ``convolution_backend='native'`` runs the
    convolutions without oneDNN, which is faster for these 5x5 grids on CPUs.
    """

    def __init__(
        self,
        schedule: NoiseSchedule,
        *,
        lr: float = 1e-3,
        weight_decay: float = 0.01,
        device: torch.device | str = "cpu",
        onednn: bool = False,
    ):
        self.device = torch.device(device)
        self.model = UNet().to(self.device)
        self.lr, self.weight_decay = float(lr), float(weight_decay)
        self.onednn = onednn
        params = list(self.model.parameters())
        self.flat = torch.cat([p.detach().reshape(-1) for p in params])
        self.flat_grad = torch.zeros_like(self.flat)
        offset = 0
        for p in params:  # parameters become views into the flat buffers
            n = p.numel()
            p.data = self.flat[offset : offset + n].view_as(p)
            p.grad = self.flat_grad[offset : offset + n].view_as(p)
            offset += n
        self.flat_param = torch.nn.Parameter(self.flat)
        self.flat_param.grad = self.flat_grad
        self.set_schedule(schedule)
        self.optimizer = self._new_optimizer()

    def set_schedule(self, schedule: NoiseSchedule) -> None:
        self.schedule = schedule
        ab = schedule.alpha_bars
        self.sqrt_ab = ab.sqrt().to(self.device, torch.float32)
        self.sqrt_1m_ab = (1.0 - ab).sqrt().to(self.device, torch.float32)
        with torch.no_grad():
            self.time_table = self.model.time_features(torch.arange(schedule.steps, device=self.device))

    def _new_optimizer(self) -> torch.optim.Optimizer:
        return torch.optim.AdamW([self.flat_param], lr=self.lr, weight_decay=self.weight_decay, fused=True)

    def reset(self, generator: torch.Generator) -> None:
        """A fresh model: weights re-drawn from ``generator`` (CPU) and a new optimizer."""
        if self.device.type == "cpu":
            reset_parameters(self.model, generator)
        else:  # draw on the CPU so that a seed gives the same initial weights on every device
            cpu = UNet()
            reset_parameters(cpu, generator)
            with torch.no_grad():
                self.flat.copy_(torch.cat([p.reshape(-1) for p in cpu.parameters()]))
        self.optimizer = self._new_optimizer()

    def fit(
        self,
        data: torch.Tensor,
        *,
        epochs: int,
        generator: torch.Generator,
        batch_size: int = 5,
        dataset_size: int = 64,
        target_loss: float | None = None,
    ) -> TrainResult:
        """Train on ``data`` (n, 1, H, W encoded bodies) for ``epochs`` epochs.

        With ``target_loss`` training stops after the first epoch whose mean loss is at most
        that value (``epochs`` is then the maximum): the thesis's proposal to control
        exploration by the MSE reached rather than by a fixed number of epochs.
        """
        start = time.perf_counter()
        dataset = repeat_to(data.to(self.device, torch.float32), dataset_size)
        shape = dataset.shape[1:]
        steps = self.schedule.steps
        bounds = [(s, min(s + batch_size, dataset_size)) for s in range(0, dataset_size, batch_size)]
        losses = torch.zeros(len(bounds), device=self.device)
        model, optimizer, grad = self.model, self.optimizer, self.flat_grad
        model.train()
        epoch_loss, done = float("nan"), 0
        with native_convolutions(not self.onednn):
            for _ in range(epochs):
                order = torch.randperm(dataset_size, generator=generator).to(self.device)
                t = torch.randint(1, steps, (dataset_size,), generator=generator).to(self.device)
                noise = torch.randn((dataset_size, *shape), generator=generator).to(self.device)
                x0 = dataset[order]
                xt = self.sqrt_ab[t].view(-1, 1, 1, 1) * x0 + self.sqrt_1m_ab[t].view(-1, 1, 1, 1) * noise
                feats = self.time_table[t]
                for i, (a, b) in enumerate(bounds):
                    loss = F.mse_loss(model.forward_features(xt[a:b], feats[a:b]), noise[a:b])
                    grad.zero_()
                    loss.backward()
                    optimizer.step()
                    losses[i] = loss.detach()
                done += 1
                epoch_loss = float(losses.mean())
                if target_loss is not None and epoch_loss <= target_loss:
                    break
        return TrainResult(done, epoch_loss, time.perf_counter() - start)
