"""Execution: evaluating bodies, in this process, local processes or on Ray.

* :mod:`.evaluation`: scoring a batch of bodies, every failure turned into a recorded outcome;
* :mod:`.workers`, :mod:`.ray`: the one worker layer, for trials and evaluations alike: a server
  object in this process, in spawned local processes or in Ray actors, answering calls without the
  caller waiting;
* :mod:`.executor`, :mod:`.pool`: evaluation executors (serial, or a supervised pool of workers,
  local or Ray), chosen by :func:`make_executor` from the :class:`Execution` options (:mod:`.options`);
* :mod:`.cache`: an opt-in cache of rewards shared across runs.

What an evaluation is given and gives back (:class:`EvalTask`, :class:`EvalOutcome`) and how a controller
may evaluate a whole generation are part of the plugin contract (:mod:`gdabench.strategy`), and starting
worker processes is a leaf module (:mod:`gdabench.spawning`), since plugins use both.

Layering: this package imports the contract and leaf modules below it, never :mod:`gdabench.running`,
:mod:`gdabench.experiment` or :mod:`gdabench.report` (``tests/test_imports.py`` checks the floors).
"""

from ..statuses import COUNTED, DUPLICATE, ERROR, INVALID, OK, TIMEOUT
from ..strategy import EvalOutcome, EvalTask
from .evaluation import evaluate
from .executor import Executor, SerialExecutor
from .options import EXECUTORS, Execution, cpu_count, make_executor

__all__ = [
    "COUNTED", "DUPLICATE", "ERROR", "EXECUTORS", "INVALID", "OK", "TIMEOUT",
    "EvalOutcome", "EvalTask", "Execution", "Executor", "SerialExecutor", "cpu_count", "evaluate", "make_executor",
]  # fmt: skip
