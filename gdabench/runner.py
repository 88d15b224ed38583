"""The harness loop: ask a designer, evaluate its bodies, record every row, tell the rewards.

The runner owns what designers must not: the evaluation budget (counted in evaluations of
unique valid bodies, as Evolution Gym counts them), de-duplication (a body already scored in
this run is not evaluated again; its row says ``duplicate`` and the designer is told the known
reward), validity (invalid bodies are recorded, never scored, and do not use budget),
failures (recorded as ``error`` or ``timeout`` rows that do use budget), the optional
evaluation cache, and writing results after every generation together with a checkpoint, so
that a killed run resumes where it stopped.
"""

from __future__ import annotations

import json
import math
import sys
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import pandas as pd

from . import seeding
from .body import Body, as_body
from .config import Experiment, PluginChoice
from .designer import Designer
from .environment import Environment
from .cache import EvaluationCache, recipe_identity
from .errors import ConfigError, DesignerError, GdabenchError, RunDirectoryError
from .evaluation import COUNTED, DUPLICATE, INVALID, OK, EvalOutcome, EvalTask, one_line
from .executors import make_executor, resolve_workers
from .plugins import Registry, registry
from .results import COLUMNS, Checkpoint, RunDirectory, platform_info, utc_now, versions
from .summary import summarize

#: a designer that proposes nothing new for this many generations in a row is stopped
MAX_STALE_GENERATIONS = 20


@dataclass(frozen=True)
class GenerationReport:
    """Progress of one run after one generation (passed to the ``on_generation`` callback)."""

    designer: str
    seed: int
    generation: int
    n_evals: int
    budget: int
    new_evals: int
    best: float


def build_designer(reg: Registry, experiment: Experiment, choice: PluginChoice, seed: int) -> Designer:
    """Instantiate a designer for one seed of ``experiment``."""
    designer = reg.get("designer", choice.name).spec.create(
        shape=tuple(experiment.shape),
        population=experiment.population,
        budget=experiment.budget,
        seed=seeding.designer_seed(seed),
        **choice.params,
    )
    if not isinstance(designer, Designer):
        raise DesignerError(f"designer {choice.name!r}: factory returned {type(designer).__name__}, not a gdabench.Designer")
    return designer


def _json(params: Mapping[str, Any]) -> str:
    return json.dumps(dict(params), sort_keys=True, default=str)


def _shape_text(shape: Sequence[int]) -> str:
    return f"{shape[0]}x{shape[1]}"


