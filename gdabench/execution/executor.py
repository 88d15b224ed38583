"""The evaluation executor interface: where the bodies of one generation are evaluated.

Results always come back in task order and an evaluation depends only on its task (body,
evaluation seed, environment and controller recipes), so a run's table does not depend on the
executor, the number of workers, or which evaluation finishes first.  Executors are context
managers: leaving the block releases their workers, whatever happened inside it.
"""

from __future__ import annotations

import abc
from typing import Any, Mapping, Sequence

from .evaluation import EvalOutcome, EvalTask, evaluate


class Executor(abc.ABC):
    """Evaluates batches of tasks; outcome ``i`` belongs to task ``i``."""

    @abc.abstractmethod
    def map(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        """Evaluate ``tasks`` and return their outcomes in task order."""

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

    def __init__(self, prebuilt: Mapping[str, Any] | None = None):
        self.prebuilt = dict(prebuilt or {})

    def map(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        return [evaluate(task, self.prebuilt) for task in tasks]
