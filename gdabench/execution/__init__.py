"""Execution: evaluating bodies, in this process, local processes or on Ray.

* :mod:`.tasks`: what an evaluation is given and gives back (:class:`EvalTask`, :class:`EvalOutcome`);
* :mod:`.evaluation`: scoring a batch of bodies, every failure turned into a recorded outcome;
* :mod:`.executor`, :mod:`.pool`, :mod:`.ray`: evaluation executors (serial, a supervised pool
  of local processes, Ray actors), chosen by :func:`make_executor` from the :class:`Execution`
  options (:mod:`.options`);
* :mod:`.strategy`: how a controller may evaluate a whole generation (successive halving);
* :mod:`.cache`: an opt-in cache of rewards shared across runs;
* :mod:`.spawning`: starting worker processes, for the pool here and for trial hosts and designers.

Layering: this package imports the interfaces and data modules below it, never
:mod:`gdabench.running` (which runs experiments and imports this package; ``tests/test_imports.py``
checks).  ``options`` and ``spawning`` are here although running an experiment uses them too
(``jobs``, the trial hosts' processes), because the executors need them and must not reach up.
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
