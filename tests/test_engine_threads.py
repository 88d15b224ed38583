"""The voxel engine's threads in a trial's own process: one, unless the trial has the machine to itself and
a batch worth splitting, or the user says otherwise (``GDABENCH_ENGINE_THREADS``)."""

from __future__ import annotations

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
