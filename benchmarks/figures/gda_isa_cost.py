"""What pinning torch's kernels to AVX2 costs gda (``gdabench.cpu``): the same short run with the pin and
with the CPU's own kernels (``GDABENCH_ISA=native``), side by side.

    python benchmarks/figures/gda_isa_cost.py --repeats 2

Each run is ``gda[compile=true]`` on ``simple``, seed 0, 100 evaluations: generation 0 and three trained
generations, of which the first compiles (or loads from inductor's cache) and is left out.  The arms
alternate; prints each generation's training and sampling seconds, the medians per arm and their ratio.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd


def run(isa: str, out: Path) -> pd.DataFrame:
    env = {**os.environ, "GDABENCH_ISA": isa}
    command = [sys.executable, "-m", "gdabench", "compare", "-d", "gda[compile=true]", "--env", "simple",
               "--budget", "100", "--seeds", "0", "--jobs", "1", "-q", "--no-report", "--out", str(out)]  # fmt: skip
    subprocess.run(command, env=env, check=True)
    rows = pd.read_parquet(out / "evaluations.parquet")
    if not rows["compiled"].dropna().astype(bool).all():  # torch.compile failed and gda went on eagerly
        raise SystemExit(f"{isa}: gda ran without its compiled kernels; nothing to compare")
    return rows.groupby("generation")[["train_seconds", "sample_seconds"]].first().iloc[2:]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    seconds: dict[str, list[float]] = {"avx2": [], "native": []}
    with tempfile.TemporaryDirectory() as tmp:
        for repeat in range(args.repeats):
            for isa in seconds:
                gens = run(isa, Path(tmp) / f"{isa}-{repeat}")
                per_gen = (gens["train_seconds"] + gens["sample_seconds"]).tolist()
                seconds[isa] += per_gen
                shown = ", ".join(f"{s:.2f}" for s in per_gen)
                print(f"repeat {repeat}, {isa:>6}: train+sample per generation {shown} s "
                      f"(load {os.getloadavg()[0]:.1f})", flush=True)  # fmt: skip
    medians = {isa: statistics.median(s) for isa, s in seconds.items()}
    for isa, median in medians.items():
        print(f"{isa:>6}: median {median:.2f} s per generation over {len(seconds[isa])} generations")
    print(f"avx2 / native: x{medians['avx2'] / medians['native']:.2f}")


if __name__ == "__main__":
    main()
