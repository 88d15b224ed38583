"""Running an experiment: resolve it once, own its run directory, run its trials, record the truth.

The process that calls :func:`compare` is the run directory's one writer (it holds its lock):
trials run here or in workers (:mod:`gdabench.running.hosts`) and hand back each generation's
rows and checkpoint, which are written here in the order they arrive.  A trial that fails
fails alone: the others complete, and the run ends ``failed`` naming it, resumable.
``run.json``'s status always tells the truth: ``complete``, ``failed`` (with the error),
``interrupted`` (Ctrl-C or SIGTERM) or, while the run is going, ``running``.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import pickle
import signal
import sys
import threading
import time
import uuid
from collections import deque
from pathlib import Path
from typing import Any, Iterator, Sequence

from .. import faults, spawning
from ..cpu import cpu_count
from ..errors import GdabenchError, RunDirectoryError, Terminated, TrialError, one_line
from ..execution.options import Execution
from ..execution.workers import InProcess, Workers
from ..experiment.build import RunSetup, setup_run
from ..experiment.config import Experiment
from ..experiment.plan import Plan
from ..experiment.trial_spec import TrialSpec
from ..plugins import Registry, registry
from ..results import (
    SUMMARY,
    Checkpoint,
    RunDirectory,
    load_reevaluations,
    no_space,
    platform_info,
    utc_now,
    versions,
    write_error,
)
from ..stats.summary import failure_counts, nothing_measured, summarize
from . import cores
from .events import Listeners, PluginHooks, RunListener
from .hosts import BodiesDone, TrialHost, trial_actors, trial_workers
from .outcomes import RunOutcomes
from .reevaluation import reevaluate_run
from .trial import GenerationResult


def _new_meta(plan: Plan, reg: Registry, command: Sequence[str] | None, execution: dict[str, Any]) -> dict[str, Any]:
    envs = plan.envs
    return {
        "run_id": f"{time.strftime('%Y%m%d-%H%M%S')}-{uuid.uuid4().hex[:6]}",
        "status": "running",
        "created": utc_now(),
        "command": list(command if command is not None else sys.argv),
        "config": plan.experiment.to_json(),
        "env_optimum": envs[0].optimum if len(envs) == 1 else None,
        "env_version": envs[0].version if len(envs) == 1 else None,
        "envs": {e.label: {"optimum": e.optimum, "version": e.version} for e in envs},
        "execution": execution,
        "wall_seconds": 0.0,
        "wall_seconds_by_part": [None],
        "versions": versions(reg.distributions()),
        "platform": platform_info(),
    }


def compare(
    experiment: Experiment | None,
    out: str | Path | None = None,
    *,
    resume: bool = False,
    execution: Execution | None = None,
    listener: RunListener | None = None,
    command: Sequence[str] | None = None,
    reg: Registry | None = None,
) -> RunDirectory:
    """Run (or resume) ``experiment`` into ``out`` and return the finished run directory.

    Everything is checked before the directory is created.  On failure the directory's
    ``run.json`` says ``failed`` (or ``interrupted``) with the error, and the run can be resumed
    with other execution options if wanted; the timeout defaults to the one it started with.
    A resume takes the experiment from the directory; ``experiment`` may only add seeds to it
    (even to a complete run), which run as if they had been in the run from the start.
    """
    setup = setup_run(experiment, out, resume=resume, execution=execution, reg=reg)
    return execute(setup, listener=listener, command=command, reg=reg)


def execute(
    setup: RunSetup,
    *,
    listener: RunListener | None = None,
    command: Sequence[str] | None = None,
    reg: Registry | None = None,
) -> RunDirectory:
    """Run what ``setup`` (from :func:`~gdabench.experiment.build.build_run`) resolved: a new run into its
    directory, or the resume of the run directory it opened; return the finished run directory."""
    reg = reg or registry()
    execution, plan, resume = setup.execution, setup.plan, setup.resumed is not None
    listener = Listeners([listener or RunListener(), PluginHooks(reg)])
    if setup.resumed is not None:
        run = setup.resumed
        if plan is None:  # a complete run, resumed unchanged: nothing to do
            return run
        meta = run.meta
        run.lock()
        added = {"added_seeds": list(setup.added_seeds)} if setup.added_seeds else {}
        run.update_meta(status="running", config=plan.experiment.to_json(), error=None,
                        resumed=[*meta.get("resumed", []), {"at": utc_now(), **execution.to_json(), **added}],
                        **run.part_started())  # fmt: skip
    else:
        assert plan is not None, "a new run's setup has a plan"
        run = RunDirectory.create(setup.out, _new_meta(plan, reg, command, execution.to_json()))
    started = time.monotonic()  # this part of the run: the first run, or a resume
    listener.run_started(run.path, plan, resume)
    try:
        with _signals_interrupt(), spawning.scripts_shared(plan.from_script):
            failures = _run_trials(plan, run, execution, listener)
            if failures:
                run.update_meta(
                    failed_trials=[
                        {"trial": plan.trials[i].title, "name": plan.trials[i].name, "error": e}
                        for i, e in sorted(failures.items())
                    ]
                )
                raise TrialError(_failure_line(plan, failures))
            how = plan.experiment.reevaluate
            if how is not None:
                reevaluated = time.monotonic()
                reevaluate_run(run, plan, how, execution, listener.reevaluated)
                done = float((run.meta.get("reevaluated") or {}).get("wall_seconds", 0.0))
                run.update_meta(reevaluated={"top": how.top, "seeds": how.seeds,
                                             "wall_seconds": round(done + time.monotonic() - reevaluated, 1)})
            frame = run.load_evaluations()
            optima = {e.label: e.optimum for e in plan.envs}
            summary = summarize(frame, optima, reevaluations=load_reevaluations(run.path))
            summary.to_csv(run.path / SUMMARY, index=False)
            measured_nothing = nothing_measured(failure_counts(frame))  # every trial ran, but some measured nothing
            status = "complete" if measured_nothing is None else "failed"
            run.update_meta(status=status, error=measured_nothing, finished=utc_now(), failed_trials=[],
                            **run.part_ended(time.monotonic() - started))
            RunOutcomes(run.path).discard()  # every trial is merged: nothing left to resume or share
    except KeyboardInterrupt as exc:
        with _uninterrupted():
            run.update_meta(
                status="interrupted",
                error="terminated (SIGTERM)" if isinstance(exc, Terminated) else "interrupted by the user",
                **run.part_ended(time.monotonic() - started),
            )
            listener.run_finished(run.path, "interrupted", None)
        raise
    except BaseException as exc:
        error = write_error(exc, run.path) if isinstance(exc, OSError) and no_space(exc) else exc
        run.update_meta(status="failed", error=str(error) if isinstance(error, GdabenchError) else one_line(error),
                        **run.part_ended(time.monotonic() - started))
        listener.run_finished(run.path, "failed", None)
        if error is not exc:
            raise error from None
        raise
    finally:
        run.unlock()
    listener.run_finished(run.path, status, summary)
    return run


def _failure_line(plan: Plan, failures: dict[int, str]) -> str:
    first = min(failures)
    more = f" (and {len(failures) - 1} more; see run.json)" if len(failures) > 1 else ""
    return f"{len(failures)} of {len(plan.trials)} trials failed: {plan.trials[first].title}: {failures[first]}{more}"


@contextlib.contextmanager
def _uninterrupted() -> Iterator[None]:
    """Clean-up that one more Ctrl-C or SIGTERM must not cut short (it would leave workers behind)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, signal.SIG_IGN) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


