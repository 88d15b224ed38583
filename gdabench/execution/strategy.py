"""Evaluation strategies: how a generation's new bodies are evaluated, all of them at once.

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
from typing import Sequence

from .tasks import EvalOutcome, EvalTask, Evaluate


class EvaluationStrategy(abc.ABC):
    """Evaluates one generation's tasks; the outcome ``i`` belongs to task ``i``."""

    @abc.abstractmethod
    def evaluate(self, tasks: Sequence[EvalTask], evaluate: Evaluate) -> list[EvalOutcome]:
        """Outcomes of ``tasks``, by calling ``evaluate`` on (rewritten) tasks as many times as needed."""
