"""Where trials run: in this process, in local worker processes, or as Ray actors.

Each place holds :class:`TrialHost` objects, which run the trials they are given one at a
time: ``open`` a trial (fresh, or restored from its checkpoint), then ``step`` it one
generation per call.  The places are the harness's one worker layer
(:mod:`gdabench.execution.workers`, with a :class:`TrialHost` as each worker's server): every call
goes out without waiting and its answer comes back through ``wait``, so the process that owns the
run directory can keep several trials going, write each generation as it arrives and never share
the directory with anyone.  A worker that dies costs only the trial it was running.
"""

from __future__ import annotations

import functools
import multiprocessing
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import pandas as pd

from .. import spawning
from ..cpu import THREADS_VARIABLE
from ..execution.cache import EvaluationCache
from ..execution.evaluation import instance
from ..execution.executor import Executor
from ..execution.options import Execution, make_executor
from ..execution.ray import RayActors
from ..execution.workers import LocalProcesses
from ..experiment.trial_spec import TrialSpec
from ..results import Checkpoint, RunDirectory
from ..sdk import progress_to
from . import cores
from .outcomes import RunOutcomes
from .pipeline import EvaluationPipeline
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
        self._evaluate: EvaluationPipeline | None = None
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
        # an inheriting controller's reward depends on the trial's history, which the cache does not key; one whose
        # bodies learn together also on the generation, and it replays a resumed generation itself
        together = bool(getattr(controller, "learns_across_bodies", False))
        self._evaluate = EvaluationPipeline(
            self._executor,
            batch,
            at_once=self.execution.workers * batch,
            report=self._report,
            cache=EvaluationCache(self.execution.cache, spec.cache_context)
            if self.execution.cache is not None
            and spec.cache_context is not None
            and not (self.trial.inherits or together)
            else None,
            # deterministic environments only; a Ray cluster's nodes may not see the run directory
            replay=RunOutcomes(self.run_path)
            if spec.cache_context is not None and self.execution.executor == "local" and not together
            else None,
            strategy=controller.evaluation_strategy() if controller else None,
        )
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
        requested = os.environ.get(THREADS_VARIABLE, "auto")
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


def trial_host(
    run_id: str, run_path: Path, execution: Execution, spare: Any, tell: Callable[[Any], None] | None
) -> TrialHost:
    """A trial worker's server (:mod:`gdabench.execution.workers`), built in the worker: a host that tells
    its progress through ``tell`` and borrows from the run's ``spare`` cores (None: never borrows)."""
    held = multiprocessing.get_context("spawn").Value("i", 0, lock=False) if spare is not None else None
    cores.install(spare, held)  # ``held``: changed only under the spare count's lock
    spawning.one_core()
    host = TrialHost(run_id, run_path, execution)
    host.in_worker, host.progress = True, tell
    return host


def trial_workers(run_id: str, run_path: Path, execution: Execution, spare: Any) -> LocalProcesses:
    """Trial workers as local processes; ``spare``: the run's count of spare cores (a ``multiprocessing.Value``
    of the spawn context) that their trials may borrow (:mod:`.cores`)."""
    make = functools.partial(trial_host, run_id, run_path, execution, spare)
    # not daemons: a trial worker starts evaluation workers of its own
    return LocalProcesses(make, label="trial worker", name="gdabench-trial", daemon=False, grace=10)


def trial_actors(ray: Any, run_id: str, run_path: Path, execution: Execution) -> RayActors:
    """Trial workers as Ray actors (one CPU each), which never borrow cores."""
    make = functools.partial(trial_host, run_id, run_path, execution, None)
    return RayActors(ray, make, label="trial worker", grace=30)
