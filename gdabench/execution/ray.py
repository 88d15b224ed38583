"""Workers on Ray: a local Ray instance, or an existing cluster (``--ray-address``).

Ray is an optional extra (``pip install 'gdabench[ray]'``) imported only when it is chosen.
:class:`RayActors` are the Ray implementation of the one worker layer
(:mod:`gdabench.execution.workers`), for trials and evaluations alike.  Evaluation actors are
supervised by the same pool as local processes (:mod:`gdabench.execution.pool`): each builds the
environment once, takes one batch of bodies at a time, and a batch that kills its actor or runs past
the timeout costs only its own evaluations while a fresh actor takes the dead one's place.  Because a
batch is only sent to an idle, ready actor, the timeout measures the evaluation, not time spent queued
on a busy cluster or starting a worker.  The designer stays in the driver.
"""

from __future__ import annotations

import logging
import os
import sys
from dataclasses import dataclass
from typing import Any, Sequence

from ..errors import ConfigError, one_line
from ..specs import Factory
from .pool import PoolExecutor, evaluators
from .workers import Answer, Make, WorkerGone, Workers, answer


def import_ray() -> Any:
    try:
        import ray
    except ImportError:
        raise ConfigError("the ray executor needs Ray: pip install 'gdabench[ray]'") from None
    return ray


class Served:
    """The actor: builds a worker's server and answers calls on it (no notes: ``make`` is given None)."""

    def __init__(self, make: Make):
        self.server = make(None)

    def call(self, method: str, args: Sequence[Any]) -> tuple[bool, Any]:
        return answer(self.server, method, args)


@dataclass(eq=False)
class _Actor:
    handle: Any
    pending: Any = None  # ObjectRef of the call in flight


class RayActors(Workers):
    """Workers as Ray actors (1 CPU each, never restarted), on a local Ray instance or a cluster.

    ``label`` names them in messages ("worker process died: ..."); ``close`` gives idle workers
    ``grace`` seconds to close their servers.
    """

    def __init__(self, ray: Any, make: Make, *, label: str, grace: float):
        self.ray, self.make, self.label, self.grace = ray, make, label, grace
        self._cls = ray.remote(num_cpus=1, max_restarts=0, max_task_retries=0)(Served)

    def start(self) -> _Actor:
        return _Actor(self._cls.remote(self.make))

    def call(self, worker: _Actor, method: str, *args: Any) -> None:
        try:
            worker.pending = worker.handle.call.remote(method, args)
        except self.ray.exceptions.RayActorError as exc:
            raise WorkerGone from exc

    def wait(self, workers: Sequence[_Actor], timeout: float | None = None) -> list[Answer]:
        ray = self.ray
        by_ref = {worker.pending: worker for worker in workers}
        done, _ = ray.wait(list(by_ref), num_returns=1, timeout=timeout)
        if done:  # collect everything else that finished meanwhile
            done, _ = ray.wait(list(by_ref), num_returns=len(by_ref), timeout=0)
        answers = []
        for ref in done:
            worker = by_ref[ref]
            try:
                answers.append(Answer(worker, *ray.get(ref)))
            except ray.exceptions.RayActorError as exc:
                answers.append(Answer(worker, False, f"{self.label} process died: {one_line(exc)}", died=True))
            except ray.exceptions.RayError as exc:  # e.g. an argument that could not be unpickled there
                answers.append(Answer(worker, False, f"ray: {one_line(exc)}"))
        return answers

    def kill(self, worker: _Actor) -> None:
        self.ray.kill(worker.handle, no_restart=True)

    def close(self, workers: Sequence[_Actor]) -> None:
        """Ask idle workers to close their servers (best effort, ``grace`` s in all), then kill them."""
        closing = []
        for worker in workers:
            try:
                closing.append(worker.handle.call.remote("close", ()))
            except Exception:  # noqa: BLE001 - closing is best effort; the kill below is not
                pass
        if closing:
            self.ray.wait(closing, num_returns=len(closing), timeout=self.grace)
        for worker in workers:
            self.kill(worker)


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


class RayExecutor(PoolExecutor):
    """A pool of ``workers`` Ray actors evaluating one batch each at a time."""

    def __init__(
        self, workers: int, *, address: str | None = None, timeout: float | None = None, warm: Sequence[Factory] = ()
    ):
        self._connection = RayConnection(address, workers)
        super().__init__(RayActors(self._connection.ray, evaluators(warm), label="worker", grace=5), workers, timeout)

    def close(self) -> None:
        super().close()
        self._connection.close()
