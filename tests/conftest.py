"""Fixtures shared by the tests: the faulty plugin, installed once; a guard on the signal handlers."""

from __future__ import annotations

import importlib
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from gdabench.plugins import Registry

FIXTURE = Path(__file__).parent / "fixtures" / "faulty_plugin"
#: tests measured to take longer than a few seconds (``python tests/support/slow_tests.py`` remakes the list from a
#: run's ``--durations=0`` report); they are marked ``slow``, so ``-m "not slow"`` runs the fast part
SLOW = Path(__file__).parent / "slow_tests.txt"


def pytest_collection_modifyitems(config, items):
    slow = {line.split()[-1] for line in SLOW.read_text().splitlines() if line.strip() and not line.startswith("#")}
    for item in items:
        if item.nodeid in slow:
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def faulty_site(tmp_path_factory) -> Path:
    """A directory holding the faulty plugin package (environments that fail on purpose), for PYTHONPATH."""
    src = tmp_path_factory.mktemp("src") / "faulty_plugin"
    shutil.copytree(FIXTURE, src)
    site = tmp_path_factory.mktemp("site")
    cmd = [
        sys.executable,
        "-m",
        "pip",
        "install",
        "--quiet",
        "--no-deps",
        "--no-build-isolation",
        "--target",
        str(site),
        str(src),
    ]
    subprocess.run(cmd, check=True, capture_output=True)
    return site


@pytest.fixture
def reg(faulty_site, monkeypatch) -> Registry:
    """A registry with the built-ins and the faulty plugin, importable by worker processes too."""
    monkeypatch.syspath_prepend(str(faulty_site))
    return Registry(entry_points=False, extra_plugins={"faulty": importlib.import_module("gdabench_faulty.plugin")})


@pytest.fixture(autouse=True)
def signal_handlers_left_as_found():
    """A test that changes a handler changes it for every later test in its process, and for the
    processes those start (an ignored SIGINT is inherited): the reliability tests' Ctrl-C then does nothing."""
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    yield
    after = {s: signal.getsignal(s) for s in before}
    assert after == before, f"the test changed signal handlers: {before} -> {after}"
