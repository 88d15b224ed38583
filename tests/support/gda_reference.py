"""A plain re-statement of the thesis's U-Net (NCHW, nn.MultiheadAttention, per-block SiLU).

Tests load gdabench's model weights into it and check that both compute the same function, so
the speed-minded implementation in ``gdabench.designers.gda.model`` cannot drift from the
architecture the thesis describes.  Benchmarks use it as the "author-style" baseline.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from gdabench.designers.gda.model import UNet, sinusoidal_encoding


class RefDoubleConv(nn.Module):
    def __init__(self, c_in, c_out, c_mid=None, residual=False):
        super().__init__()
        c_mid = c_mid or c_out
        self.residual = residual
        self.f = nn.Sequential(
            nn.Conv2d(c_in, c_mid, 3, padding=1, bias=False),
            nn.GroupNorm(1, c_mid),
            nn.GELU(),
            nn.Conv2d(c_mid, c_out, 3, padding=1, bias=False),
            nn.GroupNorm(1, c_out),
        )

    def forward(self, x):
        return F.gelu(x + self.f(x)) if self.residual else self.f(x)


class RefAttention(nn.Module):
    def __init__(self, c):
        super().__init__()
        self.mha = nn.MultiheadAttention(c, 4, batch_first=True)
        self.ln = nn.LayerNorm([c])
        self.ff = nn.Sequential(nn.LayerNorm([c]), nn.Linear(c, c), nn.GELU(), nn.Linear(c, c))

    def forward(self, x):
        b, c, h, w = x.shape
        x = x.view(b, c, h * w).swapaxes(1, 2)
        y = self.ln(x)
        a, _ = self.mha(y, y, y)
        a = a + x
        a = self.ff(a) + a
        return a.swapaxes(2, 1).view(b, c, h, w)


class RefUNet(nn.Module):
    def __init__(self):
        super().__init__()
        self.inc = RefDoubleConv(1, 16)
        self.down_conv = nn.Conv2d(16, 16, 3, stride=2, padding=1)
        self.down = nn.Sequential(RefDoubleConv(16, 16, residual=True), RefDoubleConv(16, 16))
        self.down_emb = nn.Sequential(nn.SiLU(), nn.Linear(256, 16))
        self.sa1 = RefAttention(16)
        self.bot = nn.Sequential(RefDoubleConv(16, 32), RefDoubleConv(32, 32), RefDoubleConv(32, 16))
        self.up = nn.Sequential(RefDoubleConv(32, 32, residual=True), RefDoubleConv(32, 16, 16))
        self.up_emb = nn.Sequential(nn.SiLU(), nn.Linear(256, 16))
        self.sa2 = RefAttention(16)
        self.outc = nn.Conv2d(16, 1, 1)

    def forward(self, x, t):
        e = sinusoidal_encoding(t)
        x1 = self.inc(x)
        x2 = self.down(self.down_conv(x1))
        x2 = self.sa1(x2 + self.down_emb(e)[:, :, None, None])
        x2 = self.bot(x2)
        # the author's code upsamples to a fixed (5, 5); back to the input's size is the same at 5x5
        x = F.interpolate(x2, size=x1.shape[-2:], mode="bilinear", align_corners=True)
        x = self.up(torch.cat([x1, x], dim=1)) + self.up_emb(e)[:, :, None, None]
        return self.outc(self.sa2(x))

    @torch.no_grad()
    def load_from(self, ours: UNet) -> "RefUNet":
        """Copy the weights of gdabench's model into this one."""

        def dc(ref: RefDoubleConv, mine):
            for i, m in ((0, mine.conv1), (1, mine.norm1), (3, mine.conv2), (4, mine.norm2)):
                for name, p in m.named_parameters():
                    getattr(ref.f[i], name).copy_(p)

        def att(ref: RefAttention, mine):
            ref.mha.in_proj_weight.copy_(mine.in_proj.weight)
            ref.mha.in_proj_bias.copy_(mine.in_proj.bias)
            ref.mha.out_proj.weight.copy_(mine.out_proj.weight)
            ref.mha.out_proj.bias.copy_(mine.out_proj.bias)
            ref.ln.load_state_dict(mine.norm.state_dict())
            ref.ff.load_state_dict(mine.ff.state_dict())

        dc(self.inc, ours.inc)
        self.down_conv.load_state_dict(ours.down.down.state_dict())
        dc(self.down[0], ours.down.conv_res)
        dc(self.down[1], ours.down.conv)
        self.down_emb[1].load_state_dict(ours.down.time.state_dict())
        att(self.sa1, ours.att_low)
        for ref, mine in zip(self.bot, ours.bottleneck):
            dc(ref, mine)
        dc(self.up[0], ours.up.conv_res)
        dc(self.up[1], ours.up.conv)
        self.up_emb[1].load_state_dict(ours.up.time.state_dict())
        att(self.sa2, ours.att_high)
        self.outc.load_state_dict(ours.out.state_dict())
        return self
