"""Training the next generation's model on a second core while this generation samples.

Generation g+1's model is trained on the survivors after generation g is evaluated, which
are generation g's survivors again whenever no new body beats them (in 8 to 23 of 38
generations, median 15.5, in the reference run's ten faithful seeds on ``simple``).  So as
soon as generation g's model is trained, a worker process starts training generation g+1's
model on the current survivors, with generation g+1's own random stream, while the main
process samples generation g.  If the survivors stay the same, that model is exactly the one
the main process would have trained (same code, same kernels, same stream; tested bit for
bit) and is ready early; if they change, the worker drops it at its next epoch and trains on
the new survivors instead.

When the survivors do change, the worker trains the model needed now from scratch and the
main process, which would only wait for it, trains the model after it on the same survivors
(:meth:`Speculation.train`): a guess that pays off whenever the next generation keeps its
survivors, and leaves the worker free to go two generations ahead meanwhile.

Every model comes from the same ``TrainJob.run`` with its generation's stream, so the results
are the same with or without speculation (tested); only the wall time changes.  The designer
decides *what* each generation trains on (a :class:`TrainJob`); :class:`Speculation` decides
where and when it is trained, and :mod:`.backend` whether to speculate at all.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import queue
import signal
import threading
import time
from typing import Any, Callable

import numpy as np

from ...errors import GdabenchError
from ...sdk import spawning
from ...torch_runtime import torch_threads
from .training import FitResult, Trainer, TrainerSpec, TrainJob

#: seconds between checks that the worker is still alive while waiting for it
POLL_SECONDS = 1.0


class WorkerError(GdabenchError):
    """The training process failed or died; training can go on in the main process."""


#: ``following(k)``: the job ``k`` generations on if the survivors stay, None if the run will not ask for it
Following = Callable[[int], "TrainJob | None"]


class Speculation:
    """One designer's models, trained ahead in the training process and in this one while it
    would only wait; each is the model :meth:`TrainJob.train` gives here."""

    def __init__(self, spec: TrainerSpec):
        self.spec = spec
        #: the next generation's model, trained ahead in this process: (job, weights, stream state, result)
        self._ahead: tuple[TrainJob, np.ndarray, np.ndarray, FitResult] | None = None

    @property
    def holds_next(self) -> bool:
        """Whether this process has trained a model ahead that no generation has used yet."""
        return self._ahead is not None

    def train(
        self, job: TrainJob, trainer: Trainer, following: Following
    ) -> tuple[np.ndarray, np.ndarray, FitResult, bool]:
        """``job``'s weights (training layout), stream state and result, and whether it was
        trained ahead.  Trained now by the training process if not, while ``trainer`` trains the
        next generation's model on the same survivors (a guess that pays when they stay)."""
        mine, self._ahead = self._ahead, None
        if mine is not None and mine[0] == job:
            return (*mine[1:], True)
        worker = training_worker(self.spec)
        ahead = worker.has(job)
        following_job = following(1)
        if not ahead and following_job is not None:
            worker.start(job)
            if trainer.warm:
                self._ahead = (following_job, *following_job.train(trainer))
            else:  # the first time: compile after the worker, from its cache, while it trains
                worker.wait_warm()
                job.warm_up(trainer)
        return (*worker.train(job), ahead)

    def look_ahead(self, following: Following) -> None:
        """Start the training process on the next generation's model, or on the one after if
        this process trained the next one already."""
        job = following(1)
        if job is not None and self._ahead is not None and self._ahead[0] == job:
            job = following(2)
        if job is not None:
            training_worker(self.spec).start(job)

    def close(self) -> None:
        """Stop the training process (after it failed: the designer trains here from now on)."""
        self._ahead = None
        discard_worker(self.spec)


