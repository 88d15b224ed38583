"""Starting the harness's worker processes, which are spawned (a fork of a process running torch's
threads can deadlock), without what spawning does by default that a user would not expect.

- A spawned child imports the script that started the run (``__main__``) again, so a script that calls
  :func:`gdabench.compare` without ``if __name__ == "__main__":`` would start the run again in every
  worker.  The children skip it unless the run's plugins are defined there (they need it to unpickle
  them); the runner says which with :func:`scripts_shared`.
- Ctrl-C in a terminal reaches every process of the group, and a child still setting itself up would
  print a traceback.  Children start with Ctrl-C ignored (they inherit it across ``exec``); the process
  that started them decides what an interrupt means and stops them.
- Workers run side by side, one core each (:func:`one_core`).
- A worker dies with the process that started it (:func:`process`): the moment it is killed, not a
  second later, so that a killed run's workers cannot write into its directory after its one writer
  has gone.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import types
from multiprocessing.context import SpawnContext
from multiprocessing.process import BaseProcess
from typing import Any, Callable, Iterator, Sequence

_share_script = True


@contextlib.contextmanager
def scripts_shared(share: bool) -> Iterator[None]:
    """Within this block, whether children started here import the user's script (``__main__``)."""
    global _share_script
    previous, _share_script = _share_script, share
    try:
        yield
    finally:
        _share_script = previous


@contextlib.contextmanager
def _without_script() -> Iterator[None]:
    main = sys.modules["__main__"]
    sys.modules["__main__"] = types.ModuleType("__main__")  # what spawning reads to find the script: nothing
    try:
        yield
    finally:
        sys.modules["__main__"] = main


@contextlib.contextmanager
def _ctrl_c_ignored() -> Iterator[None]:
    """Ignore Ctrl-C while a child starts (a Ctrl-C in those milliseconds is lost: press it again)."""
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGINT) is None:
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


#: run in a new worker before anything else of it is unpickled (so before any module it needs is imported)
_DIE_WITH_PARENT = """
import os
try:
    import ctypes
    ctypes.CDLL(None).prctl(1, 9)  # PR_SET_PDEATHSIG, SIGKILL: the kernel kills us when the parent dies
except (OSError, AttributeError, TypeError):  # not Linux: the watcher threads (exit_when_orphaned) remain
    pass
if os.getppid() != parent:  # it died before the line above could take effect
    os._exit(0)
"""


class _DieWithParent:
    """Unpickles, in the worker, as a call that ties the worker's life to its parent's."""

    def __init__(self, parent: int):
        self.parent = parent

    def __reduce__(self) -> tuple[Any, ...]:
        return exec, (_DIE_WITH_PARENT, {"parent": self.parent})


def process(ctx: SpawnContext, target: Callable[..., Any], args: Sequence[Any], **options: Any) -> BaseProcess:
    """A spawned process running ``target(*args)`` that dies with this process, from its first line on.

    A spawned child first unpickles its target and arguments, importing what they need (a second or
    more: numpy, torch), and only then runs the target.  So the target here is the built-in ``exec``,
    and its namespace unpickles the parent watch before the real target and arguments.
    """
    namespace = {"watch": _DieWithParent(os.getpid()), "target": target, "args": tuple(args)}
    return ctx.Process(target=exec, args=("target(*args)", namespace), **options)


def start(process: BaseProcess) -> None:
    """Start a spawned worker process with Ctrl-C ignored, importing the user's script only if it must."""
    with _ctrl_c_ignored(), (contextlib.nullcontext() if _share_script else _without_script()):
        process.start()


def one_core() -> None:
    """Run this worker's Numba kernels (the voxel engine's) on one thread: the run starts one worker per core.

    Numba's default, a thread per CPU in every process, makes the workers' threads wait for each other's
    cores: two co-design trials side by side ran 2,557-2,702 env steps/s together with two threads each
    against 4,167-4,422 with one (docs/benchmarks/codesign-speed.md).  Results do not depend on it.
    """
    from .cpu import worker_numba_threads

    worker_numba_threads()


def from_script(factory: object) -> bool:
    """Whether a plugin factory (an import string or a callable) is defined in the user's script."""
    module = factory.partition(":")[0] if isinstance(factory, str) else getattr(factory, "__module__", None)
    return module == "__main__"
