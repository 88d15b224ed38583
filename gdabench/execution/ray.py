"""Evaluating bodies on Ray: a local Ray instance, or an existing cluster (``--ray-address``).

Ray is an optional extra (``pip install 'gdabench[ray]'``) imported only when this executor is
chosen.  The workers are Ray actors (1 CPU each, never restarted), supervised by the same pool
as local processes (:mod:`gdabench.execution.pool`): each actor builds the environment once, takes
one batch of bodies at a time, and a batch that kills its actor or runs past the timeout costs only
its own evaluations while a fresh actor takes the dead one's place.  Because a batch is only sent to
an idle, ready actor, the timeout measures the evaluation, not time spent queued on a busy
cluster or starting a worker.  The designer stays in the driver.
"""

from __future__ import annotations

import logging
import math
import os
import sys
from dataclasses import dataclass
from typing import Any, Sequence

from .. import spawning
from ..errors import ConfigError, one_line
from ..specs import Factory
from ..statuses import ERROR
from ..strategy import EvalOutcome, EvalTask
from .evaluation import evaluate_batch, prepare
from .executor import Executor
from .pool import DIED, READY, RESULT, Backend, Slot, WorkerGone, WorkerPool


def import_ray() -> Any:
    try:
        import ray
    except ImportError:
        raise ConfigError("the ray executor needs Ray: pip install 'gdabench[ray]'") from None
    return ray


class Evaluator:
    """The actor: holds the environment and controller, evaluates one batch of bodies per call."""

    def __init__(self, warm: Sequence[Factory]):
        spawning.one_core()
        prepare(warm)

    def ready(self) -> bool:
        return True

    def evaluate(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        return evaluate_batch(tasks)


@dataclass(eq=False)
class _Actor:
    handle: Any
    pending: Any  # ObjectRef of the call in flight: ready() first, then each evaluate()


class RayBackend(Backend):
    def __init__(self, ray: Any, warm: Sequence[Factory]):
        self.ray, self.warm = ray, tuple(warm)
        self._cls = ray.remote(num_cpus=1, max_restarts=0, max_task_retries=0)(Evaluator)

    def start(self) -> _Actor:
        handle = self._cls.remote(self.warm)
        return _Actor(handle, handle.ready.remote())

    def send(self, worker: _Actor, tasks: Sequence[EvalTask]) -> None:
        try:
            worker.pending = worker.handle.evaluate.remote(list(tasks))
        except self.ray.exceptions.RayActorError as exc:
            raise WorkerGone from exc

    def wait(self, slots: Sequence[Slot], timeout: float | None) -> list[tuple[Slot, str, Any]]:
        ray = self.ray
        by_ref = {slot.worker.pending: slot for slot in slots}
        done, _ = ray.wait(list(by_ref), num_returns=1, timeout=timeout)
        if done:  # collect everything else that finished meanwhile
            done, _ = ray.wait(list(by_ref), num_returns=len(by_ref), timeout=0)
        events: list[tuple[Slot, str, Any]] = []
        for ref in done:
            slot = by_ref[ref]
            try:
                value = ray.get(ref)
            except ray.exceptions.RayActorError:
                events.append((slot, DIED, "worker process died"))
                continue
            except ray.exceptions.RayError as exc:  # e.g. the task could not be unpickled on the worker
                if not slot.ready:
                    events.append((slot, DIED, f"ray: {one_line(exc)}"))
                else:
                    events.append((slot, RESULT, EvalOutcome(math.nan, ERROR, f"ray: {one_line(exc)}")))
                continue
            events.append((slot, RESULT, value) if slot.ready else (slot, READY, None))
        return events

    def kill(self, worker: _Actor) -> None:
        self.ray.kill(worker.handle, no_restart=True)


class RayConnection:
    """This process's connection to Ray: started here (a local instance) or joined; a context manager.

    Ray may already be connected (inside a trial actor, or a test's cluster): then it is used
    as it is and left alone on close.
    """

    def __init__(self, address: str | None = None, num_cpus: int | None = None):
        ray = self.ray = import_ray()
        self._started = False
        if not ray.is_initialized():
            options: dict[str, Any] = {"include_dashboard": False, "logging_level": logging.WARNING}
            if address:
                options["address"] = address
            else:
                # a local instance runs on this machine: give its workers the driver's import path,
                # so that plugins importable here (installed or on PYTHONPATH) import there too
                options["num_cpus"] = num_cpus
                options["runtime_env"] = {"env_vars": {"PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}}
            try:
                ray.init(**options)
            except Exception as exc:  # noqa: BLE001 - connection failures come in several types
                where = f"the Ray cluster at {address}" if address else "a local Ray instance"
                raise ConfigError(f"cannot start or reach {where}: {one_line(exc)}") from None
            self._started = True

    def cpus(self) -> int:
        return max(1, int(self.ray.cluster_resources().get("CPU", 1)))

    def close(self) -> None:
        if self._started:
            self.ray.shutdown()
            self._started = False

    def __enter__(self) -> RayConnection:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class RayExecutor(Executor):
    """A pool of ``workers`` Ray actors evaluating one batch each at a time."""

    def __init__(
        self, workers: int, *, address: str | None = None, timeout: float | None = None, warm: Sequence[Factory] = ()
    ):
        self._connection = RayConnection(address, workers)
        self.workers = workers
        self._pool = WorkerPool(RayBackend(self._connection.ray, warm), workers, timeout=timeout)

    def map(self, tasks: Sequence[EvalTask], batch: int = 1) -> list[EvalOutcome]:
        return self._pool.map(tasks, batch)

    def close(self) -> None:
        self._pool.close()
        self._connection.close()
