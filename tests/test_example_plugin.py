"""The worked example plugin (plugins/gdabench-mapelites), installed with pip like any package."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from test_plugins import gdabench_cli, pip_install

EXAMPLE = Path(__file__).resolve().parents[1] / "plugins" / "gdabench-mapelites"


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    return pip_install(EXAMPLE, tmp_path_factory.mktemp("site"))


def test_listed_with_its_package_and_runs_in_compare(site, tmp_path):
    listing = gdabench_cli("list", "designers", path=site)
    assert listing.returncode == 0, listing.stderr
    line = next(ln for ln in listing.stdout.splitlines() if "map-elites" in ln)
    assert "gdabench-mapelites 0.1.0" in line
    out = tmp_path / "run"
    run = gdabench_cli(
        "compare",
        "--designers",
        "map-elites,ga",
        "--env",
        "simple",
        "--budget",
        "100",
        "--out",
        str(out),
        "-q",
        path=site,
    )
    assert run.returncode == 0, run.stderr
    meta = json.loads((out / "run.json").read_text())
    assert meta["versions"]["plugins"]["gdabench-mapelites"] == "0.1.0"


def test_the_plugins_own_tests_pass_when_installed(site):
    env = dict(os.environ, PYTHONPATH=str(site))
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(EXAMPLE / "tests")],
        capture_output=True,
        text=True,
        env=env,
        cwd=EXAMPLE,
    )
    assert result.returncode == 0, result.stdout + result.stderr
