"""How a trial's generation is evaluated: one object, four named steps.

A generation's tasks go through the steps in this order, each handing what it cannot answer itself
to the next:

1. ``strategy``: the controller's evaluation strategy (:class:`gdabench.EvaluationStrategy`), which
   may rewrite the tasks or call the rest of the pipeline several times (None: the tasks as they are);
2. ``replay``: the run's own record (:class:`~.outcomes.RunOutcomes`): bodies this run already scored
   (before a kill, or in another trial) are replayed; the rest go on a part at a time (as many bodies
   as the workers take in one batch each), each finished part reported and recorded at once;
3. ``cache``: ``--cache`` (:class:`~gdabench.execution.cache.EvaluationCache`): rewards of earlier
   runs, fresh ones stored;
4. ``executor``: the evaluation executor (this process, local worker processes or Ray actors),
   ``batch`` bodies per call.

Steps 2 and 3 are off (None) where their record could be wrong: an environment that is not
deterministic, a controller whose reward depends on the trial's history (the cache), a Ray cluster
whose nodes may not see the run directory (the replay).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

from ..execution.cache import EvaluationCache
from ..execution.executor import Executor
from ..strategy import EvalOutcome, EvalTask, EvaluationStrategy
from .outcomes import RunOutcomes


@dataclass
class EvaluationPipeline:
    """A trial's evaluation: call it with a generation's tasks for their outcomes, in task order.

    ``report(done, total)`` is told before the first part and after each part of a generation.
    """

    executor: Executor
    batch: int
    at_once: int
    report: Callable[[int, int], None]
    cache: EvaluationCache | None = None
    replay: RunOutcomes | None = None
    strategy: EvaluationStrategy | None = None

    def __call__(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        if self.strategy is None:
            return self.replayed(tasks)
        return self.strategy.evaluate(tasks, evaluate=self.replayed)

    def replayed(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        """Step 2: recorded outcomes replayed, the rest evaluated ``at_once`` bodies at a time and recorded."""
        known = [self.replay.get(task) if self.replay is not None else None for task in tasks]
        todo = [i for i, outcome in enumerate(known) if outcome is None]
        done = len(tasks) - len(todo)
        self.report(done, len(tasks))
        for start in range(0, len(todo), self.at_once):
            part = todo[start : start + self.at_once]
            for i, outcome in zip(part, self.cached([tasks[i] for i in part])):
                known[i] = outcome
                if self.replay is not None:
                    self.replay.put(tasks[i], outcome)
            done += len(part)
            self.report(done, len(tasks))
        filled = [outcome for outcome in known if outcome is not None]
        assert len(filled) == len(tasks), "every body was evaluated or replayed"
        return filled

    def cached(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        """Step 3: cached rewards where the cache has them, fresh ones stored."""
        if self.cache is None:
            return self.executed(tasks)
        cache = self.cache
        hits = [cache.get(task) for task in tasks]
        fresh = iter(self.executed([task for task, hit in zip(tasks, hits) if hit is None]))
        outcomes = []
        for task, hit in zip(tasks, hits):
            if hit is None:
                hit = next(fresh)
                cache.put(task, hit)
            outcomes.append(hit)
        return outcomes

    def executed(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        """Step 4: the executor, ``batch`` bodies per call."""
        return self.executor.map(tasks, batch=self.batch)