@contextlib.contextmanager
def _signals_interrupt() -> Iterator[None]:
    """SIGTERM ends the run as Ctrl-C does (status ``interrupted``), where signals can be caught."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def terminate(signum: int, frame: Any) -> None:
        raise Terminated()

    previous = signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


class _SpareCores:
    """The run's cores no trial runs on, lent to running trials once none is left waiting (:mod:`.cores`)."""

    def __init__(self, cores: int):
        self.cores = cores
        self.count = multiprocessing.get_context("spawn").Value("i", 0)
        self.lent = False

    def update(self, waiting: int, running: int, ended: int = 0) -> None:
        """After trials started or ended: lend the idle cores once nothing waits for them."""
        if waiting:
            return
        free = ended if self.lent else self.cores - running
        self.lent = True
        if free > 0:
            with self.count.get_lock():
                self.count.value += free


@contextlib.contextmanager
def _trial_workers(plan: Plan, run: RunDirectory, execution: Execution, trials: int,
                   listener: RunListener) -> Iterator[tuple[Workers, int, _SpareCores | None]]:
    """Where this run's trials go, how many at once, and the cores they may borrow."""
    run_id = run.meta["run_id"]
    if execution.executor == "ray":
        from ..execution.ray import RayConnection

        with RayConnection(execution.ray_address) as connection:
            yield (
                trial_actors(connection.ray, run_id, run.path, execution),
                execution.jobs_for(trials, connection.cpus()),
                None,
            )
        return
    jobs = execution.jobs_for(trials)
    spare = _SpareCores(execution.jobs or cpu_count()) if execution.workers == 1 else None
    if jobs > 1:
        yield trial_workers(run_id, run.path, execution, spare.count if spare else None), jobs, spare
        return
    if spare is not None:  # the trials run here, in this process
        cores.install(spare.count, multiprocessing.Value("i", 0, lock=False))
    host = TrialHost(run_id, run.path, execution)
    host.progress = lambda bodies: listener.bodies(plan.trials[bodies.trial], bodies)
    try:
        yield InProcess(host), 1, spare
    finally:
        cores.uninstall()