class Runner:
    """Runs every (designer, seed) of an :class:`Experiment` into one run directory."""

    def __init__(
        self,
        experiment: Experiment,
        *,
        workers: int | None = None,
        executor: str | None = None,
        timeout: float | None = None,
        ray_address: str | None = None,
        cache: str | Path | None = None,
        on_generation: Callable[[GenerationReport], None] | None = None,
        reg: Registry | None = None,
    ):
        self.experiment = experiment
        self.reg = reg or registry()
        self.on_generation = on_generation or (lambda report: None)
        exp = experiment
        env_spec = self.reg.get("environment", exp.env.name).spec
        self.env_recipe = env_spec.recipe({"shape": tuple(exp.shape), **exp.env.params})
        self.env: Environment = self.env_recipe.build()
        self.ctrl_recipe = None
        prebuilt: dict[str, Any] = {self.env_recipe.key(): self.env}
        if exp.controller is not None:
            ctrl_spec = self.reg.get("controller", exp.controller.name).spec
            self.ctrl_recipe = ctrl_spec.recipe(exp.controller.params)
            prebuilt[self.ctrl_recipe.key()] = self.ctrl_recipe.build()
        for choice in exp.designers:  # constructor errors (bad parameters) surface before any run starts
            build_designer(self.reg, exp, choice, exp.seeds[0])
        self.cache = self._open_cache(cache) if cache is not None and self.env.deterministic else None
        kind, count = resolve_workers(executor, workers)
        self.execution = {"executor": kind, "workers": count, "timeout": timeout, "ray_address": ray_address, "cache": str(cache) if self.cache else None}
        warm = [r for r in (self.env_recipe, self.ctrl_recipe) if r is not None]
        self.executor = make_executor(kind, count, prebuilt, timeout=timeout, warm=warm, ray_address=ray_address)

    def _open_cache(self, root: str | Path) -> EvaluationCache:
        exp = self.experiment

        def package(kind: str, name: str) -> tuple[str, str]:
            item = self.reg.get(kind, name)  # type: ignore[arg-type]
            return item.distribution, item.version

        try:
            context = {
                "env": exp.env.name,
                "env_recipe": recipe_identity(self.env_recipe, package("environment", exp.env.name)),
                "controller": exp.controller.name if exp.controller else None,
                "controller_recipe": recipe_identity(self.ctrl_recipe, package("controller", exp.controller.name) if exp.controller else None),
            }
        except TypeError as exc:
            raise ConfigError(f"cannot use the evaluation cache: a parameter is not a plain value ({exc})") from None
        return EvaluationCache(root, context)

    # -- the loop ----------------------------------------------------------------------------------
    def run_all(self, run: RunDirectory) -> pd.DataFrame:
        """Run every (seed, designer) pair not yet complete in ``run``; returns the full table."""
        self.run, self.run_id = run, run.meta["run_id"]
        try:
            for repetition, seed in enumerate(self.experiment.seeds):
                for choice in self.experiment.designers:
                    self.run_trial(choice, seed, repetition)
        finally:
            self.executor.close()
        return run.load_evaluations()

    def run_trial(self, choice: PluginChoice, seed: int, repetition: int) -> None:
        exp, label = self.experiment, choice.label
        if self.run.is_finished(label, seed):
            return
        checkpoint = self.run.load_checkpoint(label, seed)
        start_gen = checkpoint.next_generation if checkpoint else 0
        done = self.run.pending_rows(label, seed, before_generation=start_gen)
        designer = checkpoint.designer if checkpoint else build_designer(self.reg, exp, choice, seed)
        seen: dict[str, float] = {}
        n_evals, best, clock0 = 0, math.nan, time.perf_counter()
        if done is not None:
            counted = done[done["status"].isin(COUNTED)]
            seen = dict(zip(counted["body_hash"], counted["reward"]))
            n_evals, best = len(counted), float(done["best_so_far"].iloc[-1])
            clock0 -= float(done["elapsed_seconds"].iloc[-1])
        constant = {
            "run_id": self.run_id,
            "designer": label,
            "designer_name": choice.name,
            "env": exp.env.label,
            "env_version": self.env.version or "",
            "controller": exp.controller.label if exp.controller else "",
            "designer_params": _json({**self.reg.get("designer", choice.name).spec.defaults, **choice.params}),
            "env_params": _json({k: v for k, v in self.env_recipe.params if k != "shape"}),
            "controller_params": _json(dict(self.ctrl_recipe.params)) if self.ctrl_recipe else "{}",
            "shape": _shape_text(exp.shape),
            "population": exp.population,
            "budget": exp.budget,
            "seed": seed,
            "repetition": repetition,
        }
        workdir_root = self.run.path / "artifacts" / self.run.trial_name(label, seed)
        generation, stale, tell_seconds = start_gen, 0, 0.0
        while n_evals < exp.budget:
            t0 = time.perf_counter()
            bodies, info = self._ask(designer, label, seed)
            design_seconds = tell_seconds + time.perf_counter() - t0

            rows: list[dict[str, Any]] = []
            tasks: list[EvalTask] = []
            task_rows: list[int] = []
            for index, body in enumerate(bodies):
                row = {**constant, "generation": generation, "index": index, "body": body.text, "body_hash": body.hash}
                row.update(info[index] if info else {})
                reason = self.env.invalid_reason(body)
                if reason is not None:
                    row.update(reward=math.nan, status=INVALID, message=reason)
                elif body.hash in seen:
                    row.update(reward=seen[body.hash], status=DUPLICATE, message="already evaluated in this run")
                elif n_evals + len(tasks) >= exp.budget:
                    break  # budget exhausted: the rest of this generation is never evaluated nor told
                else:
                    seen[body.hash] = math.nan  # reserve: later copies in this generation are duplicates
                    eval_seed = seeding.evaluation_seed(seed, body.hash)
                    tasks.append(EvalTask(body, eval_seed, self.env_recipe, self.ctrl_recipe, workdir_root / body.hash))
                    task_rows.append(len(rows))
                rows.append(row)
            truncated = len(rows) < len(bodies)

            outcomes = self._evaluate(tasks)
            for row_i, task, outcome in zip(task_rows, tasks, outcomes):
                seen[task.body.hash] = outcome.reward
                rows[row_i].update(
                    reward=outcome.reward, status=outcome.status, message=outcome.message, cached=outcome.cached, eval_seconds=outcome.seconds
                )
                rows[row_i].update(self._check_extra(outcome.info, "environment"))
            elapsed = time.perf_counter() - clock0
            stamp = utc_now()
            # a duplicate of a body first seen in this same generation gets that body's reward
            for row in rows:
                if row["status"] == DUPLICATE:
                    row["reward"] = seen[row["body_hash"]]
            for row in rows:
                if row["status"] in COUNTED:
                    n_evals += 1
                    if row["status"] == OK and not (row["reward"] <= best):  # also true while best is nan
                        best = row["reward"]
                row.setdefault("eval_seconds", 0.0)
                row.setdefault("cached", False)
                row.update(n_evals=n_evals, best_so_far=best, design_seconds=design_seconds, elapsed_seconds=elapsed, timestamp=stamp)
            self.run.append_generation(label, seed, generation, rows)
            self.on_generation(GenerationReport(label, seed, generation, n_evals, exp.budget, len(tasks), best))

            if n_evals >= exp.budget or truncated:
                break
            if exp.stop_at_optimum and self.env.optimum is not None and best >= self.env.optimum:
                break
            stale = 0 if tasks else stale + 1
            if stale >= MAX_STALE_GENERATIONS:
                raise DesignerError(f"designer {label!r} (seed {seed}) proposed no new valid body in {stale} generations in a row")
            t0 = time.perf_counter()
            told = [as_body(r["body"]) for r in rows]
            try:
                designer.tell(told, [float(r["reward"]) for r in rows])
            except GdabenchError:
                raise
            except Exception as exc:  # noqa: BLE001
                raise DesignerError(f"designer {label!r} (seed {seed}) raised in tell(): {one_line(exc)}") from exc
            tell_seconds = time.perf_counter() - t0
            generation += 1
            self.run.save_checkpoint(label, seed, Checkpoint(designer, generation))
        self.run.finish_trial(label, seed)

    def _evaluate(self, tasks: list[EvalTask]) -> list[EvalOutcome]:
        """Outcomes in task order: cached rewards where the cache has them, the executor for the rest."""
        if self.cache is None:
            return self.executor.map(tasks)
        hits = [self.cache.get(task) for task in tasks]
        misses = [task for task, hit in zip(tasks, hits) if hit is None]
        fresh = iter(self.executor.map(misses))
        outcomes = []
        for task, hit in zip(tasks, hits):
            if hit is None:
                hit = next(fresh)
                self.cache.put(task, hit)
            outcomes.append(hit)
        return outcomes

    def _ask(self, designer: Designer, label: str, seed: int) -> tuple[list[Body], list[Mapping[str, Any]]]:
        try:
            proposed = designer.ask()
            info = list(designer.proposal_info() or [])
        except GdabenchError:
            raise
        except Exception as exc:  # noqa: BLE001
            raise DesignerError(f"designer {label!r} (seed {seed}) raised in ask(): {one_line(exc)}") from exc
        try:
            bodies = [as_body(b) for b in proposed]
        except (GdabenchError, TypeError, ValueError) as exc:
            raise DesignerError(f"designer {label!r} (seed {seed}) proposed a malformed body: {exc}") from None
        if not bodies:
            raise DesignerError(f"designer {label!r} (seed {seed}) proposed no bodies")
        if info and len(info) != len(bodies):
            raise DesignerError(f"designer {label!r}: proposal_info() has {len(info)} entries for {len(bodies)} bodies")
        return bodies, [self._check_extra(i, "designer") for i in info]

    @staticmethod
    def _check_extra(extra: Mapping[str, Any], who: str) -> Mapping[str, Any]:
        clash = set(extra) & set(COLUMNS)
        if clash:
            raise DesignerError(f"{who} extra column {sorted(clash)[0]!r} clashes with a core result column")
        return extra


