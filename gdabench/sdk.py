"""The plugin SDK: what a designer, environment or controller may use from gdabench besides its interfaces.

A plugin (built-in or a third party's) imports the interfaces (:mod:`gdabench.designer`,
:mod:`gdabench.environment`, :mod:`gdabench.specs`), the leaf modules (:mod:`gdabench.body`,
:mod:`gdabench.errors`, :mod:`gdabench.seeding`, ...) and this module, never the harness's machinery
(:mod:`gdabench.execution`, :mod:`gdabench.running`, :mod:`gdabench.results`), which may change between
releases; ``tests/test_imports.py`` holds the built-in plugins to the same rule.

* progress: :func:`report_progress` says how a long evaluation or a designer's step is going;
* cores: a designer offered the run's spare cores through :meth:`gdabench.Designer.lend_cores` asks
  :func:`cpu_count` how many this process may use;
* helpers: :mod:`gdabench.spawning` starts a helper process the way the harness starts its workers
  (killed with its parent, Ctrl-C left to the parent), e.g. ``gda`` training ahead on a second core;
* the evaluation contract: :class:`EvalTask`, :class:`EvalOutcome` and :class:`EvaluationStrategy`
  (a controller's way of evaluating a whole generation, :meth:`gdabench.Controller.evaluation_strategy`);
* the batch contract between controllers and environments: :class:`BodyBatch` (many bodies' environments
  stepped as one batch, each step a :class:`Transition`), built by :class:`GymBodies` from Gymnasium
  environments or by :class:`ArrayBodies` from an array simulator; :func:`gdabench.testing.check_body_batch`
  checks an environment's batches;
* parameters: :func:`config_signature` gives a plugin class the signature of its config dataclass, so its
  parameters are checked like any factory's; :func:`read_parquet` reads a results table (e.g. a prior);
* files: :func:`atomic_write_bytes` writes a file whole or not at all, as the run directory does (a plugin's
  artifacts that a resumed run reads back).
"""

from __future__ import annotations

import contextlib
from typing import Callable, Iterator

from . import spawning
from .atomic import atomic_write_bytes
from .batched import UNSTABLE_INFO_KEY, ArrayBodies, ArraySimulator, BodyBatch, GymBodies, Transition
from .cpu import cpu_count
from .params import config_signature
from .parquet import read_parquet
from .specs import hookimpl
from .strategy import EvalOutcome, EvalTask, Evaluate, EvaluationStrategy

__all__ = [
    "UNSTABLE_INFO_KEY", "ArrayBodies", "ArraySimulator", "BodyBatch", "EvalOutcome", "EvalTask", "Evaluate",
    "EvaluationStrategy", "GymBodies", "Transition", "atomic_write_bytes", "config_signature", "cpu_count",
    "hookimpl", "progress_to", "read_parquet", "report_progress", "spawning",
]  # fmt: skip

_progress: list[Callable[[str], None]] = []


def report_progress(note: str) -> None:
    """Say how a long evaluation is going (e.g. a batch's training timesteps and speed).  The progress
    display shows it beside its trial while the bodies are evaluated in the trial's own process (the
    default ``--workers 1``); elsewhere it goes nowhere.  Cheap: call it every few seconds at most."""
    if _progress:
        _progress[-1](note)


@contextlib.contextmanager
def progress_to(callback: Callable[[str], None]) -> Iterator[None]:
    """Route :func:`report_progress` notes made inside the block to ``callback``."""
    _progress.append(callback)
    try:
        yield
    finally:
        _progress.pop()
