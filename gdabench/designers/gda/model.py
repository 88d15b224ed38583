"""The thesis's noise-prediction U-Net for small voxel grids (90,833 parameters at 5x5).

Architecture as in the author's code (thesis section 4.3): a double convolution lifts the
1-channel grid to 16 channels, one strided convolution halves the grid (5x5 -> 3x3),
self-attention and a 16 -> 32 -> 32 -> 16 bottleneck work there, a bilinear upsampling and a
skip connection return to full size, self-attention again, and a 1x1 convolution predicts
the noise.  The timestep enters through a sinusoidal encoding projected onto the channels of
the down and up blocks.  The SiLU that the author applies to the encoding inside each block
is applied once in :meth:`UNet.time_features` (the same values), so that trainers can
tabulate the features of all timesteps up front.

The attention is written with ``scaled_dot_product_attention`` instead of
``nn.MultiheadAttention``: the same parameters, initialisation and arithmetic, with less
per-call overhead, which matters because training runs thousands of tiny steps.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

TIME_DIM = 256
BASE_CHANNELS = 16
HEADS = 4


def sinusoidal_encoding(t: torch.Tensor, dim: int = TIME_DIM) -> torch.Tensor:
    """Encode integer timesteps ``t`` (shape (n,)) as ``[sin(t f), cos(t f)]``, ``dim`` values each."""
    freqs = 1.0 / (10000.0 ** (torch.arange(0, dim, 2, device=t.device, dtype=torch.float32) / dim))
    angles = t.to(torch.float32)[:, None] * freqs[None, :]
    return torch.cat([torch.sin(angles), torch.cos(angles)], dim=-1)


class DoubleConv(nn.Module):
    """conv3x3 - GroupNorm(1) - GELU - conv3x3 - GroupNorm(1), optionally as ``gelu(x + f(x))``."""

    def __init__(self, c_in: int, c_out: int, c_mid: int | None = None, residual: bool = False):
        super().__init__()
        c_mid = c_mid or c_out
        self.residual = residual
        self.conv1 = nn.Conv2d(c_in, c_mid, kernel_size=3, padding=1, bias=False)
        self.norm1 = nn.GroupNorm(1, c_mid)
        self.conv2 = nn.Conv2d(c_mid, c_out, kernel_size=3, padding=1, bias=False)
        self.norm2 = nn.GroupNorm(1, c_out)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = self.norm2(self.conv2(F.gelu(self.norm1(self.conv1(x)))))
        return F.gelu(x + h) if self.residual else h


class SelfAttention(nn.Module):
    """Pre-norm multi-head self-attention over grid cells, then a pre-norm feed-forward block."""

    def __init__(self, channels: int, heads: int = HEADS):
        super().__init__()
        self.heads = heads
        self.norm = nn.LayerNorm(channels)
        self.in_proj = nn.Linear(channels, 3 * channels)
        self.out_proj = nn.Linear(channels, channels)
        self.ff = nn.Sequential(
            nn.LayerNorm(channels), nn.Linear(channels, channels), nn.GELU(), nn.Linear(channels, channels)
        )
        # nn.MultiheadAttention's initialisation: xavier input projection, zero biases
        nn.init.xavier_uniform_(self.in_proj.weight)
        nn.init.zeros_(self.in_proj.bias)
        nn.init.zeros_(self.out_proj.bias)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        b, c, h, w = x.shape
        tokens = x.flatten(2).transpose(1, 2)  # (b, cells, c)
        q, k, v = self.in_proj(self.norm(tokens)).view(b, h * w, 3, self.heads, c // self.heads).permute(2, 0, 3, 1, 4)
        if torch.is_grad_enabled():
            att = F.scaled_dot_product_attention(q, k, v)
        else:  # plain softmax attention: the same numbers, twice as fast as the fused CPU kernel at head size 4
            att = torch.softmax((q * (q.shape[-1] ** -0.5)) @ k.transpose(-1, -2), dim=-1) @ v
        att = att.transpose(1, 2).reshape(b, h * w, c)
        tokens = tokens + self.out_proj(att)
        tokens = tokens + self.ff(tokens)
        return tokens.transpose(1, 2).reshape(b, c, h, w)


class Down(nn.Module):
    """Strided convolution to half size, two double convolutions, plus the time embedding."""

    def __init__(self, c_in: int, c_out: int, time_dim: int = TIME_DIM):
        super().__init__()
        self.down = nn.Conv2d(c_in, c_in, kernel_size=3, stride=2, padding=1)
        self.conv_res = DoubleConv(c_in, c_in, residual=True)
        self.conv = DoubleConv(c_in, c_out)
        self.time = nn.Linear(time_dim, c_out)

    def forward(self, x: torch.Tensor, t_feat: torch.Tensor) -> torch.Tensor:
        x = self.conv(self.conv_res(self.down(x)))
        return x + self.time(t_feat)[:, :, None, None]


class Up(nn.Module):
    """Bilinear upsampling to the skip's size, concatenation, two double convolutions, time embedding."""

    def __init__(self, c_in: int, c_out: int, time_dim: int = TIME_DIM):
        super().__init__()
        self.conv_res = DoubleConv(c_in, c_in, residual=True)
        self.conv = DoubleConv(c_in, c_out, c_in // 2)
        self.time = nn.Linear(time_dim, c_out)

    def forward(self, x: torch.Tensor, skip: torch.Tensor, t_feat: torch.Tensor) -> torch.Tensor:
        x = F.interpolate(x, size=skip.shape[-2:], mode="bilinear", align_corners=True)
        x = self.conv(self.conv_res(torch.cat([skip, x], dim=1)))
        return x + self.time(t_feat)[:, :, None, None]


class UNet(nn.Module):
    """Predicts the noise in a batch of noisy encoded bodies ``(n, 1, H, W)`` at timesteps ``t``."""

    def __init__(self, channels: int = BASE_CHANNELS, time_dim: int = TIME_DIM):
        super().__init__()
        c = channels
        self.time_dim = time_dim
        self.inc = DoubleConv(1, c)
        self.down = Down(c, c, time_dim)
        self.att_low = SelfAttention(c)
        self.bottleneck = nn.Sequential(DoubleConv(c, 2 * c), DoubleConv(2 * c, 2 * c), DoubleConv(2 * c, c))
        self.up = Up(2 * c, c, time_dim)
        self.att_high = SelfAttention(c)
        self.out = nn.Conv2d(c, 1, kernel_size=1)

    def time_features(self, t: torch.Tensor) -> torch.Tensor:
        """SiLU of the sinusoidal encoding of integer timesteps ``t`` (shape (n,)): parameter-free."""
        return F.silu(sinusoidal_encoding(t, self.time_dim))

    def forward(self, x: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """Predict the noise in ``x`` (n, 1, H, W) at integer timesteps ``t`` (shape (n,) or (1,))."""
        return self.forward_features(x, self.time_features(t))

    def forward_features(self, x: torch.Tensor, t_feat: torch.Tensor) -> torch.Tensor:
        """Same as :meth:`forward` with :meth:`time_features` of ``t`` already computed."""
        skip = self.inc(x)
        h = self.att_low(self.down(skip, t_feat))
        h = self.bottleneck(h)
        h = self.att_high(self.up(h, skip, t_feat))
        return self.out(h)


@torch.no_grad()
def reset_parameters(model: nn.Module, generator: torch.Generator) -> None:
    """Re-initialise ``model`` in place as PyTorch initialises a new one, drawing from ``generator``.

    Convolutions and linear layers: weights and biases uniform on +-1/sqrt(fan_in); norms: ones
    and zeros; attention: xavier-uniform input projection and zero biases (as
    ``nn.MultiheadAttention``).  A seeded generator makes every "fresh model" reproducible
    without touching torch's global random state.
    """
    for module in model.modules():
        if isinstance(module, (nn.Conv2d, nn.Linear)):
            fan_in = module.weight[0].numel()
            bound = 1.0 / math.sqrt(fan_in)
            module.weight.uniform_(-bound, bound, generator=generator)
            if module.bias is not None:
                module.bias.uniform_(-bound, bound, generator=generator)
        elif isinstance(module, (nn.GroupNorm, nn.LayerNorm)):
            module.weight.fill_(1.0)
            module.bias.zero_()
    for module in model.modules():
        if isinstance(module, SelfAttention):
            fan_in, fan_out = module.in_proj.weight.shape[1], module.in_proj.weight.shape[0]
            bound = math.sqrt(6.0 / (fan_in + fan_out))
            module.in_proj.weight.uniform_(-bound, bound, generator=generator)
            module.in_proj.bias.zero_()
            module.out_proj.bias.zero_()


def parameter_count(model: nn.Module) -> int:
    return sum(p.numel() for p in model.parameters())