def _new_meta(experiment: Experiment, reg: Registry, command: Sequence[str] | None, env: Environment, execution: Mapping[str, Any]) -> dict[str, Any]:
    stamp = time.strftime("%Y%m%d-%H%M%S")
    return {
        "run_id": f"{stamp}-{uuid.uuid4().hex[:6]}",
        "status": "running",
        "created": utc_now(),
        "command": list(command if command is not None else sys.argv),
        "config": experiment.to_json(),
        "env_optimum": env.optimum,
        "env_version": env.version,
        "execution": dict(execution),
        "versions": versions(reg.distributions()),
        "platform": platform_info(),
    }


def default_out_dir(experiment: Experiment, root: str | Path = "results") -> Path:
    names = "-".join(d.name for d in experiment.designers)
    return Path(root) / f"{time.strftime('%Y%m%d-%H%M%S')}-{experiment.env.name.replace('/', '_')}-{names}"


def compare(
    experiment: Experiment,
    out: str | Path | None = None,
    *,
    resume: bool = False,
    workers: int | None = None,
    executor: str | None = None,
    timeout: float | None = None,
    ray_address: str | None = None,
    cache: str | Path | None = None,
    on_generation: Callable[[GenerationReport], None] | None = None,
    command: Sequence[str] | None = None,
    reg: Registry | None = None,
) -> RunDirectory:
    """Run (or resume) ``experiment`` into ``out`` and return the finished run directory.

    Everything is checked before the directory is created.  On failure the directory's
    ``run.json`` says ``failed`` (or ``interrupted``) with the error, and the run can be resumed.
    Execution options (executor, workers, Ray address, cache) may differ on resume; the timeout
    defaults to the one the run was started with.
    """
    reg = reg or registry()
    if resume:
        if out is None:
            raise RunDirectoryError("resume needs the run directory")
        run = RunDirectory.open(out)
        meta = run.meta
        if meta.get("status") == "complete":
            return run
        experiment = Experiment.from_json(meta["config"])
        experiment.validate(reg)
        if timeout is None:
            timeout = (meta.get("execution") or {}).get("timeout")
    else:
        experiment.validate(reg)
    execution = dict(workers=workers, executor=executor, timeout=timeout, ray_address=ray_address, cache=cache)
    runner = Runner(experiment, **execution, on_generation=on_generation, reg=reg)
    if resume:
        resumed = {"at": utc_now(), **runner.execution}
        run.update_meta(status="running", resumed=[*meta.get("resumed", []), resumed], error=None)
    else:
        meta = _new_meta(experiment, reg, command, runner.env, runner.execution)
        try:
            run = RunDirectory.create(out or default_out_dir(experiment), meta)
        except BaseException:
            runner.executor.close()
            raise
    try:
        frame = runner.run_all(run)
    except KeyboardInterrupt:
        run.update_meta(status="interrupted", error="interrupted by the user")
        raise
    except BaseException as exc:
        run.update_meta(status="failed", error=str(exc) if isinstance(exc, GdabenchError) else one_line(exc))
        raise
    optimum = run.meta.get("env_optimum")
    summarize(frame, optimum).to_csv(run.path / "summary.csv", index=False)
    run.update_meta(status="complete", finished=utc_now())
    return run
