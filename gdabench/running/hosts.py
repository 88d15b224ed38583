"""Where trials run: in this process, in local worker processes, or as Ray actors.

Each place holds :class:`TrialHost` objects, which run the trials they are given one at a
time: ``open`` a trial (fresh, or restored from its checkpoint), then ``step`` it one
generation per call.  Every call goes out without waiting (:meth:`TrialWorkers.call`) and its
answer comes back through :meth:`TrialWorkers.wait`, so the process that owns the run
directory can keep several trials going, write each generation as it arrives and never share
the directory with anyone.  A worker that dies costs only the trial it was running.
"""

from __future__ import annotations

import abc
import functools
import multiprocessing
import os
import signal
import threading
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any, Callable, Sequence

import pandas as pd

from .. import spawning
from ..errors import GdabenchError, one_line
from ..execution.cache import EvaluationCache
from ..execution.evaluation import instance
from ..execution.executor import Executor
from ..execution.options import Execution, make_executor
from ..execution.pool import death_message, exit_when_orphaned
from ..experiment.trial_spec import TrialSpec
from ..results import Checkpoint, RunDirectory
from ..sdk import progress_to
from ..strategy import EvalOutcome, EvalTask, Evaluate
from . import cores
from .outcomes import RunOutcomes
from .trial import GenerationResult, Trial


@dataclass(frozen=True)
class BodiesDone:
    """Progress inside a generation, sent while it runs: ``done`` of its ``total`` new bodies are evaluated;
    ``note``: what the evaluation running now says about itself
    (:func:`gdabench.sdk.report_progress`)."""

    trial: int  # the spec's index
    generation: int
    done: int
    total: int
    note: str = ""


class TrialHost:
    """Runs trials one at a time in its process, with one evaluation executor for its life.

    ``progress``, when set, is told :class:`BodiesDone` after every body (or every batch of bodies
    evaluated at once) of a generation.
    """

    def __init__(self, run_id: str, run_path: Path, execution: Execution):
        self.run_id, self.run_path, self.execution = run_id, Path(run_path), execution
        self.trial: Trial | None = None
        self.progress: Callable[[BodiesDone], None] | None = None
        self._executor: Executor | None = None
        self._evaluate: Evaluate | None = None
        self._done = (0, 0)
        self._batch, self._share = 1, cores.CpuShare()
        #: True in a trial worker process (one of several trials side by side: one engine thread each)
        self.in_worker = False

    def open(self, spec: TrialSpec, checkpoint: Checkpoint | None, done: pd.DataFrame | None) -> None:
        """Start ``spec``'s trial, or continue it from ``checkpoint`` (``done``: its rows so far)."""
        cores.release()
        env = instance(spec.env.factory)
        workdir = RunDirectory(self.run_path).artifacts(spec.name)
        if checkpoint is None:
            self.trial = Trial(spec, self.run_id, env, workdir)
        else:
            self.trial = Trial(spec, self.run_id, env, workdir, checkpoint.designer, checkpoint.next_generation, done)
        self.trial.designer.lend_cores(cores.borrow)
        if self._executor is None:
            warm = [r for r in (spec.env.factory, spec.controller) if r is not None]
            self._executor = make_executor(self.execution, warm)
        controller = instance(spec.controller) if spec.controller else None
        batch = self.execution.batch or (controller or env).bodies_at_once
        evaluate: Evaluate = functools.partial(self._executor.map, batch=batch)
        # an inheriting controller's reward depends on the trial's history, which the cache does not key; one whose
        # bodies learn together also on the generation, and it replays a resumed generation itself
        history = self.trial.inherits or bool(getattr(controller, "learns_across_bodies", False))
        if self.execution.cache is not None and spec.cache_context is not None and not history:
            evaluate = cached(evaluate, EvaluationCache(self.execution.cache, spec.cache_context))
        # deterministic environments only; a Ray cluster's nodes may not see the run directory
        outcomes = (
            RunOutcomes(self.run_path)
            if spec.cache_context is not None and self.execution.executor == "local"
            and not getattr(controller, "learns_across_bodies", False)
            else None
        )
        evaluate = body_by_body(evaluate, self.execution.workers * batch, outcomes, self._report)
        strategy = controller.evaluation_strategy() if controller else None
        self._evaluate = evaluate if strategy is None else functools.partial(strategy.evaluate, evaluate=evaluate)
        self._batch = batch if self.execution.workers == 1 and self.execution.timeout is None else 1  # here, or not
        self._share = cores.CpuShare()

    def _report(self, done: int, total: int, note: str = "") -> None:
        self._done = (done, total)
        if self.progress is not None and self.trial is not None:
            self.progress(BodiesDone(self.trial.spec.index, self.trial.generation, done, total, note))

    def _note(self, note: str) -> None:
        self._report(*self._done, note)

    def step(self) -> GenerationResult:
        """Run the open trial's next generation."""
        assert self.trial is not None and self._evaluate is not None, "open a trial first"
        requested = os.environ.get(cores.THREADS_VARIABLE, "auto")
        if requested.strip().lower() != "auto" or not self.in_worker:  # a worker's 'auto' is one (one_core)
            cores.use_engine_threads(cores.engine_threads(self._batch, self._share, requested))
        with progress_to(self._note):
            result = self.trial.step(self._evaluate)
        if result.finished:
            self.trial = None
            cores.release()
        return result

    def close(self) -> None:
        self.trial = None
        cores.release()
        if self._executor is not None:
            self._executor.close()
            self._executor = None


