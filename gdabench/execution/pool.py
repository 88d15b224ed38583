"""A supervised pool of evaluation workers that survives its workers.

``concurrent.futures.ProcessPoolExecutor`` cannot stop one hung task, and when one worker dies
it breaks the whole pool, failing every task in flight.  Evaluations of robot bodies hang and
crash (a physics engine aborting, a controller running out of memory), so this pool gives each
worker one batch of bodies at a time (:func:`~gdabench.execution.executor.batches`) and always
knows which batch a worker runs:

* a worker that dies is replaced, and only the batch it was running becomes ``error`` rows;
* a batch that runs past its timeout (the per-body timeout times its bodies: a batch learned in
  lockstep cannot stop one body) has its worker killed and replaced, and becomes ``timeout`` rows;
* every other batch is unaffected, so no outcome depends on what failed around it.

Workers build the run's environment and controller (an :class:`Evaluator`) before they answer
that they are ready, so start-up is not charged to the first evaluation's timeout.  The workers
are the harness's one worker layer (:mod:`gdabench.execution.workers`): local processes here,
Ray actors in :mod:`gdabench.execution.ray`.
"""

from __future__ import annotations

import functools
import math
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Sequence

from .. import spawning
from ..errors import GdabenchError, one_line
from ..specs import Factory
from ..statuses import ERROR, TIMEOUT
from ..strategy import EvalOutcome, EvalTask
from .evaluation import evaluate_batch, prepare
from .executor import Executor, batches
from .workers import LocalProcesses, Tell, WorkerGone, Workers

#: seconds the pool waits for its first worker to import gdabench and build the environment
#: (workers that start later, e.g. queued on a busy Ray cluster, may take as long as they need)
START_TIMEOUT = 300.0


