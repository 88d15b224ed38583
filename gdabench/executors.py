"""Executors: where the bodies of one generation are evaluated.

Results always come back in task order, so a run's table does not depend on the executor or on
which evaluation finishes first.  Designers stay in the driver process.
"""

from __future__ import annotations

import abc
import multiprocessing
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Mapping, Sequence

from .errors import ConfigError
from .evaluation import ERROR, EvalOutcome, EvalTask, evaluate

EXECUTORS = ("serial", "process")


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
    """A pool of local worker processes (spawned, so torch and threads are safe)."""

    name = "process"

    def __init__(self, workers: int):
        self.workers = workers
        self._pool: ProcessPoolExecutor | None = None

    def _get_pool(self) -> ProcessPoolExecutor:
        if self._pool is None:
            self._pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=multiprocessing.get_context("spawn"))
        return self._pool

    def map(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        futures = [self._get_pool().submit(evaluate, task) for task in tasks]
        outcomes = []
        for future in futures:
            try:
                outcomes.append(future.result())
            except BrokenProcessPool:
                outcomes.append(EvalOutcome(float("nan"), ERROR, "worker process died"))
        if any(o.message == "worker process died" for o in outcomes):
            self.close()  # a fresh pool replaces the broken one on the next generation
        return outcomes

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


def make_executor(kind: str | None, workers: int, prebuilt: Mapping[str, Any] | None = None) -> Executor:
    """``kind=None`` picks serial for one worker and processes otherwise."""
    if workers < 1:
        raise ConfigError(f"workers must be at least 1, got {workers}")
    kind = kind or ("serial" if workers == 1 else "process")
    if kind == "serial":
        return SerialExecutor(prebuilt)
    if kind == "process":
        return ProcessExecutor(workers)
    raise ConfigError(f"unknown executor {kind!r}; known executors: {', '.join(EXECUTORS)}")
