"""Remake ``tests/slow_tests.txt`` from a pytest run's ``--durations=0`` report.

    python -m pytest -n 2 --durations=0 -q | tee durations.txt
    python tests/support/slow_tests.py durations.txt [--over 5]

A test is slow when its setup, call and teardown took more than ``--over`` seconds together in that run.
"""

from __future__ import annotations

import argparse
import re
from collections import defaultdict
from pathlib import Path

LINE = re.compile(r"^\s*([0-9.]+)s (setup|call|teardown)\s+(\S+)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("report", type=Path)
    parser.add_argument("--over", type=float, default=5.0)
    args = parser.parse_args()
    seconds: dict[str, float] = defaultdict(float)
    for line in args.report.read_text().splitlines():
        match = LINE.match(line)
        if match:
            seconds[match.group(3)] += float(match.group(1))
    slow = sorted((s, node) for node, s in seconds.items() if s > args.over)
    header = [
        f"# tests over {args.over:g} s in {args.report.name} (seconds, node id); remade by tests/support/slow_tests.py"
    ]
    out = Path(__file__).resolve().parents[1] / "slow_tests.txt"
    out.write_text("\n".join(header + [f"{s:8.1f} {node}" for s, node in reversed(slow)]) + "\n")
    print(f"{len(slow)} slow tests, {sum(s for s, _ in slow):.0f} s of {sum(seconds.values()):.0f} s; wrote {out}")


if __name__ == "__main__":
    main()