class Evaluator:
    """An evaluation worker's server: builds the environment and controller once, evaluates one batch per call."""

    def __init__(self, warm: Sequence[Factory], tell: Tell | None = None):
        spawning.one_core()
        prepare(warm)

    def ready(self) -> bool:
        return True

    def evaluate(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        return evaluate_batch(tasks)

    def close(self) -> None:
        """Nothing to release: the built environment and controller go with the process."""


def evaluators(warm: Sequence[Factory]) -> functools.partial[Evaluator]:
    """What builds an evaluation worker's server, given the recipes it builds before its first body."""
    return functools.partial(Evaluator, tuple(warm))


class WorkerStartError(GdabenchError):
    """A worker could not start (it died or hung while importing or building the environment)."""


@dataclass(eq=False)
class Slot:
    """One place in the pool: a worker and the batch it runs (indices of its tasks)."""

    worker: Any
    ready: bool = False
    task: list[int] | None = None
    started: float = 0.0
    born: float = field(default_factory=time.monotonic)


class WorkerPool:
    """``size`` supervised evaluation workers (servers made by :func:`evaluators`); :meth:`map` returns
    outcomes in task order."""

    def __init__(self, workers: Workers, size: int, *, timeout: float | None = None):
        self.workers, self.size, self.timeout = workers, size, timeout
        self.slots: list[Slot] = []

    def _start(self) -> Slot:
        worker = self.workers.start()
        try:
            self.workers.call(worker, "ready")  # answered once the worker has built its environment
        except WorkerGone:
            pass  # it died at once: its death is the answer
        return Slot(worker)

    def map(self, tasks: Sequence[EvalTask], batch: int = 1) -> list[EvalOutcome]:
        outcomes: list[EvalOutcome | None] = [None] * len(tasks)
        queue = deque(batches(tasks, self.size, batch))
        while len(self.slots) < min(self.size, len(queue)):
            self.slots.append(self._start())
        try:
            while queue or any(s.task is not None for s in self.slots):
                for slot in self.slots:
                    if slot.ready and slot.task is None and queue:
                        self._dispatch(slot, queue, tasks, outcomes)
                self._step(outcomes)
        except BaseException:
            self.close()  # interrupted or broken: do not leave workers evaluating for nobody
            raise
        return outcomes  # type: ignore[return-value]

    def _dispatch(
        self, slot: Slot, queue: deque[list[int]], tasks: Sequence[EvalTask], outcomes: list[EvalOutcome | None]
    ) -> None:
        part = queue.popleft()
        try:
            self.workers.call(slot.worker, "evaluate", [tasks[i] for i in part])
        except WorkerGone:
            queue.appendleft(part)  # the worker died while idle: not this batch's fault
            self._replace(slot)
            return
        except Exception as exc:  # noqa: BLE001 - e.g. a task that does not pickle
            _fill(outcomes, part, EvalOutcome(math.nan, ERROR, f"task could not be sent to a worker: {one_line(exc)}"))
            return
        slot.task, slot.started = part, time.monotonic()

    def _deadline(self, slot: Slot, any_ready: bool) -> float | None:
        if not slot.ready:
            return None if any_ready else slot.born + START_TIMEOUT
        if self.timeout is None or slot.task is None:
            return None
        return slot.started + self.timeout * len(slot.task)

    def _step(self, outcomes: list[EvalOutcome | None]) -> None:
        """Wait for the next results, deaths or deadlines, and handle them."""
        live = [s for s in self.slots if s.task is not None or not s.ready]
        if not live:
            return
        any_ready = any(s.ready for s in self.slots)
        deadlines = [d for d in (self._deadline(s, any_ready) for s in live) if d is not None]
        timeout = max(0.0, min(deadlines) - time.monotonic()) if deadlines else None
        by_worker = {slot.worker: slot for slot in live}
        for answer in self.workers.wait(list(by_worker), timeout):
            slot = by_worker[answer.worker]
            if not slot.ready:
                if not answer.ok:
                    self._discard(slot)
                    raise WorkerStartError(f"a worker could not start: {answer.value}")
                slot.ready = True
            elif answer.ok:
                assert slot.task is not None
                for i, outcome in zip(slot.task, answer.value):
                    outcomes[i] = outcome
                slot.task = None
            else:  # the batch could not run or come back, or its worker died: every body of it is an error
                assert slot.task is not None
                share = (time.monotonic() - slot.started) / len(slot.task)
                _fill(outcomes, slot.task, EvalOutcome(math.nan, ERROR, answer.value, share))
                if answer.died:
                    self._replace(slot)
                else:
                    slot.task = None
        now = time.monotonic()
        for slot in live:
            deadline = self._deadline(slot, any_ready)
            if slot not in self.slots or deadline is None or now < deadline or (slot.ready and slot.task is None):
                continue
            if not slot.ready:
                self._discard(slot)
                raise WorkerStartError(f"no worker started within {START_TIMEOUT:g} s")
            assert slot.task is not None
            n = len(slot.task)
            within = f"the {self.timeout:g} s timeout" + (f" ({n} bodies evaluated together)" if n > 1 else "")
            message = f"evaluation did not finish within {within}"
            _fill(outcomes, slot.task, EvalOutcome(math.nan, TIMEOUT, message, (now - slot.started) / n))
            self._replace(slot)

    def _discard(self, slot: Slot) -> None:
        self.workers.kill(slot.worker)
        self.slots.remove(slot)

    def _replace(self, slot: Slot) -> None:
        self.workers.kill(slot.worker)
        self.slots[self.slots.index(slot)] = self._start()

    def close(self) -> None:
        """Stop every worker: idle ones are asked to finish, busy or starting ones are killed."""
        idle = [s.worker for s in self.slots if s.ready and s.task is None]
        for slot in self.slots:
            if not (slot.ready and slot.task is None):
                self.workers.kill(slot.worker)
        self.workers.close(idle)
        self.slots = []


def _fill(outcomes: list[EvalOutcome | None], part: Sequence[int], outcome: EvalOutcome) -> None:
    for i in part:
        outcomes[i] = outcome


class PoolExecutor(Executor):
    """A supervised pool of ``size`` evaluation workers; a dead or hung worker costs only its own batch."""

    def __init__(self, workers: Workers, size: int, timeout: float | None):
        self.workers = size
        self._pool = WorkerPool(workers, size, timeout=timeout)

    def map(self, tasks: Sequence[EvalTask], batch: int = 1) -> list[EvalOutcome]:
        return self._pool.map(tasks, batch)

    def close(self) -> None:
        self._pool.close()


class ProcessExecutor(PoolExecutor):
    """Local worker processes."""

    def __init__(self, workers: int, *, timeout: float | None = None, warm: Sequence[Factory] = ()):
        local = LocalProcesses(evaluators(warm), label="worker", name="gdabench-worker", daemon=True, grace=5)
        super().__init__(local, workers, timeout)
