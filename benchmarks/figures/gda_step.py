"""gda's training step: hand-derived backward (backprop.py) against plain autograd, eager and compiled.

Times whole epochs as the faithful setting trains them (64 items, batches of 5: 12 steps of 5 and
one of 4, each followed by an AdamW step) on one torch thread, variants interleaved round by
round so that load on a shared machine hits them alike; prints the median seconds per epoch of
each and its ratio to the current default (hand-derived, compiled), and per faithful generation
(250 epochs).

    python benchmarks/figures/gda_step.py --epochs 20 --rounds 5
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Callable

import gdabench  # noqa: F401  # isort: skip - before torch: it pins torch's CPU kernels to AVX2 (gdabench.cpu)
import torch
import torch.nn.functional as F
from torch import nn
from torch.func import functional_call, grad_and_value

from gdabench.designers.gda.backprop import FastUNet
from gdabench.designers.gda.model import UNet, reset_parameters

SIZES = [5] * 12 + [4]


def handmade(compiled: bool) -> Callable[[torch.Tensor, torch.Tensor, torch.Tensor], torch.Tensor]:
    """gda's step: the hand-derived backward over flat buffers and one fused AdamW update."""
    model = UNet()
    net = FastUNet(model, (5, 5), torch.device("cpu"))
    net.params.flat.grad = net.params.grad
    opt = torch.optim.AdamW([net.params.flat], lr=1e-3, weight_decay=0.01, fused=True)
    steps: dict[int, Callable] = {}

    def step(x: torch.Tensor, f: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
        fn = steps.get(x.shape[0])
        if fn is None:
            if compiled:
                net.prepare(x.shape[0])
                fn = torch.compile(net.step, dynamic=False, options={"cpp_wrapper": True})
            else:
                fn = net.step
            steps[x.shape[0]] = fn
        loss = fn(x, f, n)
        opt.step()
        return loss

    return step


class NoiseLoss(nn.Module):
    """The training objective as a module, so that ``functional_call`` can swap its parameters."""

    def __init__(self, unet: UNet):
        super().__init__()
        self.unet = unet

    def forward(self, x: torch.Tensor, f: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
        return F.mse_loss(self.unet.forward_features(x, f), n)


def autograd(
    compiled: bool, optimizer_inside: bool
) -> Callable[[torch.Tensor, torch.Tensor, torch.Tensor], torch.Tensor]:
    objective = NoiseLoss(UNet())
    reset_parameters(objective, torch.Generator().manual_seed(0))
    names = [n for n, _ in objective.named_parameters()]
    params = [p.detach() for p in objective.parameters()]
    opt = torch.optim.AdamW(objective.parameters(), lr=1e-3, weight_decay=0.01, fused=True)

    def grads(x: torch.Tensor, f: torch.Tensor, n: torch.Tensor) -> tuple[list[torch.Tensor], torch.Tensor]:
        g, loss = grad_and_value(lambda named: functional_call(objective, named, (x, f, n)))(dict(zip(names, params)))
        return [g[k] for k in names], loss

    if optimizer_inside:
        from torch.optim.adamw import adamw

        exp_avg = [torch.zeros_like(p) for p in params]
        exp_avg_sq = [torch.zeros_like(p) for p in params]
        counts = [torch.zeros((), dtype=torch.float32) for _ in params]

        def whole(x: torch.Tensor, f: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
            with torch.no_grad():
                g, loss = grads(x, f, n)
                adamw(
                    params,
                    g,
                    exp_avg,
                    exp_avg_sq,
                    [],
                    counts,
                    amsgrad=False,
                    beta1=0.9,
                    beta2=0.999,
                    lr=1e-3,
                    weight_decay=0.01,
                    eps=1e-8,
                    maximize=False,
                )
            return loss

        return torch.compile(whole, dynamic=False) if compiled else whole

    fn = torch.compile(grads, dynamic=False) if compiled else grads

    def step(x: torch.Tensor, f: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
        g, loss = fn(x, f, n)
        for p, gi in zip(objective.parameters(), g):
            p.grad = gi
        opt.step()
        return loss.detach()

    return step


def epoch(step: Callable, data: torch.Tensor, feats: torch.Tensor, noise: torch.Tensor) -> None:
    a = 0
    for b in SIZES:
        step(data[a : a + b], feats[a : a + b], noise[a : a + b])
        a += b


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--epochs", type=int, default=20, help="epochs per timing")
    ap.add_argument("--rounds", type=int, default=5, help="interleaved timings of each variant")
    ap.add_argument(
        "--only-handmade", action="store_true", help="skip the autograd variants (they take minutes to compile)"
    )
    args = ap.parse_args()
    torch.set_num_threads(1)
    gen = torch.Generator().manual_seed(0)
    data = torch.randn(64, 1, 5, 5, generator=gen)
    feats = UNet().time_features(torch.randint(1, 500, (64,), generator=gen))
    noise = torch.randn(64, 1, 5, 5, generator=gen)
    variants = {
        "hand-derived, compiled (default)": handmade(True),
        "hand-derived, eager": handmade(False),
    }
    if not args.only_handmade:
        variants["autograd, compiled; AdamW(fused) outside"] = autograd(True, False)
        variants["autograd + functional AdamW, one compiled graph"] = autograd(True, True)
        variants["autograd, eager; AdamW(fused)"] = autograd(False, False)
    for name, step in variants.items():  # compile and warm up
        start = time.perf_counter()
        epoch(step, data, feats, noise)
        print(f"first epoch (compiles) {time.perf_counter() - start:7.2f} s  {name}", flush=True)
    times: dict[str, list[float]] = {name: [] for name in variants}
    for _ in range(args.rounds):
        for name, step in variants.items():
            start = time.perf_counter()
            for _ in range(args.epochs):
                epoch(step, data, feats, noise)
            times[name].append((time.perf_counter() - start) / args.epochs)
    base = statistics.median(times["hand-derived, compiled (default)"])
    print(f"\nmedian of {args.rounds} rounds of {args.epochs} epochs, one torch thread")
    for name, ts in times.items():
        med = statistics.median(ts)
        print(f"{med * 1000:8.2f} ms/epoch  {med * 250:6.2f} s/generation  x{med / base:5.2f}  {name}")


if __name__ == "__main__":
    main()
