"""CPU cores a trial may borrow: the run's spare cores, once no trial is waiting for one.

A run uses ``--jobs`` cores (by default every CPU), one per running trial.  When no trial is
left waiting and fewer trials run than there are cores, the spare cores are free, and a
designer that can use more than one core (``gda`` trains the next generation's model ahead on a
second core) may borrow one with :func:`borrow`, which the trial's host lends it
(:meth:`gdabench.designer.Designer.lend_cores`), until its trial ends.  Borrowing never changes a
result, only how long it takes, so it may depend on what else is running.

Outside a run (a designer driven by hand), a core is spare if the process may use more than one.
"""

from __future__ import annotations

import os
import sys
import time
from typing import Any

from ..cpu import cpu_count, requested_threads, set_numba_threads
from ..envs.voxel import PARALLEL_FROM

_pool: Any = None  # shared count of spare cores (multiprocessing.Value), set in a run's trial processes
_held: Any = None  # cores this process's current trial holds (multiprocessing.Value)
_outside_run = True


def install(pool: Any, held: Any) -> None:
    """Make this process take part in a run's core accounting: ``pool`` counts the run's spare
    cores and ``held`` this process's borrowed ones (``multiprocessing.Value``; None: never lend)."""
    global _pool, _held, _outside_run
    _pool, _held, _outside_run = pool, held, False


def uninstall() -> None:
    """Back to outside a run (the run this process took part in is over)."""
    global _pool, _held, _outside_run
    release()
    _pool, _held, _outside_run = None, None, True


def borrow() -> bool:
    """One more core for the rest of this trial: True if this trial holds one or one was spare."""
    if _outside_run:
        return cpu_count() >= 2
    if _pool is None:
        return False
    with _pool.get_lock():
        if _held.value:
            return True
        if _pool.value > 0:
            _pool.value -= 1
            _held.value += 1
            return True
    return False


def release() -> None:
    """Give back what this process's trial borrowed (its trial ended)."""
    if _pool is None:
        return
    with _pool.get_lock():
        _pool.value += _held.value
        _held.value = 0


# -- the voxel engine's threads --------------------------------------------------------------------
#: a core counts as taken when others kept it this busy since the last look
TAKEN = 0.5


class CpuShare:
    """How much of the machine other processes used since the last look (Linux's /proc/stat against this
    process's own CPU time; elsewhere unknown, so counted as taken)."""

    def __init__(self) -> None:
        self._last = self._sample()

    @staticmethod
    def _sample() -> tuple[float, float, float] | None:
        try:
            with open("/proc/stat") as fh:
                fields = [int(v) for v in fh.readline().split()[1:]]
        except (OSError, ValueError):
            return None
        ticks = os.sysconf("SC_CLK_TCK")
        busy = (sum(fields) - fields[3] - (fields[4] if len(fields) > 4 else 0)) / ticks  # all but idle, iowait
        own = time.process_time()
        return time.monotonic(), busy, own

    def others(self) -> float | None:
        """Cores kept busy by other processes since the last call (None where it cannot be known)."""
        now = self._sample()
        last, self._last = self._last, now
        if now is None or last is None or now[0] - last[0] < 0.05:
            return None
        return max(0.0, (now[1] - last[1]) - (now[2] - last[2])) / (now[0] - last[0])


def engine_threads(batch: int, share: CpuShare | None, requested: str | None = None) -> int:
    """Numba threads for the voxel engine in a trial that runs in its own process, before a generation.

    One, unless the user asks for more (``requested``, from :data:`gdabench.cpu.THREADS_VARIABLE`), or the trial has the
    machine to itself: its batch is large enough to split (:data:`PARALLEL_FROM`), the run lends it spare
    cores (:func:`borrow`) and no other process kept a core busy since the last generation.  Numba's threads
    wait for each other at every step: one on a core another process holds makes every step wait for it,
    which made a run several times slower (146 s against 39 s with one thread beside one busy process).
    """
    explicit = requested_threads(requested)
    if explicit is not None:
        return explicit
    if batch < PARALLEL_FROM or share is None or not borrow():
        return 1
    others = share.others()
    if others is None:
        return 1
    return max(1, min(cpu_count(), int(cpu_count() - others + 1 - TAKEN)))


def use_engine_threads(threads: int) -> None:
    """Set the voxel engine's threads in this process (only where the engine, and so Numba, is loaded)."""
    if "numba" in sys.modules:
        set_numba_threads(threads)
