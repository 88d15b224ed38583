"""What two cores of this machine give two independent gda trainings: the ceiling of ``--jobs 2``.

Research, kept for the record (``benchmarks/research/``): a ceiling of the hardware, measured for
docs/benchmarks/main-job.md; of gdabench it runs only gda's training step.

    python benchmarks/research/parallel_ceiling.py [--epochs 40] [--rounds 3]

Runs gda's faithful training (compiled, one torch thread, 5 survivors repeated to 64 items, batches
of 5) in one process alone, then in two processes at once, alternately for ``--rounds`` rounds, and
prints the median seconds per epoch of each.  Two trials side by side cannot finish faster than
``2 * alone / side_by_side`` times one after another, whatever the scheduler does; if that is below
a figure asked of ``--jobs 2``, the hardware (shared caches, memory bandwidth, a host's hyperthreads)
and not the harness sets the limit.  Run it on a quiet machine.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import statistics
import time

import numpy as np

import gdabench  # noqa: F401 - before torch: it pins torch's CPU kernels to AVX2 (gdabench.cpu)


def train(epochs: int, start: mp.Barrier, out: mp.Queue) -> None:
    import torch

    from gdabench.designers.gda.schedule import make_schedule
    from gdabench.designers.gda.training import Trainer, TrainJob

    torch.set_num_threads(1)
    trainer = Trainer(make_schedule("linear", 500, 1e-4, 0.02), compile=True)
    data = np.random.default_rng(0).uniform(-1, 1, (5, 1, 5, 5)).astype(np.float32)
    job = TrainJob.make(data, 0, epochs=epochs, batch_size=5, dataset_size=64)
    job.warm_up(trainer)  # compiled (from inductor's cache after the first run) before the clock starts
    start.wait()
    began = time.perf_counter()
    job.train(trainer)
    out.put((time.perf_counter() - began) / epochs)


def measure(processes: int, epochs: int) -> float:
    """Median seconds per epoch over ``processes`` trainings started together."""
    ctx = mp.get_context("spawn")
    barrier, out = ctx.Barrier(processes), ctx.Queue()
    workers = [ctx.Process(target=train, args=(epochs, barrier, out)) for _ in range(processes)]
    for w in workers:
        w.start()
    times = [out.get() for _ in workers]
    for w in workers:
        w.join()
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--epochs", type=int, default=40)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    measure(1, 1)  # fill inductor's cache
    alone, together = [], []
    for _ in range(args.rounds):
        alone.append(measure(1, args.epochs))
        together.append(measure(2, args.epochs))
    a, t = statistics.median(alone), statistics.median(together)
    print(
        f"alone: {a * 1e3:.1f} ms per epoch; two side by side: {t * 1e3:.1f} ms per epoch each (medians of "
        f"{args.rounds} rounds)"
    )
    print(
        f"each is {t / a:.2f}x slower side by side; ceiling of two trials at once against one after another: "
        f"{2 * a / t:.2f}x"
    )


if __name__ == "__main__":
    main()
