"""Execution options: where a run's trials and their evaluations run.

* ``jobs``: trials (designer x environment x seed) at once.  Locally each runs in a worker
  process of its own (or in the calling process when only one runs at a time); on Ray each
  is an actor of the cluster.
* ``workers``: evaluation processes per trial.  One evaluates in the trial's own process;
  more (or a ``timeout``) give the trial a supervised pool of worker processes (Ray actors on
  Ray), which pays where an evaluation is expensive (physics with a learning controller).
* ``batch``: bodies handed to an environment in one call (at most; a generation is split evenly
  over the workers).  Default: what the controller (or environment) asks for
  (``bodies_at_once``): 1 for most, a generation for ``ppo``, which learns its bodies in lockstep.
  Smaller batches bound memory and lose less to a kill; larger ones learn faster per core.

None of this changes a run's results: a trial depends only on its seed, and an evaluation only
on its body, its seed and the recipes, so the table is the same on any executor with any
number of jobs and workers.  Execution options may change when a run is resumed.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Sequence

from ..cpu import cpu_count
from ..errors import ConfigError
from ..specs import Factory
from .executor import Executor, SerialExecutor
from .pool import ProcessExecutor

EXECUTORS = ("local", "ray")


@dataclass(frozen=True)
class Execution:
    """How a run is executed; see the module docstring."""

    executor: str = "local"
    jobs: int | None = None
    workers: int = 1
    timeout: float | None = None
    ray_address: str | None = None
    cache: str | None = None
    batch: int | None = None

    def __post_init__(self) -> None:
        if self.executor not in EXECUTORS:
            raise ConfigError(f"unknown executor {self.executor!r}; known executors: {', '.join(EXECUTORS)}")
        for name in ("jobs", "workers", "batch"):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 1):
                raise ConfigError(f"{name} must be a positive integer, got {value!r}")
        if self.timeout is not None and not (isinstance(self.timeout, (int, float)) and self.timeout > 0):
            raise ConfigError(f"timeout must be a positive number of seconds, got {self.timeout!r}")
        if self.ray_address and self.executor != "ray":
            raise ConfigError("--ray-address needs --executor ray")
        if self.cache is not None:
            object.__setattr__(self, "cache", str(self.cache))

    def jobs_for(self, trials: int, cpus: int | None = None) -> int:
        """Trials to run at once: ``jobs``, or else as many as the CPUs allow ``workers`` each."""
        jobs = self.jobs or max(1, (cpus or cpu_count()) // self.workers)
        return max(1, min(jobs, trials))

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def make_executor(execution: Execution, warm: Sequence[Factory] = ()) -> Executor:
    """The evaluation executor of a trial's process.

    Evaluating here reuses this process's built environment and controller
    (:func:`.evaluation.instance`); ``warm`` are the recipes worker processes build before their first
    body, so that start-up is not charged to an evaluation's time.
    """
    if execution.workers == 1 and execution.timeout is None:
        return SerialExecutor()
    if execution.executor == "ray":
        from .ray import RayExecutor

        return RayExecutor(execution.workers, address=execution.ray_address, timeout=execution.timeout, warm=warm)
    return ProcessExecutor(execution.workers, timeout=execution.timeout, warm=warm)
