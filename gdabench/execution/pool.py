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

Workers build the run's environment and controller before they report ready, so start-up is
not charged to the first evaluation's timeout.  The pool logic is shared; a :class:`Backend`
says what a worker is: a local process (:class:`ProcessBackend`, here) or a Ray actor
(:mod:`gdabench.execution.ray`).
"""

from __future__ import annotations

import abc
import math
import multiprocessing
import os
import signal
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from typing import Any, Sequence

from .. import spawning
from ..errors import GdabenchError, one_line
from ..specs import Factory
from ..statuses import ERROR, TIMEOUT
from ..strategy import EvalOutcome, EvalTask
from .evaluation import evaluate_batch, prepare
from .executor import Executor, batches

#: seconds the pool waits for its first worker to import gdabench and build the environment
#: (workers that start later, e.g. queued on a busy Ray cluster, may take as long as they need)
START_TIMEOUT = 300.0
READY, RESULT, DIED = "ready", "result", "died"


class WorkerStartError(GdabenchError):
    """A worker could not start (it died or hung while importing or building the environment)."""


class WorkerGone(Exception):
    """A task could not be handed to a worker because the worker is no longer there."""


@dataclass(eq=False)
class Slot:
    """One place in the pool: the backend's worker and the batch it runs (indices of its tasks)."""

    worker: Any
    ready: bool = False
    task: list[int] | None = None
    started: float = 0.0
    born: float = field(default_factory=time.monotonic)


class Backend(abc.ABC):
    """What a worker is and how to talk to it."""

    @abc.abstractmethod
    def start(self) -> Any:
        """Start a worker; it reports READY (through :meth:`wait`) once it can take tasks."""

    @abc.abstractmethod
    def send(self, worker: Any, tasks: Sequence[EvalTask]) -> None:
        """Hand a batch to an idle worker; raise :class:`WorkerGone` if it is not there any more."""

    @abc.abstractmethod
    def wait(self, slots: Sequence[Slot], timeout: float | None) -> list[tuple[Slot, str, Any]]:
        """Block up to ``timeout`` s for events: (slot, READY, None), (slot, RESULT, outcomes of its batch),
        (slot, DIED, message)."""

    @abc.abstractmethod
    def kill(self, worker: Any) -> None:
        """Stop a worker now, whatever it is doing."""

    def stop(self, workers: Sequence[Any]) -> None:
        """Stop idle workers (default: kill them)."""
        for worker in workers:
            self.kill(worker)


class WorkerPool:
    """``size`` supervised workers; :meth:`map` returns outcomes in task order."""

    def __init__(self, backend: Backend, size: int, *, timeout: float | None = None):
        self.backend, self.size, self.timeout = backend, size, timeout
        self.slots: list[Slot] = []

    def map(self, tasks: Sequence[EvalTask], batch: int = 1) -> list[EvalOutcome]:
        outcomes: list[EvalOutcome | None] = [None] * len(tasks)
        queue = deque(batches(tasks, self.size, batch))
        while len(self.slots) < min(self.size, len(queue)):
            self.slots.append(Slot(self.backend.start()))
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
            self.backend.send(slot.worker, [tasks[i] for i in part])
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
        for slot, kind, payload in self.backend.wait(live, timeout):
            if kind == READY:
                slot.ready = True
            elif not slot.ready:
                self._discard(slot)
                raise WorkerStartError(
                    f"a worker could not start: {payload if kind == DIED else 'it answered before it was ready'}"
                )
            elif kind == RESULT:
                assert slot.task is not None
                if isinstance(payload, EvalOutcome):  # one outcome for the whole batch (it could not run)
                    _fill(outcomes, slot.task, payload)
                else:
                    for i, outcome in zip(slot.task, payload):
                        outcomes[i] = outcome
                slot.task = None
            else:
                assert slot.task is not None
                share = (time.monotonic() - slot.started) / len(slot.task)
                _fill(outcomes, slot.task, EvalOutcome(math.nan, ERROR, payload, share))
                self._replace(slot)
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
        self.backend.kill(slot.worker)
        self.slots.remove(slot)

    def _replace(self, slot: Slot) -> None:
        self.backend.kill(slot.worker)
        self.slots[self.slots.index(slot)] = Slot(self.backend.start())

    def close(self) -> None:
        """Stop every worker: idle ones are asked to finish, busy or starting ones are killed."""
        idle = [s.worker for s in self.slots if s.ready and s.task is None]
        for slot in self.slots:
            if not (slot.ready and slot.task is None):
                self.backend.kill(slot.worker)
        self.backend.stop(idle)
        self.slots = []


def _fill(outcomes: list[EvalOutcome | None], part: Sequence[int], outcome: EvalOutcome) -> None:
    for i in part:
        outcomes[i] = outcome


