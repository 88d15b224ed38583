"""Produce the committed reference results: the main job at full size, with its report.

    python benchmarks/ops/reference_results.py                  # ga,cppn,gda on simple, 1000 evaluations, seeds 0..9
    python benchmarks/ops/reference_results.py --designers ga,random --out /tmp/ref   # any other comparison
    python benchmarks/ops/reference_results.py --config experiments/walker.toml --out results/reference/walker \
        --reevaluate 3x5 --primary gda,ga

It runs ``gdabench compare`` (niced, one thread per process: the machine is shared), resumes
the run if a previous attempt was interrupted, re-evaluates a run made without re-evaluation
(``--reevaluate``: ``gdabench reevaluate``, resumable), writes the report (``--primary`` names a
primary comparison for a run whose experiment has none), prints every file's size and
fails if the directory is larger than ``--max-mb`` (committed results must stay small).  The README's
headline plot and table are ``<out>/report/best_so_far.png`` and the table in
``<out>/report/summary.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _status(out: Path) -> str | None:
    try:
        return json.loads((out / "run.json").read_text()).get("status")
    except (OSError, ValueError):
        return None


def _committed(out: Path) -> list[Path]:
    """The files of ``out`` that ``git add`` would take (a run's ``.gitignore`` leaves out what only resuming
    or replaying on this machine needs); every file when ``out`` is outside the repository."""
    listed = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard", "--", str(out.resolve())],
                            cwd=ROOT, capture_output=True, text=True)
    if listed.returncode != 0:
        return sorted(p for p in out.rglob("*") if p.is_file())
    return sorted(ROOT / line for line in listed.stdout.splitlines() if (ROOT / line).is_file())


def _gdabench(*args: str) -> None:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    command = ["nice", "-n", "10", sys.executable, "-m", "gdabench", *args]
    print("+", " ".join(command[3:]), flush=True)
    code = subprocess.run(command, env=env).returncode
    if code:
        raise SystemExit(code)  # gdabench has printed why, in one line


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", type=Path, help="experiment file (replaces the 4 below)")
    parser.add_argument("--designers", default="ga,cppn,gda")
    parser.add_argument("--env", default="simple")
    parser.add_argument("--budget", default="1000")
    parser.add_argument("--seeds", default="0..9")
    parser.add_argument("--workers", default="1")
    parser.add_argument("--out", type=Path, help="default: results/reference/simple in the repository")
    parser.add_argument("--max-mb", type=float, default=5.0, help="fail if what would be committed is larger")
    parser.add_argument("--reevaluate", help="TOPxSEEDS: re-evaluate the run's trials (gdabench reevaluate)")
    parser.add_argument("--primary", help="A,B: the report tests A against B alone (gdabench report --primary)")
    args = parser.parse_args()

    out: Path = args.out
    if out is None:  # relative, so that the committed run.json and report name no machine's paths
        os.chdir(ROOT)
        out = Path("results") / "reference" / "simple"
    status = _status(out)
    if status is None:
        what = (["--config", str(args.config)] if args.config else
                ["--designers", args.designers, "--env", args.env, "--budget", args.budget, "--seeds", args.seeds])
        _gdabench("compare", *what, "--workers", args.workers, "--out", str(out), "--quiet", "--no-report")
    elif status != "complete":
        _gdabench("compare", "--resume", str(out), "--workers", args.workers, "--quiet", "--no-report")
    if args.reevaluate:
        _gdabench("reevaluate", str(out), "--reevaluate", args.reevaluate, "--jobs", args.workers)
    _gdabench("report", str(out), *(["--primary", args.primary] if args.primary else []))

    files = _committed(out)
    total = sum(p.stat().st_size for p in files)
    for p in files:
        print(f"{p.stat().st_size / 1e3:9.1f} kB  {p.relative_to(out.resolve())}")
    print(f"{total / 1e6:9.2f} MB  total in {out}")
    if total > args.max_mb * 1e6:
        print(f"too large to commit: {total / 1e6:.2f} MB > {args.max_mb} MB", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
