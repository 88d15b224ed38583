"""A trial: one designer on one environment with one seed, run generation by generation.

The trial owns what designers must not: the evaluation budget (counted in evaluations of
unique valid bodies, as Evolution Gym counts them), de-duplication (a body already scored in
this trial is not evaluated again; its row says ``duplicate`` and the designer is told the
known reward), validity (invalid bodies are recorded, never scored, and do not use budget),
and failures (``error`` or ``timeout`` rows that do use budget).

A trial never touches the run directory: each :meth:`Trial.step` returns the generation's rows
and, when the trial goes on, a checkpoint (the pickled designer after ``tell``), and the
process that owns the run directory writes both.  :meth:`Trial.restore` rebuilds a trial from
the last checkpoint and the rows written before it, which is what resuming a run means.
"""

from __future__ import annotations

import math
import pickle
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import pandas as pd

from .. import seeding
from ..body import Body, as_body
from ..designer import Designer
from ..environment import Environment
from ..errors import DesignerError, GdabenchError, one_line
from ..execution.evaluation import instance
from ..experiment.trial_spec import TrialSpec
from ..hookspecs import GenerationReport
from ..results import COLUMNS, Checkpoint, utc_now
from ..statuses import COUNTED, DUPLICATE, INVALID, OK
from ..strategy import EvalTask, Evaluate

#: a designer that proposes nothing new for this many generations in a row is stopped
MAX_STALE_GENERATIONS = 20


@dataclass(frozen=True)
class GenerationResult:
    """One generation of a trial, ready to be written: rows, then the checkpoint (None once the trial ended)."""

    trial: int  # the spec's index
    generation: int
    rows: list[dict[str, Any]]
    checkpoint: bytes | None
    report: GenerationReport

    @property
    def finished(self) -> bool:
        return self.checkpoint is None


