"""Run listeners the tests use to stop a run at a chosen generation (as a crash would)."""

from __future__ import annotations

from gdabench.running.events import RunListener


class Killed(Exception):
    """Raised by :class:`KillAt` where a test wants the run to die."""


class KillAt(RunListener):
    """Raise :class:`Killed` (or ``error``) once the trial (designer, seed) has written ``generation``."""

    def __init__(self, designer: str, seed: int, generation: int, error: BaseException | None = None):
        self.where, self.error = (designer, seed, generation), error

    def generation(self, spec, result) -> None:
        if (spec.designer.label, spec.seed, result.generation) == self.where:
            raise self.error or Killed(f"killed after {self.where}")
