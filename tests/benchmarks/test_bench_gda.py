"""Speed of the gda designer against an author-style loop, on one torch thread.

Run with ``python -m pytest tests/benchmarks/test_bench_gda.py --benchmark-enable`` (add
``--benchmark-timer=time.process_time`` on a machine shared with other work).  Each
"author-style" benchmark re-creates the thesis code's inner loop (its architecture with
``nn.MultiheadAttention``, a shuffling DataLoader, per-parameter AdamW, ``loss.item()`` every
step, a fresh timestep tensor per sampling step) without its progress bars and logging, so it
is if anything faster than the published code; compare the two rows of each pair.
"""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
import torch.nn.functional as F
from torch._dynamo.utils import counters
from torch.utils.data import DataLoader

from gdabench import make_designer, random_body
from gdabench.designers.gda.encoding import encode
from gdabench.designers.gda.sampling import ancestral_sample
from gdabench.designers.gda.schedule import make_schedule
from gdabench.designers.gda.training import Trainer, repeat_to
from gdabench.torch_runtime import torch_threads

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from support.gda_reference import RefUNet

SCHEDULE = make_schedule("linear", 500, 1e-4, 0.02)
SURVIVORS = torch.from_numpy(encode(np.stack([random_body(np.random.default_rng(i)).voxels for i in range(5)])))[
    :, None
]


@pytest.fixture(autouse=True)
def one_thread():
    with torch_threads(1):
        yield


def needs_enabled(benchmark):
    """Compiling costs a minute or two the first time: only when benchmarks really run."""
    if benchmark.disabled:
        pytest.skip("compiles; run with --benchmark-enable")


@pytest.mark.parametrize("compiled", [False, True], ids=["eager", "compiled"])
def test_train_epoch(benchmark, compiled):
    """One epoch of the faithful training: 64 items, batches of 5 (13 optimizer steps)."""
    if compiled:
        needs_enabled(benchmark)
    trainer = Trainer(SCHEDULE, compile=compiled)
    generator = torch.Generator().manual_seed(0)
    trainer.reset(generator)
    counters.clear()
    trainer.fit(SURVIVORS, epochs=2, generator=generator)  # compiles, if asked
    assert counters["stats"]["unique_graphs"] == (
        2 if compiled else 0
    )  # batches of 5 and the last of 4, no recompilation
    result = benchmark(lambda: trainer.fit(SURVIVORS, epochs=1, generator=generator))
    assert result.epochs == 1


def test_train_epoch_author_style(benchmark):
    """The same epoch the author's way: the same batches, so the two rows compare like with like."""
    model = RefUNet()
    optimizer = torch.optim.AdamW(model.parameters(), lr=1e-3)
    loader = DataLoader(repeat_to(SURVIVORS, 64), batch_size=5, shuffle=True)
    alpha_bar = SCHEDULE.alpha_bars.float()

    def epoch() -> list[float]:
        losses = []
        for x in loader:
            t = torch.randint(1, 500, (x.shape[0],))
            noise = torch.randn_like(x)
            ab = alpha_bar[t][:, None, None, None]
            loss = F.mse_loss(model(ab.sqrt() * x + (1 - ab).sqrt() * noise, t), noise)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            losses.append(loss.item())
        return losses

    losses = benchmark(epoch)
    assert len(losses) == 13 and all(np.isfinite(losses))  # 12 batches of 5 and one of 4, as gdabench's epoch


@pytest.mark.parametrize("compiled", [False, True], ids=["eager", "compiled"])
def test_sampling_pass(benchmark, compiled):
    """One ancestral pass of 50 samples over 499 steps, as the thesis code draws them."""
    if compiled:
        needs_enabled(benchmark)
    trainer = Trainer(SCHEDULE, compile=compiled)
    forward = trainer.sample_forward()
    generator = torch.Generator().manual_seed(0)

    def sample() -> torch.Tensor:
        return ancestral_sample(trainer.model, SCHEDULE, 50, (5, 5), generator, torch.device("cpu"), forward=forward)

    x = benchmark.pedantic(sample, rounds=5, warmup_rounds=1)  # the warm-up compiles, if asked
    assert x.shape == (50, 1, 5, 5)


def test_sampling_pass_author_style(benchmark):
    """The same pass the author's way: 50 samples, one network call per step t = 499 .. 1."""
    model = RefUNet().eval()
    calls = []
    model.register_forward_hook(lambda module, args, out: calls.append(args[0].shape[0]))
    beta, alpha, alpha_bar = SCHEDULE.betas.float(), SCHEDULE.alphas.float(), SCHEDULE.alpha_bars.float()

    @torch.no_grad()
    def sample(n=50):
        calls.clear()
        x = torch.randn(n, 1, 5, 5)
        for i in reversed(range(1, 500)):
            t = (torch.ones(n) * i).long()
            eps = model(x, t)
            a, ab, b = alpha[t][:, None, None, None], alpha_bar[t][:, None, None, None], beta[t][:, None, None, None]
            noise = torch.randn_like(x) if i > 1 else torch.zeros_like(x)
            x = 1 / torch.sqrt(a) * (x - ((1 - a) / torch.sqrt(1 - ab)) * eps) + torch.sqrt(b) * noise
        return x

    x = benchmark.pedantic(sample, rounds=3, warmup_rounds=1)
    assert x.shape == (50, 1, 5, 5) and torch.isfinite(x).all()
    assert calls == [50] * 499  # as many calls, of the same size, as ancestral_sample makes


@pytest.mark.parametrize("compiled", [False, True], ids=["eager", "compiled"])
def test_generation(benchmark, compiled):
    """One whole faithful generation: train a fresh model for 250 epochs, sample 25 new bodies.

    On one core (no training ahead), like the author's code it is compared with.  In the suite's
    untimed run the same code path trains for 5 epochs: it only has to keep working.
    """
    if compiled:
        needs_enabled(benchmark)
    epochs = 5 if benchmark.disabled else 250
    designer = make_designer(
        "gda", seed=0, population=25, budget=10_000, epochs=epochs, compile=compiled, speculate=False
    )
    bodies = designer.ask()
    designer.tell(bodies, [float(np.asarray(b.voxels).sum()) for b in bodies])
    checkpoint = pickle.dumps(designer)  # the same generation every round; the trainer (compiled once) is shared

    def generation():
        return pickle.loads(checkpoint).ask()

    assert len(benchmark.pedantic(generation, rounds=3, warmup_rounds=1 if compiled else 0)) == 25
