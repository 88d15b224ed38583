"""Re-evaluation: each trial's final best bodies trained again under further seeds.

Where a body's reward depends on a training seed (a controller learns it), a trial's best reward is
the largest of a budget's worth of noisy numbers, and so biased upward: the winner's curse.  After
every trial has spent its budget, the ``top`` best distinct bodies of each trial (by their reward in
the trial; ties: the earlier) are evaluated again under ``seeds`` further seeds each
(:func:`gdabench.seeding.reevaluation_seed`, a stream of its own, so the draw that selected a body
is never reused to score it).  The report scores the trial by the best of those bodies' means over
the further seeds (:func:`gdabench.stats.reevaluated.trial_scores`).

Rows go to ``<run>/reevaluations.parquet`` (:data:`gdabench.results.REEVALUATION_COLUMNS`),
rewritten whole after each trial's bodies, so a killed run loses at most one trial's re-evaluations
and a resume does only what is missing.  Re-evaluations do not use a trial's budget and never enter
``evaluations.parquet``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Callable

import pandas as pd

from .. import seeding
from ..body import Body
from ..cpu import cpu_count
from ..errors import ConfigError
from ..execution.executor import Executor
from ..execution.options import Execution, make_executor
from ..experiment.config import Reevaluation
from ..experiment.plan import Plan
from ..plugins import Registry
from ..results import (
    REEVALUATION_COLUMNS,
    REEVALUATION_KEYS,
    REEVALUATION_TYPES,
    REEVALUATIONS,
    RunDirectory,
    atomic_write_bytes,
    load_reevaluations,
    parquet_bytes,
)
from ..statuses import OK
from ..strategy import EvalTask


def top_bodies(trial: pd.DataFrame, top: int) -> pd.DataFrame:
    """The ``top`` best distinct bodies a trial evaluated, best first (ties: the one evaluated first)."""
    ok = trial[trial["status"] == OK]
    ranked = ok.sort_values(["reward", "n_evals", "index"], ascending=[False, True, True], kind="stable")
    return ranked.drop_duplicates("body_hash").head(top)


def reevaluate(
    run: RunDirectory,
    plan: Plan,
    how: Reevaluation,
    executor: Executor,
    batch: int,
    on_trial: Callable[[str, int, int], None] | None = None,
) -> pd.DataFrame:
    """Re-evaluate every finished trial of the run that is not yet done, in the table's order; returns the
    whole table.  ``plan`` (environments and controller) may be resolved without designers.

    ``on_trial(title, done, total)`` is told after each trial's bodies.
    """
    frame = run.load_evaluations()
    table = load_reevaluations(run.path)
    done = set(map(tuple, table.loc[table["status"] == OK, REEVALUATION_KEYS].itertuples(index=False)))
    table = table[table["status"] == OK]  # failed re-evaluations are tried again
    envs = {e.label: e for e in plan.envs}
    trials = list(dict.fromkeys(zip(frame["env"], frame["designer"], frame["seed"])))
    for number, (env, designer, seed) in enumerate(trials, 1):
        rows = frame[(frame["env"] == env) & (frame["designer"] == designer) & (frame["seed"] == seed)]
        run_id = str(rows["run_id"].iloc[0]) if "run_id" in rows.columns and len(rows) else ""
        todo: list[tuple[dict, EvalTask]] = []
        for rank, best in enumerate(top_bodies(rows, how.top).itertuples(), 1):
            body = Body.from_text(best.body)
            for replicate in range(1, how.seeds + 1):
                if (env, designer, seed, body.hash, replicate) in done:
                    continue
                eval_seed = seeding.reevaluation_seed(seed, body.hash, replicate)
                row = {"env": env, "designer": designer, "seed": seed, "run_id": run_id, "rank": rank,
                       "body": body.text, "body_hash": body.hash, "first_reward": float(best.reward),
                       "replicate": replicate, "eval_seed": eval_seed}  # fmt: skip
                todo.append((row, EvalTask(body, eval_seed, envs[env].factory, plan.controller)))
        if todo:
            outcomes = executor.map([task for _, task in todo], batch)
            new = [{**row, "reward": o.reward if o.status == OK else math.nan, "status": o.status,
                    "message": o.message, "eval_seconds": o.seconds}
                   for (row, _), o in zip(todo, outcomes)]  # fmt: skip
            added = pd.DataFrame(new, columns=REEVALUATION_COLUMNS).astype(REEVALUATION_TYPES)
            table = pd.concat([table, added], ignore_index=True)
            atomic_write_bytes(run.path / REEVALUATIONS, parquet_bytes(table[REEVALUATION_COLUMNS]))
        if on_trial is not None:
            on_trial(f"{designer} seed {seed}" + (f" on {env}" if len(envs) > 1 else ""), number, len(trials))
    return table


def reevaluate_run(
    run: RunDirectory,
    plan: Plan,
    how: Reevaluation,
    execution: Execution,
    on_trial: Callable[[str, int, int], None] | None = None,
) -> pd.DataFrame:
    """:func:`reevaluate` with an executor of the run's execution options: as many evaluation processes as
    the run ran trials at once (``--jobs``) times ``--workers``, in this process when that is one; each
    call as large as ``--batch`` or the controller's lockstep batch."""
    env, controller = plan.scorers()
    batch = execution.batch or (controller or env).bodies_at_once
    if getattr(controller, "learns_across_bodies", False):
        batch = 1  # each re-evaluation learns alone, from scratch: the same for any --jobs and trial order
    workers = (execution.jobs or max(1, cpu_count() // execution.workers)) * execution.workers
    pool = Execution(executor=execution.executor, workers=workers, timeout=execution.timeout,
                     ray_address=execution.ray_address)  # fmt: skip
    warm = [r for r in (*(e.factory for e in plan.envs), plan.controller) if r is not None]
    with make_executor(pool, warm) as executor:
        return reevaluate(run, plan, how, executor, batch, on_trial)


def reevaluate_directory(
    run_dir: str | Path,
    how: Reevaluation | None = None,
    execution: Execution | None = None,
    on_trial: Callable[[str, int, int], None] | None = None,
    reg: Registry | None = None,
) -> pd.DataFrame:
    """Re-evaluate the finished trials of a run already on disk (a run made without re-evaluation, or one
    whose re-evaluation was cut short), holding the run's lock; ``how`` defaults to the run's own setting
    (its experiment's, or the one it was re-evaluated with before), else to the default top and seeds.
    ``run.json`` records the setting under ``reevaluated``."""
    import time

    from ..experiment.build import stored_experiment
    from ..plugins import registry

    run = RunDirectory.open(run_dir)
    experiment = stored_experiment(run)
    recorded = run.meta.get("reevaluated") or {}
    earlier = Reevaluation(recorded["top"], recorded["seeds"]) if recorded else None
    how = how or experiment.reevaluate or earlier or Reevaluation()
    if recorded and (recorded.get("top"), recorded.get("seeds")) != (how.top, how.seeds):
        raise ConfigError(f"{run.path} was re-evaluated {recorded.get('top')}x{recorded.get('seeds')}; "
                          f"re-evaluating it {how.text} would mix two settings in one table")  # fmt: skip
    plan = Plan.resolve(experiment, reg or registry(), designers=False)
    plan.check_versions(run.path, run.meta, "re-evaluating it")
    run.lock()
    start, before = time.monotonic(), float(recorded.get("wall_seconds", 0.0))

    def record() -> None:  # the setting from the start (a killed re-evaluation resumes with it), the time after
        seconds = round(before + time.monotonic() - start, 1)
        run.update_meta(reevaluated={"top": how.top, "seeds": how.seeds, "wall_seconds": seconds})

    def trial_done(title: str, done: int, total: int) -> None:
        record()
        if on_trial is not None:
            on_trial(title, done, total)

    try:
        record()
        table = reevaluate_run(run, plan, how, execution or Execution(), trial_done)
    finally:
        record()
        run.unlock()
    return table
