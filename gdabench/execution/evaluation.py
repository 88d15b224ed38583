"""Evaluating a batch of bodies, with every failure turned into a recorded outcome.

This is the function executors run, in the driver or in worker processes: a batch (part of a
generation, as large as ``--batch`` allows) goes to the environment in one call
(:meth:`gdabench.Environment.evaluate_bodies`), so that an environment or controller that
simulates or learns bodies together can.  An environment that raises (``sys.exit`` included) or
returns a non-finite reward yields an ``error`` outcome for that body, with its message; a failure
of the whole call is every body's; the run goes on.  Hangs and dying worker processes are the
executors' job (``timeout`` and ``error`` outcomes).  Environments and controllers are built once
per process and reused.
"""

from __future__ import annotations

import inspect
import math
import time
from typing import Any, Sequence

from ..environment import Environment, Evaluation
from ..errors import one_line
from ..specs import Factory
from ..statuses import ERROR, OK
from ..strategy import EvalOutcome, EvalTask

_built: dict[str, Any] = {}

def instance(recipe: Factory) -> Any:
    """The object ``recipe`` builds, built once per process: the one cache of built environments and
    controllers (the plan puts in the ones it built to check them, :func:`adopt`)."""
    key = recipe.key()
    if key not in _built:
        _built[key] = recipe.build()
    return _built[key]


def adopt(recipe: Factory, built: Any) -> Any:
    """Make ``built`` this process's object for ``recipe`` (a newer plan's replaces an older one's)."""
    _built[recipe.key()] = built
    return built


def prepare(recipes: Sequence[Factory]) -> None:
    """Build and keep the environment and controller in this process before the first body.

    Worker processes call this at start-up so that building (importing torch, loading a
    simulator) is not charged to the first evaluation's time or timeout.  A recipe that fails
    to build is skipped here: :func:`evaluate` reports the failure for every body.
    """
    for recipe in recipes:
        try:
            instance(recipe)
        except Exception:  # noqa: BLE001
            pass


def evaluate_batch(tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
    """Score ``tasks`` (bodies of one environment and controller) in one call; never raises for a failure
    of the environment or controller.  A body's ``seconds`` is its share of the call's time."""
    start = time.perf_counter()
    first = tasks[0]
    if any(task.env != first.env or task.controller != first.controller for task in tasks):
        raise ValueError("a batch holds bodies of one environment and controller")
    try:
        env: Environment = instance(first.env)
        controller = instance(first.controller) if first.controller else None
        # the parents' work directories go to environments that hand them on (ControlledEnvironment does)
        lineage = (
            {"parents": [task.parents for task in tasks]}
            if any(task.parents for task in tasks) and "parents" in inspect.signature(env.evaluate_bodies).parameters
            else {}
        )
        results = env.evaluate_bodies(
            [task.body for task in tasks],
            seeds=[task.seed for task in tasks],
            controller=controller,
            workdirs=[task.workdir for task in tasks],
            **lineage,
        )
        if len(results) != len(tasks):
            raise RuntimeError(f"evaluate_bodies returned {len(results)} results for {len(tasks)} bodies")
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - a failing evaluation is data, not a crash
        seconds = (time.perf_counter() - start) / len(tasks)
        return [EvalOutcome(math.nan, ERROR, one_line(exc), seconds) for _ in tasks]
    seconds = (time.perf_counter() - start) / len(tasks)
    return [_outcome(result, seconds) for result in results]


def evaluate(task: EvalTask) -> EvalOutcome:
    """Score one body (the batch of one)."""
    return evaluate_batch([task])[0]


def _outcome(result: float | Evaluation | BaseException, seconds: float) -> EvalOutcome:
    if isinstance(result, BaseException):
        return EvalOutcome(math.nan, ERROR, one_line(result), seconds)
    ev = result if isinstance(result, Evaluation) else Evaluation(float(result))
    try:
        reward = float(ev.reward)
    except (TypeError, ValueError) as exc:
        return EvalOutcome(math.nan, ERROR, one_line(exc), seconds)
    if not math.isfinite(reward):
        return EvalOutcome(
            math.nan, ERROR, f"environment returned a non-finite reward ({reward})", seconds, dict(ev.info)
        )
    return EvalOutcome(reward, OK, "", seconds, dict(ev.info))