def _run_trials(plan: Plan, run: RunDirectory, execution: Execution, listener: RunListener) -> dict[int, str]:
    """Run every unfinished trial of ``plan``; the failed ones' messages by trial index."""
    finished = run.finished_trials()
    for spec in plan.trials:
        if spec.key in finished:
            run.discard_trial_files(spec.name)  # left behind by a kill while the trial was being merged
    todo = deque(t for t in plan.trials if t.key not in finished)
    if not todo:
        return {}
    order = {t.key: t.index for t in plan.trials}
    position = lambda key: order.get(key, len(order))  # noqa: E731 - rows of trials no longer planned go last
    failures: dict[int, str] = {}
    running: dict[Any, TrialSpec] = {}
    idle: list[Any] = []
    with _trial_workers(plan, run, execution, len(todo), listener) as (workers, jobs, spare):
        try:
            while todo or running:
                while todo and len(running) < jobs:
                    spec = todo.popleft()
                    try:
                        checkpoint = _load_checkpoint(run, spec)
                        done = run.pending_rows(
                            spec.name, before_generation=checkpoint.next_generation if checkpoint else 0
                        )
                    except RunDirectoryError as exc:
                        failures[spec.index] = str(exc)
                        listener.trial_finished(spec, str(exc))
                        continue
                    worker = idle.pop() if idle else workers.start()
                    workers.call(worker, "open", spec, checkpoint, done)
                    running[worker] = spec
                    listener.trial_started(spec)
                if spare is not None:
                    spare.update(len(todo), len(running))
                for answer in workers.wait(list(running)):
                    spec = running[answer.worker]
                    if not answer.ok:
                        del running[answer.worker]
                        if spare is not None:
                            spare.update(len(todo), len(running), ended=1)
                        if answer.died:
                            workers.kill(answer.worker)
                        else:
                            idle.append(answer.worker)
                        failures[spec.index] = answer.value
                        listener.trial_finished(spec, answer.value)
                        continue
                    result = answer.value
                    if isinstance(result, BodiesDone):  # the generation goes on
                        listener.bodies(spec, result)
                        continue
                    if isinstance(result, GenerationResult):
                        run.append_generation(spec.name, result.generation, result.rows)
                        faults.point("rows-written")
                        if result.checkpoint is not None:
                            run.save_checkpoint(spec.name, result.checkpoint)
                            faults.point("checkpoint-written")
                        listener.generation(spec, result)
                        if result.finished:
                            run.finish_trial(spec.name, position)
                            del running[answer.worker]
                            if spare is not None:
                                spare.update(len(todo), len(running), ended=1)
                            idle.append(answer.worker)
                            listener.trial_finished(spec, None)
                            continue
                    workers.call(answer.worker, "step")
        finally:
            with _uninterrupted():
                for worker in running:
                    workers.kill(worker)
                workers.close(idle)
    return failures


def _load_checkpoint(run: RunDirectory, spec: TrialSpec) -> Checkpoint | None:
    data = run.load_checkpoint(spec.name)
    if data is None:
        return None
    try:
        return pickle.loads(data)
    except Exception as exc:  # noqa: BLE001 - any unreadable checkpoint is one line for the user
        raise RunDirectoryError(
            f"cannot restore checkpoint {run.checkpoint_path(spec.name)}: {one_line(exc)}"
        ) from None
