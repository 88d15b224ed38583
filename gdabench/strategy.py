"""The batch contract: what an evaluation is given and gives back, and how a generation is evaluated.

:class:`EvalTask` and :class:`EvalOutcome` are the vocabulary executors, caches and strategies share;
:class:`EvaluationStrategy` is what a controller may hand a trial (:meth:`gdabench.Controller.evaluation_strategy`)
to evaluate a generation's bodies together.  Part of the plugin contract (re-exported by :mod:`gdabench.sdk`),
so it imports nothing of the machinery that runs it (:mod:`gdabench.execution`).

Evaluation strategies: how a generation's new bodies are evaluated, all of them at once.

By default every new body of a generation is evaluated once, fully.  A controller may instead
hand the trial a strategy (:meth:`gdabench.Controller.evaluation_strategy`) that sees the whole
generation: successive halving, for example, trains every body briefly, and then only the better
part for longer.  A strategy only decides *which* evaluations to run and in what rounds; it
runs them through the ``evaluate`` function it is given (the trial's executor and cache, in
parallel where the run allows), so it stays deterministic and executor-independent as long as it
decides from the outcomes alone.  Bodies it stops early keep the outcome of their last round;
their rows should say so through an extra column of that outcome's ``info``.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from .body import Body
from .specs import Factory


@dataclass(frozen=True)
class EvalTask:
    body: Body
    seed: int
    env: Factory
    controller: Factory | None = None
    workdir: Path | None = None
    #: work directories of the bodies this one came from, nearest first (what the designer said, for a
    #: controller that inherits a parent's policy, ``ppo[init=parent]``); empty otherwise
    parents: tuple[Path, ...] = ()


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


class EvaluationStrategy(abc.ABC):
    """Evaluates one generation's tasks; the outcome ``i`` belongs to task ``i``."""

    @abc.abstractmethod
    def evaluate(self, tasks: Sequence[EvalTask], evaluate: Evaluate) -> list[EvalOutcome]:
        """Outcomes of ``tasks``, by calling ``evaluate`` on (rewritten) tasks as many times as needed."""