def _serve(conn: Any, abandoned: Any, warm: Any, spec: TrainerSpec) -> None:
    """The worker's loop: train each job received and reply ``(job id, outcome)``.

    The outcome is (weights, stream state, result), None for a job abandoned while it ran,
    or the error message.  The worker leaves Ctrl-C to the main process and ends quietly when
    the main process is gone (killed runs leave no orphan and no traceback).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    with torch_threads(spec.threads):
        _train_jobs(conn, abandoned, warm, spec.make())


def _train_jobs(conn: Any, abandoned: Any, warm: Any, trainer: Trainer) -> None:
    parent = os.getppid()
    # a reply (~360 kB of weights) fills the pipe until the main process reads it, which may be
    # only after it has trained a model itself: sending from a thread keeps the worker training
    replies: queue.SimpleQueue[Any] = queue.SimpleQueue()
    threading.Thread(target=_send_replies, args=(conn, replies), daemon=True, name="gda-replies").start()
    try:
        while (message := conn.recv()) is not None:
            job_id, job = message

            def stop(job_id: int = job_id) -> bool:  # asked before each epoch
                warm.value = trainer.warm  # the compiled step is in inductor's on-disk cache now
                return abandoned.value == job_id or os.getppid() != parent

            try:
                trained = job.train(trainer, stop=stop)
                outcome: Any = None if stop() else trained
            except Exception as exc:  # noqa: BLE001 - reported to the main process, which trains itself
                outcome = f"{type(exc).__name__}: {exc}"
            replies.put((job_id, outcome))
    except (EOFError, OSError):  # the main process has gone
        return


def _send_replies(conn: Any, replies: queue.SimpleQueue[Any]) -> None:
    try:
        while True:
            conn.send(replies.get())
    except OSError:  # the main process has gone; the worker's loop ends on its own
        return


class TrainingWorker:
    """A process that trains one job at a time; :meth:`start` one ahead, :meth:`train` to get one."""

    def __init__(self, spec: TrainerSpec):
        ctx = mp.get_context("spawn")  # never fork a process that has started torch's threads
        self._conn, child = ctx.Pipe()
        self._abandoned = ctx.Value("q", -1, lock=False)
        self._warm = ctx.Value("b", False, lock=False)
        self._process = spawning.process(
            ctx, _serve, (child, self._abandoned, self._warm, spec), daemon=True, name="gda-training"
        )
        try:
            spawning.start(self._process)
        except Exception as exc:  # noqa: BLE001 - e.g. inside a daemonic process, which may not have children
            raise WorkerError(f"cannot start the training process ({type(exc).__name__}: {exc})") from None
        finally:
            child.close()
        self._next_id = 0
        self._pending: tuple[int, TrainJob] | None = None

    def start(self, job: TrainJob) -> None:
        """Begin training ``job`` in the background, abandoning a different job under way."""
        if self.has(job):
            return
        if self._pending is not None:
            self._abandoned.value = self._pending[0]
        self._send((self._next_id, job))
        self._pending = (self._next_id, job)
        self._next_id += 1

    def has(self, job: TrainJob) -> bool:
        """Whether ``job`` is under way (or done and not yet collected)."""
        return self._pending is not None and self._pending[1] == job

    def train(self, job: TrainJob) -> tuple[np.ndarray, np.ndarray, FitResult]:
        """``job``'s trained weights (training layout), stream state and result."""
        self.start(job)
        assert self._pending is not None
        job_id = self._pending[0]
        while True:  # replies to abandoned jobs come first and are skipped
            reply_id, outcome = self._receive()
            if reply_id == job_id:
                break
        self._pending = None
        if not isinstance(outcome, tuple):
            raise WorkerError(f"training process failed: {outcome}")
        weights, state, result = outcome
        return weights, state, result

    def wait_warm(self) -> None:
        """Return once the worker has compiled its training step (so a compilation here finds
        the on-disk cache warm instead of running a second C++ compiler beside the worker's),
        or has replied (e.g. with an error) without getting that far."""
        while not self._warm.value and not self._conn.poll():
            if not self._process.is_alive():
                raise WorkerError(f"training process exited with code {self.exitcode}")
            time.sleep(0.05)

    @property
    def alive(self) -> bool:
        return self._process.is_alive()

    @property
    def exitcode(self) -> int | None:
        return self._process.exitcode

    def close(self) -> None:
        if self._pending is not None:  # stop a job under way at its next epoch
            self._abandoned.value = self._pending[0]
        try:
            self._conn.send(None)
        except OSError:
            pass
        self._process.join(timeout=5)
        if self._process.is_alive():
            self._process.terminate()

    def _send(self, message: Any) -> None:
        try:
            self._conn.send(message)
        except OSError as exc:
            raise WorkerError(f"training process unreachable ({exc})") from None

    def _receive(self) -> Any:
        try:
            while not self._conn.poll(POLL_SECONDS):
                if not self._process.is_alive():
                    raise WorkerError(f"training process exited with code {self.exitcode}")
            return self._conn.recv()
        except (EOFError, OSError) as exc:
            raise WorkerError(f"training process lost ({type(exc).__name__})") from None


#: workers of this process, one per configuration: designers run one after another and share
#: them (each job starts from fresh weights), so each compiles its training step once
_WORKERS: dict[TrainerSpec, TrainingWorker] = {}


def training_worker(spec: TrainerSpec) -> TrainingWorker:
    """This configuration's worker, started if there is none; one that died since is an error
    (the designer then trains in this process and discards it)."""
    worker = _WORKERS.get(spec)
    if worker is None:
        worker = _WORKERS[spec] = TrainingWorker(spec)
    elif not worker.alive:
        raise WorkerError(f"training process exited with code {worker.exitcode}")
    return worker


def discard_worker(spec: TrainerSpec) -> None:
    worker = _WORKERS.pop(spec, None)
    if worker is not None:
        worker.close()
