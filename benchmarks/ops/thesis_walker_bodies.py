"""The thesis author's published Walker-v0 bodies and their rewards, as one small CSV.

The thesis's walker figures (its figure 5.1) come from its author's published run data, not from its
text: ``imported_exp_data/`` of https://github.com/JohnStewardson/evolving_robots_diffusion (commit
298cc01), runs ``2024-08-26-Walker_v0_cppn`` (CPPN-NEAT), ``2024-09-13-Diffusion_v0`` (the generational
diffusion algorithm) and ``2024_09_27_Walker_v0_ga`` (the GA).  Each ``generation_N`` holds the bodies
(``structure/I.npz``, array ``arr_0``: Evolution Gym voxel codes, row 0 at the top) and ``output.txt``
(``I<TAB><TAB>reward``: each body's Evolution Gym 2.0 PPO reward after 1e6 timesteps, the best mean
evaluation, scored without the final step's reward).  A survivor is listed again in later generations
with its first reward.

This script reads a clone of that repository (``git clone``, or the ``fetch`` tool's mirror) and
writes one row per listed body: ``run, designer, generation, index, body, reward``; only these data are
kept, none of the author's code.  Bodies without a listed reward (a generation that never finished
training) are left out.

Usage::

    python benchmarks/ops/thesis_walker_bodies.py /path/to/evolving_robots_diffusion \\
        --out docs/benchmarks/output/thesis-walker-bodies.csv
"""

from __future__ import annotations

import argparse
import csv
import io
import subprocess
from pathlib import Path

import numpy as np

#: the author's Walker-v0 runs and which designer made each
RUNS = {
    "2024-08-26-Walker_v0_cppn": "cppn",
    "2024-09-13-Diffusion_v0": "gda",
    "2024_09_27_Walker_v0_ga": "ga",
}
SOURCE = "https://github.com/JohnStewardson/evolving_robots_diffusion (imported_exp_data/, commit 298cc01)"


def reader(repo: Path):
    """Read a file of the repository's HEAD, from a work tree or a bare mirror alike."""

    def read(path: str) -> bytes | None:
        done = subprocess.run(["git", "-C", str(repo), "show", f"HEAD:{path}"], capture_output=True)
        return done.stdout if done.returncode == 0 else None

    return read


def rows(repo: Path) -> list[dict]:
    read, out = reader(repo), []
    for run, designer in RUNS.items():
        generation = 0
        while (listing := read(f"imported_exp_data/{run}/generation_{generation}/output.txt")) is not None:
            for line in listing.decode().splitlines():
                if not line.strip():
                    continue
                index, reward = line.split()
                raw = read(f"imported_exp_data/{run}/generation_{generation}/structure/{index}.npz")
                if raw is None:
                    raise SystemExit(f"error: {run} generation {generation} lists body {index} without its structure")
                grid = np.load(io.BytesIO(raw))["arr_0"].astype(int)
                body = "/".join("".join(str(v) for v in row) for row in grid)
                out.append({"run": run, "designer": designer, "generation": generation, "index": int(index),
                            "body": body, "reward": float(reward)})
            generation += 1
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("repo", type=Path, help="a clone (or bare mirror) of JohnStewardson/evolving_robots_diffusion")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks/output/thesis-walker-bodies.csv"))
    args = parser.parse_args()
    table = rows(args.repo)
    with args.out.open("w", newline="") as f:
        f.write(f"# source: {SOURCE}\n")
        writer = csv.DictWriter(f, fieldnames=list(table[0]))
        writer.writeheader()
        writer.writerows(table)
    distinct = len({r["body"] for r in table})
    print(f"{len(table)} rows, {distinct} distinct bodies -> {args.out}")


if __name__ == "__main__":
    main()
