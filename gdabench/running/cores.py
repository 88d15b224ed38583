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

from typing import Any

from ..execution.options import cpu_count

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
