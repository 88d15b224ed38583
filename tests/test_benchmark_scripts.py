"""Every measurement script under benchmarks/ still starts: its imports resolve and it parses its options.

The figures in docs/benchmarks/ cite these scripts as the commands that reproduce them, so a script
broken by a refactor (a removed helper it imports) would leave a figure nobody can reproduce.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(p for p in (ROOT / "benchmarks").glob("*.py") if "__main__" in p.read_text())


def test_the_scripts_are_found():
    assert {"main_job.py", "gda_step.py", "scaling_table.py", "random_sampler.py"} <= {p.name for p in SCRIPTS}


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_a_benchmark_script_starts_and_shows_its_usage(script):
    done = subprocess.run(
        [sys.executable, str(script), "--help"], capture_output=True, text=True, cwd=ROOT, timeout=300
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "usage:" in done.stdout