class Trial:
    """The state of one trial between generations."""

    def __init__(self, spec: TrialSpec, run_id: str, env: Environment, workdir: Path, designer: Designer | None = None,
                 next_generation: int = 0, done: pd.DataFrame | None = None):
        self.spec, self.env, self.workdir = spec, env, workdir
        self.designer = (
            designer
            if designer is not None
            else spec.designer.build(spec.shape, spec.population, spec.budget, spec.seed)
        )
        self.constants = {"run_id": run_id, **spec.constants}
        self.generation = next_generation
        self.seen: dict[str, float] = {}
        self.n_evals, self.best, self.stale, self.tell_seconds = 0, math.nan, 0, 0.0
        self.clock0 = time.perf_counter()
        #: the controller starts children from their parents' files (``Controller.inherits``)
        self.inherits = spec.controller is not None and bool(getattr(instance(spec.controller), "inherits", False))
        if done is not None and len(done):
            counted = done[done["status"].isin(COUNTED)]
            self.seen = dict(zip(counted["body_hash"], counted["reward"]))
            self.n_evals, self.best = len(counted), float(done["best_so_far"].iloc[-1])
            self.clock0 -= float(done["elapsed_seconds"].iloc[-1])

    @property
    def label(self) -> str:
        return f"designer {self.spec.designer.label!r} (seed {self.spec.seed})"

    def step(self, evaluate: Evaluate) -> GenerationResult:
        """Ask for a generation, evaluate its new bodies, tell the rewards; the rows and the checkpoint."""
        spec = self.spec
        if self.stale >= MAX_STALE_GENERATIONS:
            raise DesignerError(f"{self.label} proposed no new valid body in {self.stale} generations in a row")
        t0 = time.perf_counter()
        bodies, info, parents = self._ask()
        design_seconds = self.tell_seconds + time.perf_counter() - t0

        rows: list[dict[str, Any]] = []
        tasks: list[EvalTask] = []
        task_rows: list[int] = []
        for index, body in enumerate(bodies):
            row = {
                **self.constants,
                "generation": self.generation,
                "index": index,
                "body": body.text,
                "body_hash": body.hash,
            }
            row.update(info[index] if info else {})
            reason = self.env.invalid_reason(body)
            if reason is not None:
                row.update(reward=math.nan, status=INVALID, message=reason)
            elif body.hash in self.seen:
                row.update(reward=self.seen[body.hash], status=DUPLICATE, message="already evaluated in this run")
            elif self.n_evals + len(tasks) >= spec.budget:
                break  # budget exhausted: the rest of this generation is never evaluated nor told
            else:
                self.seen[body.hash] = math.nan  # reserve: later copies in this generation are duplicates
                eval_seed = seeding.evaluation_seed(spec.seed, body.hash)
                tasks.append(EvalTask(body, eval_seed, spec.env.factory, spec.controller, self.workdir / body.hash,
                                      self._parent_workdirs(parents[index] if parents else ())))
                task_rows.append(len(rows))
            rows.append(row)
        truncated = len(rows) < len(bodies)

        for row_i, task, outcome in zip(task_rows, tasks, evaluate(tasks)):
            self.seen[task.body.hash] = outcome.reward
            rows[row_i].update(
                reward=outcome.reward,
                status=outcome.status,
                message=outcome.message,
                cached=outcome.cached,
                eval_seconds=outcome.seconds,
            )
            rows[row_i].update(_extra(outcome.info, "environment"))
        elapsed, stamp = time.perf_counter() - self.clock0, utc_now()
        for row in rows:
            if row["status"] == DUPLICATE:  # a copy of a body first seen in this same generation gets its reward
                row["reward"] = self.seen[row["body_hash"]]
            if row["status"] in COUNTED:
                self.n_evals += 1
                if row["status"] == OK and not (row["reward"] <= self.best):  # also true while best is nan
                    self.best = row["reward"]
            row.setdefault("eval_seconds", 0.0)
            row.setdefault("cached", False)
            row.update(
                n_evals=self.n_evals,
                best_so_far=self.best,
                design_seconds=design_seconds,
                elapsed_seconds=elapsed,
                timestamp=stamp,
            )
        report = GenerationReport(
            spec.designer.label,
            spec.env.label,
            spec.seed,
            self.generation,
            self.n_evals,
            spec.budget,
            len(tasks),
            self.best,
        )

        generation = self.generation
        if self._ends(truncated, bool(tasks)):
            return GenerationResult(spec.index, generation, rows, None, report)
        t0 = time.perf_counter()
        try:
            self.designer.tell([as_body(r["body"]) for r in rows], [float(r["reward"]) for r in rows])
        except GdabenchError:
            raise
        except Exception as exc:
            raise DesignerError(f"{self.label} raised in tell(): {one_line(exc)}") from exc
        self.tell_seconds = time.perf_counter() - t0
        self.generation += 1
        return GenerationResult(
            spec.index, generation, rows, pickle.dumps(Checkpoint(self.designer, self.generation)), report
        )

    def _ends(self, truncated: bool, evaluated: bool) -> bool:
        spec = self.spec
        if self.n_evals >= spec.budget or truncated:
            return True
        if spec.stop_at_optimum and spec.env.optimum is not None and self.best >= spec.env.optimum:
            return True
        self.stale = 0 if evaluated else self.stale + 1
        return False

    def _parent_workdirs(self, parents: Sequence[Body]) -> tuple[Path, ...]:
        """Where the parents evaluated successfully in this trial keep their files, for a controller that
        inherits (nothing for the others, so that their outcomes stay keyed by body and seed alone)."""
        if not self.inherits:
            return ()
        return tuple(self.workdir / p.hash for p in parents if math.isfinite(self.seen.get(p.hash, math.nan)))

    def _ask(self) -> tuple[list[Body], list[Mapping[str, Any]], list[Sequence[Body]]]:
        try:
            proposed = self.designer.ask()
            info = list(self.designer.proposal_info() or [])
            said = self.designer.proposal_parents() or [] if self.inherits else []
            parents: list[Sequence[Body]] = [[as_body(p) for p in ps] for ps in said]
        except GdabenchError:
            raise
        except Exception as exc:
            raise DesignerError(f"{self.label} raised in ask(): {one_line(exc)}") from exc
        try:
            bodies = [as_body(b) for b in proposed]
        except (GdabenchError, TypeError, ValueError) as exc:
            raise DesignerError(f"{self.label} proposed a malformed body: {exc}") from None
        if not bodies:
            raise DesignerError(f"{self.label} proposed no bodies")
        if info and len(info) != len(bodies):
            raise DesignerError(f"{self.label}: proposal_info() has {len(info)} entries for {len(bodies)} bodies")
        if parents and len(parents) != len(bodies):
            raise DesignerError(f"{self.label}: proposal_parents() has {len(parents)} entries for {len(bodies)} bodies")
        return bodies, [_extra(i, "designer") for i in info], parents


def _extra(extra: Mapping[str, Any], who: str) -> Mapping[str, Any]:
    clash = set(extra) & set(COLUMNS)
    if clash:
        raise DesignerError(f"{who} extra column {sorted(clash)[0]!r} clashes with a core result column")
    return extra
