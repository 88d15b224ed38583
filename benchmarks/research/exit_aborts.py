"""How often a process that read parquet tables aborts at exit, by how it read them.

Research, kept for the record (``benchmarks/research/``): the measurement behind reading parquet through Arrow's own
reader; its ``bytesio`` arm is a way gdabench no longer reads.

    python benchmarks/research/exit_aborts.py --runs 80 --processes 6      # about 4 minutes on 2 cores

Each run is a fresh Python process that reads a parquet file three times and exits; ``--processes``
loops of ``--runs`` runs each go at once for every way of reading, side by side, and the count of
processes that exited non-zero (pyarrow's "terminate called without an active exception", exit -6)
is printed per way:

* ``bytesio``: ``pandas.read_parquet(io.BytesIO(data))``, how gdabench read before 5 December 2026;
* ``gdabench``: :func:`gdabench.results.read_parquet`, Arrow's own file and buffer.

The aborts are rare (about one process in 75 on the 2-core machine) and depend on load: compare the
ways in one run, never across runs.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
READS = {
    "bytesio": "import io, pandas as pd\nfor _ in range(3): pd.read_parquet(io.BytesIO(PATH.read_bytes()))",
    "gdabench": "from gdabench.results import read_parquet\nfor _ in range(3): read_parquet(PATH)",
}


def aborted(way: str, path: Path, runs: int) -> int:
    code = f"from pathlib import Path\nPATH = Path({str(path)!r})\n{READS[way]}\n"
    return sum(subprocess.run([sys.executable, "-c", code], capture_output=True).returncode != 0 for _ in range(runs))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=80, help="processes per loop")
    parser.add_argument("--processes", type=int, default=6, help="loops at once per way of reading")
    parser.add_argument("--file", type=Path, default=ROOT / "results" / "reference" / "simple" / "evaluations.parquet")
    args = parser.parse_args()
    jobs = [way for _ in range(args.processes) for way in READS]
    with ThreadPoolExecutor(len(jobs)) as pool:
        counts = list(pool.map(lambda way: aborted(way, args.file, args.runs), jobs))
    for way in READS:
        bad = sum(c for j, c in zip(jobs, counts) if j == way)
        print(f"{way:9s} {bad} of {args.runs * args.processes} processes aborted")
    return 0


if __name__ == "__main__":
    sys.exit(main())