def body_by_body(
    evaluate: Evaluate, at_once: int, outcomes: RunOutcomes | None, report: Callable[[int, int], None]
) -> Evaluate:
    """``evaluate`` a generation ``at_once`` bodies at a time (as many as its workers take in one batch each),
    so that each finished batch is reported and recorded in the run's ``outcomes`` at once, and recorded bodies
    are replayed."""

    def evaluate_each(tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        known = [outcomes.get(task) if outcomes is not None else None for task in tasks]
        todo = [i for i, outcome in enumerate(known) if outcome is None]
        done = len(tasks) - len(todo)
        report(done, len(tasks))
        for start in range(0, len(todo), at_once):
            part = todo[start:start + at_once]
            for i, outcome in zip(part, evaluate([tasks[i] for i in part])):
                known[i] = outcome
                if outcomes is not None:
                    outcomes.put(tasks[i], outcome)
            done += len(part)
            report(done, len(tasks))
        filled = [outcome for outcome in known if outcome is not None]
        assert len(filled) == len(tasks), "every body was evaluated or replayed"
        return filled

    return evaluate_each


def cached(evaluate: Evaluate, cache: EvaluationCache) -> Evaluate:
    """``evaluate`` behind the cache: cached rewards where it has them, fresh ones stored."""

    def evaluate_cached(tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        hits = [cache.get(task) for task in tasks]
        fresh = iter(evaluate([task for task, hit in zip(tasks, hits) if hit is None]))
        outcomes = []
        for task, hit in zip(tasks, hits):
            if hit is None:
                hit = next(fresh)
                cache.put(task, hit)
            outcomes.append(hit)
        return outcomes

    return evaluate_cached


@dataclass(frozen=True)
class Answer:
    """What came back from a worker: a call's value, or why it failed (``died``: the worker is gone)."""

    worker: Any
    ok: bool
    value: Any
    died: bool = False


class TrialWorkers(abc.ABC):
    """Places to run :class:`TrialHost` calls without waiting for them; a context manager."""

    @abc.abstractmethod
    def start(self) -> Any:
        """A new worker holding a fresh TrialHost."""

    @abc.abstractmethod
    def call(self, worker: Any, method: str, *args: Any) -> None:
        """Start ``host.method(*args)`` on ``worker``; its answer comes from :meth:`wait`."""

    @abc.abstractmethod
    def wait(self, workers: Sequence[Any]) -> list[Answer]:
        """Block until at least one of ``workers`` answers; every answer that is in."""

    @abc.abstractmethod
    def kill(self, worker: Any) -> None:
        """Stop a worker now, whatever it is doing."""

    def close(self, workers: Sequence[Any]) -> None:
        for worker in workers:
            self.kill(worker)

    def __enter__(self) -> TrialWorkers:
        return self

    def __exit__(self, *exc: object) -> None:  # noqa: B027 - nothing to release unless a subclass says so
        pass


def _answer(host: TrialHost, method: str, args: Sequence[Any]) -> tuple[bool, Any]:
    try:
        return True, getattr(host, method)(*args)
    except GdabenchError as exc:
        return False, str(exc)
    except Exception as exc:  # noqa: BLE001 - a trial's failure is the trial's, reported in one line
        return False, one_line(exc)


# -- in this process --------------------------------------------------------------------------------
class InProcess(TrialWorkers):
    """One host in the calling process: a call runs at once, and ``wait`` hands over its answer."""

    def __init__(self, host: TrialHost):
        self.host = host
        self._answers: list[Answer] = []

    def start(self) -> TrialHost:
        return self.host

    def call(self, worker: TrialHost, method: str, *args: Any) -> None:
        ok, value = _answer(worker, method, args)
        self._answers.append(Answer(worker, ok, value))

    def wait(self, workers: Sequence[Any]) -> list[Answer]:
        answers, self._answers = self._answers, []
        return answers

    def kill(self, worker: TrialHost) -> None:
        worker.close()


# -- local worker processes ---------------------------------------------------------------------------
def _serve(conn: Connection, host: TrialHost, parent: int, pool: Any, held: Any) -> None:
    """A trial worker process: answer the driver's calls until it says stop or goes away."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the driver decides what an interrupt means
    host.progress = lambda bodies: conn.send((True, bodies))
    host.in_worker = True
    cores.install(pool, held)
    spawning.one_core()
    threading.Thread(target=exit_when_orphaned, args=(parent,), daemon=True).start()
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):  # the driver is gone
            break
        if message is None:
            break
        method, args = message
        ok, value = _answer(host, method, args)
        try:
            conn.send((ok, value))
        except OSError:  # the driver is gone
            break
        except Exception as exc:  # noqa: BLE001 - e.g. an extra column value that does not pickle
            conn.send((False, f"the trial's answer could not be sent to the driver: {one_line(exc)}"))
    host.close()


@dataclass(eq=False)
class _Process:
    process: multiprocessing.process.BaseProcess
    conn: Connection


class LocalProcesses(TrialWorkers):
    """Trial workers as spawned local processes (spawn is safe with torch and threads).

    ``spare`` is the run's count of spare cores (a ``multiprocessing.Value`` of the spawn
    context) that the workers' trials may borrow (:mod:`.cores`).
    """

    def __init__(self, run_id: str, run_path: Path, execution: Execution, spare: Any):
        self.args, self.spare = (run_id, run_path, execution), spare
        self._ctx = multiprocessing.get_context("spawn")

    def start(self) -> _Process:
        driver_end, worker_end = self._ctx.Pipe()
        host = TrialHost(*self.args)
        held = self._ctx.Value("i", 0, lock=False)  # changed only under the spare count's lock
        process = spawning.process(
            self._ctx, _serve, (worker_end, host, os.getpid(), self.spare, held), daemon=False, name="gdabench-trial"
        )
        spawning.start(process)
        worker_end.close()
        return _Process(process, driver_end)

    def call(self, worker: _Process, method: str, *args: Any) -> None:
        worker.conn.send((method, args))

    def wait(self, workers: Sequence[_Process]) -> list[Answer]:
        by_handle: dict[Any, _Process] = {}
        for worker in workers:
            by_handle[worker.conn] = by_handle[worker.process.sentinel] = worker
        answers = []
        for worker in dict.fromkeys(by_handle[r] for r in wait(list(by_handle))):
            if worker.conn.poll():
                try:
                    ok, value = worker.conn.recv()
                except (EOFError, OSError):
                    pass
                else:
                    answers.append(Answer(worker, ok, value))
                    continue
            worker.process.join(5)
            answers.append(
                Answer(
                    worker, False, death_message(worker.process.exitcode).replace("worker", "trial worker"), died=True
                )
            )
        return answers

    def kill(self, worker: _Process) -> None:
        if worker.process.is_alive():
            worker.process.kill()
        worker.process.join(5)
        worker.conn.close()

    def close(self, workers: Sequence[_Process]) -> None:
        """Ask idle workers to finish (closing their evaluation pools), then make sure they did."""
        for worker in workers:
            try:
                worker.conn.send(None)
            except (OSError, ValueError):
                pass
        for worker in workers:
            worker.process.join(10)
            self.kill(worker)


# -- Ray actors ---------------------------------------------------------------------------------------
class HostActor:
    """A TrialHost inside a Ray actor, answering as a local worker process does (never borrowing cores)."""

    def __init__(self, *args: Any):
        cores.install(None, None)
        spawning.one_core()
        self.host = TrialHost(*args)
        self.host.in_worker = True

    def call(self, method: str, args: Sequence[Any]) -> tuple[bool, Any]:
        return _answer(self.host, method, args)


@dataclass(eq=False)
class _Actor:
    handle: Any
    pending: Any = None


class RayActors(TrialWorkers):
    """Trial workers as Ray actors (one CPU each), on a local Ray instance or a cluster."""

    def __init__(self, ray: Any, run_id: str, run_path: Path, execution: Execution):
        self.ray, self.args = ray, (run_id, run_path, execution)
        self._cls = ray.remote(num_cpus=1, max_restarts=0, max_task_retries=0)(HostActor)

    def start(self) -> _Actor:
        return _Actor(self._cls.remote(*self.args))

    def call(self, worker: _Actor, method: str, *args: Any) -> None:
        worker.pending = worker.handle.call.remote(method, args)

    def wait(self, workers: Sequence[_Actor]) -> list[Answer]:
        ray = self.ray
        by_ref = {w.pending: w for w in workers}
        done, _ = ray.wait(list(by_ref), num_returns=1)
        done, _ = ray.wait(list(by_ref), num_returns=len(by_ref), timeout=0)  # everything else that is in
        answers = []
        for ref in done:
            worker = by_ref[ref]
            try:
                answers.append(Answer(worker, *ray.get(ref)))
            except ray.exceptions.RayActorError as exc:
                answers.append(Answer(worker, False, f"trial worker died: {one_line(exc)}", died=True))
            except ray.exceptions.RayError as exc:  # e.g. an argument that could not be unpickled there
                answers.append(Answer(worker, False, f"ray: {one_line(exc)}"))
        return answers

    def kill(self, worker: _Actor) -> None:
        self.ray.kill(worker.handle, no_restart=True)

    def close(self, workers: Sequence[_Actor]) -> None:
        for worker in workers:
            try:
                self.ray.get(worker.handle.call.remote("close", ()), timeout=30)
            except Exception:  # noqa: BLE001 - closing is best effort; the kill below is not
                pass
            self.kill(worker)
