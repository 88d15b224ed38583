"""The voxel engine's threads in a trial's own process: one, unless the trial has the machine to itself and
a batch worth splitting, or the user says otherwise (``GDABENCH_ENGINE_THREADS``)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from gdabench.running import cores


class Share:
    def __init__(self, others):
        self.value = others

    def others(self):
        return self.value


@pytest.fixture
def two_cores(monkeypatch):
    monkeypatch.setattr(cores, "cpu_count", lambda: 2)
    monkeypatch.setattr(cores, "borrow", lambda: True)


def test_a_large_batch_on_an_idle_machine_uses_every_core(two_cores):
    assert cores.engine_threads(25, Share(0.05)) == 2


@pytest.mark.parametrize("others", [1.0, 0.6, None], ids=["one busy process", "most of a core", "unknown"])
def test_a_core_someone_else_uses_is_not_the_engines(two_cores, others):
    """Beside one busy process, Numba's second thread waits for the busy core at every step (146 s against
    39 s with one thread): the engine keeps to one."""
    assert cores.engine_threads(25, Share(others)) == 1


def test_a_small_batch_or_no_spare_core_runs_on_one_thread(two_cores, monkeypatch):
    assert cores.engine_threads(cores.PARALLEL_FROM - 1, Share(0.0)) == 1
    monkeypatch.setattr(cores, "borrow", lambda: False)  # the run's cores are all taken by its trials
    assert cores.engine_threads(25, Share(0.0)) == 1


def test_the_user_sets_them(two_cores):
    assert cores.engine_threads(1, Share(2.0), "3") == 3
    assert cores.engine_threads(25, Share(0.0), "auto") == 2


def test_ppo_learns_on_the_torch_threads_it_asked_for(tmp_path):
    """Numba's OpenMP pool, as it starts (at the engine's first step, inside a training), set the OpenMP thread
    count that torch reads as its own: every Adam step of PPO then ran on two threads, and with the other core
    busy 3 bodies at 512 timesteps learned in 54 s instead of 11.  The pool starts once per process, so the check
    runs in a fresh one."""
    script = """
import sys, gdabench, torch
from gdabench.controllers.ppo import update
seen, call = set(), update.LockstepUpdate.__call__
def spy(self, batch):
    seen.add(torch.get_num_threads())
    return call(self, batch)
update.LockstepUpdate.__call__ = spy
gdabench.compare("random", "walker", controller="ppo[timesteps=128,n_steps=64,batch_size=64,n_epochs=1]",
                 seeds=[0], budget=1, population=1, out=sys.argv[1], progress=False, reevaluate="off")
print(sorted(seen))
"""
    env = {**os.environ, "NUMBA_NUM_THREADS": "2"}
    env.pop("OMP_NUM_THREADS", None)
    out = subprocess.run([sys.executable, "-c", script, str(tmp_path / "r")], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split("\n")[-2] == "[1]"  # ppo's default: one torch thread per training