# -- local processes -------------------------------------------------------------------------------
def exit_when_orphaned(parent: int) -> None:
    while True:
        time.sleep(1.0)
        if os.getppid() != parent:
            os._exit(0)  # the driver is gone (killed): nobody will read our results


def _serve(conn: Connection, warm: Sequence[Factory], parent: int) -> None:
    """Worker process main loop: evaluate the batches the driver sends, one at a time.

    Ctrl-C is ignored (the driver decides what an interrupt means), and the worker exits by
    itself when the driver dies, even in the middle of a hung evaluation.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=exit_when_orphaned, args=(parent,), daemon=True).start()
    spawning.one_core()
    prepare(warm)
    try:
        conn.send(READY)
    except OSError:  # the driver is gone (stopped while this worker started): nobody to tell
        return
    while True:
        try:
            tasks = conn.recv()
        except (EOFError, OSError):  # the driver is gone
            return
        if tasks is None:
            return
        outcomes = evaluate_batch(tasks)
        try:
            conn.send(outcomes)
        except OSError:  # the driver is gone
            return
        except Exception as exc:  # noqa: BLE001 - e.g. an info value that does not pickle
            message = f"result could not be sent to the driver: {one_line(exc)}"
            conn.send(EvalOutcome(math.nan, ERROR, message, outcomes[0].seconds))


def death_message(exitcode: int | None) -> str:
    if exitcode is not None and exitcode < 0:
        try:
            return f"worker process died (killed by {signal.Signals(-exitcode).name})"
        except ValueError:
            pass
    return f"worker process died (exit code {exitcode})"


@dataclass(eq=False)
class _Process:
    process: multiprocessing.process.BaseProcess
    conn: Connection


class ProcessBackend(Backend):
    """Workers are spawned local processes (spawn is safe with torch and threads), one pipe each."""

    def __init__(self, warm: Sequence[Factory] = ()):
        self.warm = tuple(warm)
        self._ctx = multiprocessing.get_context("spawn")

    def start(self) -> _Process:
        driver_end, worker_end = self._ctx.Pipe()
        process = spawning.process(
            self._ctx, _serve, (worker_end, self.warm, os.getpid()), daemon=True, name="gdabench-worker"
        )
        spawning.start(process)
        worker_end.close()
        return _Process(process, driver_end)

    def send(self, worker: _Process, tasks: Sequence[EvalTask]) -> None:
        try:
            worker.conn.send(list(tasks))  # pickles first: a task that does not pickle writes nothing
        except (BrokenPipeError, ConnectionError, EOFError) as exc:
            raise WorkerGone from exc

    def wait(self, slots: Sequence[Slot], timeout: float | None) -> list[tuple[Slot, str, Any]]:
        by_handle: dict[Any, Slot] = {}
        for slot in slots:
            by_handle[slot.worker.conn] = by_handle[slot.worker.process.sentinel] = slot
        ready = wait(list(by_handle), timeout)
        events: list[tuple[Slot, str, Any]] = []
        for slot in dict.fromkeys(by_handle[r] for r in ready):  # each slot once, conn before sentinel
            worker = slot.worker
            if worker.conn.poll():
                try:
                    message = worker.conn.recv()
                except (EOFError, OSError):
                    message = None
                except Exception as exc:  # noqa: BLE001 - a result the driver cannot unpickle
                    message = EvalOutcome(math.nan, ERROR, f"result could not be read from the worker: {one_line(exc)}")
                if message is not None:
                    events.append((slot, READY, None) if message == READY else (slot, RESULT, message))
                    continue
            worker.process.join(5)
            events.append((slot, DIED, death_message(worker.process.exitcode)))
        return events

    def kill(self, worker: _Process) -> None:
        if worker.process.is_alive():
            worker.process.kill()
        worker.process.join(5)
        worker.conn.close()

    def stop(self, workers: Sequence[_Process]) -> None:
        for worker in workers:
            try:
                worker.conn.send(None)
            except (OSError, ValueError):
                pass
        deadline = time.monotonic() + 5
        for worker in workers:
            worker.process.join(max(0.0, deadline - time.monotonic()))
            self.kill(worker)


class ProcessExecutor(Executor):
    """Local worker processes; a dead or hung worker costs only its own evaluation."""

    def __init__(self, workers: int, *, timeout: float | None = None, warm: Sequence[Factory] = ()):
        self.workers = workers
        self._pool = WorkerPool(ProcessBackend(warm), workers, timeout=timeout)

    def map(self, tasks: Sequence[EvalTask], batch: int = 1) -> list[EvalOutcome]:
        return self._pool.map(tasks, batch)

    def close(self) -> None:
        self._pool.close()
