"""The evaluation executor interface: where the bodies of one generation are evaluated.

Results always come back in task order and an evaluation depends only on its task (body,
evaluation seed, environment and controller recipes), so a run's table does not depend on the
executor, the number of workers, or which evaluation finishes first.  Executors are context
managers: leaving the block releases their workers, whatever happened inside it.

Executors hand bodies over in batches (:func:`batches`): each batch is evaluated in one call, so
an environment or controller can simulate or learn its bodies together.  Batching does not change
results either: an evaluation must not depend on the other bodies of its batch.
"""

from __future__ import annotations

import abc
import math
from typing import Sequence

from ..strategy import EvalOutcome, EvalTask
from .evaluation import evaluate_batch


class Executor(abc.ABC):
    """Evaluates batches of tasks; outcome ``i`` belongs to task ``i``."""

    @abc.abstractmethod
    def map(self, tasks: Sequence[EvalTask], batch: int = 1) -> list[EvalOutcome]:
        """Evaluate ``tasks``, at most ``batch`` bodies per call, and return their outcomes in task order."""

    def close(self) -> None:  # noqa: B027 - optional: only executors with workers override it
        """Release workers (idempotent)."""

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class SerialExecutor(Executor):
    """Evaluate in the calling process, reusing its already built environment and controller.

    No timeout is possible here (a running Python function cannot be stopped from outside): a
    hang hangs the trial and a crash ends it; ask for a timeout to evaluate in a worker process.
    """

    def map(self, tasks: Sequence[EvalTask], batch: int = 1) -> list[EvalOutcome]:
        outcomes: list[EvalOutcome | None] = [None] * len(tasks)
        for part in batches(tasks, 1, batch):
            for i, outcome in zip(part, evaluate_batch([tasks[i] for i in part])):
                outcomes[i] = outcome
        return outcomes  # type: ignore[return-value]


def batches(tasks: Sequence[EvalTask], parts: int, most: int) -> list[list[int]]:
    """Task indices in batches of one environment and controller each, at most ``most`` bodies per batch and,
    where there are enough bodies, at least ``parts`` batches (one per worker), near-equal in size."""
    groups: dict[tuple[str, str | None], list[int]] = {}
    for i, task in enumerate(tasks):
        groups.setdefault((task.env.key(), task.controller.key() if task.controller else None), []).append(i)
    out = []
    for group in groups.values():
        k = min(len(group), max(parts, math.ceil(len(group) / most)))
        size, extra = divmod(len(group), k)
        start = 0
        for j in range(k):
            end = start + size + (j < extra)
            out.append(group[start:end])
            start = end
    return out
