"""Time Evolution Gym's random sampler, batched (``gdabench.body.random_body``) against one grid per draw.

    python benchmarks/figures/random_sampler.py [--bodies 20] [--shapes 5x5,8x8,12x12]

Both draw the same bodies from the same stream (tests/test_body.py checks it); the figure is the
ratio of their times per body, measured side by side on each shape.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from gdabench.body import EVOGYM_VOXEL_WEIGHTS, Body, invalid_reason, parse_shape, random_body


def one_at_a_time(rng: np.random.Generator, shape: tuple[int, int], exclude: set[str]) -> Body:
    """The sampler as Evolution Gym writes it: one grid per draw until it is valid and new."""
    p = EVOGYM_VOXEL_WEIGHTS / EVOGYM_VOXEL_WEIGHTS.sum()
    while True:
        voxels = rng.choice(len(p), size=shape, p=p).astype(np.int8)
        if invalid_reason(voxels) is None and Body(voxels).hash not in exclude:
            return Body(voxels)


def per_body(sample, shape: tuple[int, int], bodies: int) -> tuple[float, list[str]]:
    rng, seen = np.random.default_rng(0), set()
    start = time.perf_counter()
    for _ in range(bodies):
        seen.add(sample(rng, shape, exclude=seen).hash)
    return (time.perf_counter() - start) / bodies, sorted(seen)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bodies", type=int, default=20)
    parser.add_argument("--shapes", default="5x5,8x8,12x12")
    args = parser.parse_args()
    print("| shape | one at a time, ms per body | batched, ms per body | speed-up |")
    print("|---|--:|--:|--:|")
    for text in args.shapes.split(","):
        shape = parse_shape(text)
        slow, theirs = per_body(one_at_a_time, shape, args.bodies)
        fast, ours = per_body(random_body, shape, args.bodies)
        assert ours == theirs, "the batched sampler drew other bodies"
        print(f"| {text} | {slow * 1e3:.2f} | {fast * 1e3:.2f} | {slow / fast:.1f}x |")


if __name__ == "__main__":
    main()
