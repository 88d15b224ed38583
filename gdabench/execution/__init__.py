"""Execution: evaluating bodies and running trials, in this process, local processes or on Ray.

* :mod:`.evaluation`: scoring a batch of bodies, every failure turned into a recorded outcome;
* :mod:`.executor`, :mod:`.pool`, :mod:`.ray`: evaluation executors (serial, a supervised pool
  of local processes, Ray actors), chosen by :func:`make_executor` from the :class:`Execution`
  options (:mod:`.options`);
* :mod:`.trials`: where whole trials run (this process, local worker processes, Ray actors);
* :mod:`.cache`: an opt-in cache of rewards shared across runs.
"""

from ..statuses import COUNTED, DUPLICATE, ERROR, INVALID, OK, TIMEOUT
from .evaluation import evaluate
from .executor import Executor, SerialExecutor
from .options import EXECUTORS, Execution, cpu_count, make_executor
from .tasks import EvalOutcome, EvalTask

__all__ = [
    "COUNTED", "DUPLICATE", "ERROR", "EXECUTORS", "INVALID", "OK", "TIMEOUT",
    "EvalOutcome", "EvalTask", "Execution", "Executor", "SerialExecutor", "cpu_count", "evaluate", "make_executor",
]  # fmt: skip
