"""Time the main job and measure its memory (Linux).

    python benchmarks/figures/main_job.py [--out DIR] [extra gdabench compare arguments ...]
    python benchmarks/figures/main_job.py -D gda.speculate=false      # without training ahead

Runs ``gdabench compare --designers ga,cppn,gda --env simple`` and prints the wall time, the
peak RSS of the largest process (what ``/usr/bin/time -v`` reports) and the peak RSS summed
over the whole process tree (gda's training process, inductor's compile workers), sampled
every second, then each designer's time and gda's per-generation training and sampling medians.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd


def tree_rss_kb(root: int) -> int:
    """Resident memory of ``root`` and all its descendants, in kB (from /proc)."""
    parents, rss = {}, {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            status = (entry / "status").read_text()
        except OSError:
            continue
        parents[int(entry.name)] = int(fields[1])
        rss[int(entry.name)] = next(
            (int(line.split()[1]) for line in status.splitlines() if line.startswith("VmRSS:")), 0
        )
    total = 0
    for pid in rss:
        ancestor = pid
        while ancestor not in (root, 0, 1) and ancestor in parents:
            ancestor = parents[ancestor]
        if ancestor == root:
            total += rss[pid]
    return total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, help="run directory (default: a temporary one)")
    args, extra = parser.parse_known_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="main-job-")) / "run"
    command = [
        "gdabench",
        "compare",
        "--designers",
        "ga,cppn,gda",
        "--env",
        "simple",
        "--out",
        str(out),
        "--quiet",
        *extra,
    ]
    start = time.perf_counter()
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL)
    peak = 0
    while process.poll() is None:
        peak = max(peak, tree_rss_kb(process.pid))
        time.sleep(1.0)
    wall = time.perf_counter() - start
    if process.returncode:
        sys.exit(f"gdabench exited with code {process.returncode}")
    largest = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    print(f"command: {' '.join(command)}")
    print(f"wall time: {int(wall // 60)} min {wall % 60:.1f} s")
    print(f"peak RSS: largest process {largest / 1024:.0f} MB, summed over the process tree {peak / 1024:.0f} MB")
    rows = pd.read_parquet(out / "evaluations.parquet")
    for designer, group in rows.groupby("designer", sort=False):
        print(f"{designer}: {group['elapsed_seconds'].max():.1f} s")
    gens = rows[rows["designer"] == "gda"].groupby("generation").first().iloc[1:]
    ahead = int((gens["trained_ahead"] == True).sum()) if "trained_ahead" in gens else 0  # noqa: E712 - None in generation 0
    print(
        f"gda per generation: training {gens['train_seconds'].median():.2f} s, sampling "
        f"{gens['sample_seconds'].median():.2f} s "
        f"(medians); {ahead} of {len(gens)} trained generations had their model trained ahead"
    )
    print(f"results: {out}" if args.out else f"results: {out} (temporary)")


if __name__ == "__main__":
    main()
