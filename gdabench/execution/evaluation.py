"""Evaluating one body, with every failure turned into a recorded outcome.

This is the function executors run, in the driver or in worker processes.  An environment
that raises (``sys.exit`` included) or returns a non-finite reward yields an ``error`` outcome
with its message; the run goes on.  Hangs and dying worker processes are the executors' job
(``timeout`` and ``error`` outcomes).  Environments and controllers are built once per process
and reused.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from ..body import Body
from ..environment import Environment, Evaluation
from ..errors import one_line
from ..specs import Factory

OK, INVALID, DUPLICATE, ERROR, TIMEOUT = "ok", "invalid", "duplicate", "error", "timeout"
#: statuses that used an evaluation (and so count against the budget)
COUNTED = (OK, ERROR, TIMEOUT)


@dataclass(frozen=True)
class EvalTask:
    body: Body
    seed: int
    env: Factory
    controller: Factory | None = None
    workdir: Path | None = None


@dataclass(frozen=True)
class EvalOutcome:
    reward: float
    status: str
    message: str = ""
    seconds: float = 0.0
    info: Mapping[str, Any] = field(default_factory=dict)
    #: the reward was taken from the evaluation cache instead of being computed
    cached: bool = False


#: what evaluates a generation's tasks (an executor's ``map``, possibly behind a cache): outcome ``i`` is task ``i``'s
Evaluate = Callable[[Sequence[EvalTask]], list[EvalOutcome]]


_built: dict[str, Any] = {}


def instance(recipe: Factory, prebuilt: Mapping[str, Any] | None = None) -> Any:
    """The object ``recipe`` builds, built once per process (or taken from ``prebuilt``)."""
    key = recipe.key()
    if prebuilt and key in prebuilt:
        return prebuilt[key]
    if key not in _built:
        _built[key] = recipe.build()
    return _built[key]


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


def evaluate(task: EvalTask, prebuilt: Mapping[str, Any] | None = None) -> EvalOutcome:
    """Score one body; never raises for a failure of the environment or controller."""
    start = time.perf_counter()
    try:
        env: Environment = instance(task.env, prebuilt)
        controller = instance(task.controller, prebuilt) if task.controller else None
        result = env.evaluate(task.body, seed=task.seed, controller=controller, workdir=task.workdir)
        ev = result if isinstance(result, Evaluation) else Evaluation(float(result))
        reward = float(ev.reward)
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - a failing evaluation is data, not a crash
        return EvalOutcome(math.nan, ERROR, one_line(exc), time.perf_counter() - start)
    seconds = time.perf_counter() - start
    if not math.isfinite(reward):
        return EvalOutcome(
            math.nan, ERROR, f"environment returned a non-finite reward ({reward})", seconds, dict(ev.info)
        )
    return EvalOutcome(reward, OK, "", seconds, dict(ev.info))
