"""Executors: where the bodies of one generation are evaluated.

* ``serial``: one body after the other in the driver process (no timeout: a hang hangs the run,
  a crash ends it); with a timeout, one body after the other in one worker process;
* ``process``: a supervised pool of local worker processes (:mod:`gdabench.pool`), the
  default for more than one worker;
* ``ray``: Ray tasks on a local Ray instance or an existing cluster (:mod:`gdabench.ray_executor`).

Results always come back in task order and an evaluation depends only on its task (body,
evaluation seed, environment and controller recipes), so a run's table does not depend on the
executor, the number of workers, or which evaluation finishes first.  Designers stay in the
driver process.
"""

from __future__ import annotations

import abc
import os
from typing import Any, Mapping, Sequence

from .errors import ConfigError
from .evaluation import EvalOutcome, EvalTask, evaluate
from .specs import Factory

EXECUTORS = ("serial", "process", "ray")


class Executor(abc.ABC):
    name: str = ""

    @abc.abstractmethod
    def map(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        """Evaluate ``tasks``; outcome ``i`` belongs to task ``i``."""

    def close(self) -> None:
        """Release workers."""

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class SerialExecutor(Executor):
    """Evaluate in the driver process, reusing the driver's environment and controller."""

    name = "serial"

    def __init__(self, prebuilt: Mapping[str, Any] | None = None):
        self.prebuilt = dict(prebuilt or {})

    def map(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        return [evaluate(task, self.prebuilt) for task in tasks]


class ProcessExecutor(Executor):
    """Local worker processes; a dead or hung worker costs only its own evaluation."""

    name = "process"

    def __init__(self, workers: int, *, timeout: float | None = None, warm: Sequence[Factory] = ()):
        from .pool import ProcessBackend, WorkerPool

        self.workers = workers
        self._pool = WorkerPool(ProcessBackend(warm), workers, timeout=timeout)

    def map(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        return self._pool.map(tasks)

    def close(self) -> None:
        self._pool.close()


def resolve_workers(kind: str | None, workers: int | None) -> tuple[str, int | None]:
    """The executor and worker count a run uses: ``kind=None`` is serial for one worker (or
    none given) and processes otherwise; ``process`` without a count uses every CPU; ``ray``
    without a count runs as many tasks at once as the Ray cluster has CPUs (``None``)."""
    if workers is not None and workers < 1:
        raise ConfigError(f"workers must be at least 1, got {workers}")
    kind = kind or ("serial" if (workers or 1) == 1 else "process")
    if kind not in EXECUTORS:
        raise ConfigError(f"unknown executor {kind!r}; known executors: {', '.join(EXECUTORS)}")
    if kind == "serial":
        if workers not in (None, 1):
            raise ConfigError(f"the serial executor runs one evaluation at a time; use --executor process for {workers} workers")
        return kind, 1
    if kind == "process":
        return kind, workers or os.cpu_count() or 1
    return kind, workers


def make_executor(
    kind: str | None,
    workers: int | None = None,
    prebuilt: Mapping[str, Any] | None = None,
    *,
    timeout: float | None = None,
    warm: Sequence[Factory] = (),
    ray_address: str | None = None,
) -> Executor:
    """Build an executor (see :func:`resolve_workers` for the defaults).

    ``prebuilt`` maps recipe keys to the driver's own environment and controller (reused by
    the serial executor); ``warm`` are the recipes worker processes build before their first
    body; ``timeout`` limits each evaluation in seconds (the serial executor then evaluates in
    one worker process, since a running Python function cannot be stopped from outside).
    """
    kind, count = resolve_workers(kind, workers)
    if timeout is not None and not timeout > 0:
        raise ConfigError(f"timeout must be a positive number of seconds, got {timeout}")
    if ray_address and kind != "ray":
        raise ConfigError("--ray-address needs --executor ray")
    if kind == "serial":
        if timeout is None:
            return SerialExecutor(prebuilt)
        executor = ProcessExecutor(1, timeout=timeout, warm=warm)
        executor.name = "serial"
        return executor
    if kind == "process":
        return ProcessExecutor(count or 1, timeout=timeout, warm=warm)
    from .ray_executor import RayExecutor

    return RayExecutor(count, address=ray_address, timeout=timeout, warm=warm)
