"""The run's own record of finished evaluations, kept as each body finishes (``<run>/outcomes/``).

Two things depend on it.  A kill in the middle of a generation loses only the bodies still being
evaluated: a resume asks the restored designer for the same generation, and the bodies already scored
are taken from here instead of being trained again.  And trials of one run that propose the same body
under the same seed (``ga`` and ``gda`` share generation 0 by design) score it once: a body's reward
depends only on the body, the evaluation seed and the environment and controller recipes, so the second
trial replays the first one's outcome, its files (a trained policy) copied to its own folder.  That holds
when the first trial recorded the body before the second asks for it; two such trials running at the same
time may both train it (nothing waits on another trial's body), which costs time but not the table.

Only deterministic environments are recorded, and only successful evaluations (an error may be
transient).  A replayed outcome is the computed one, with its time; it is not marked ``cached`` (that
column is about ``--cache``).  The folder is removed when the run completes.
"""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

from .. import faults
from ..execution.cache import OutcomeStore
from ..statuses import OK
from ..strategy import EvalOutcome, EvalTask

OUTCOMES = "outcomes"


class RunOutcomes(OutcomeStore):
    """Successful outcomes of the run in ``run_path``, by task (body, evaluation seed, recipes)."""

    def __init__(self, run_path: Path):
        self.run_path = Path(run_path)
        super().__init__(self.run_path / OUTCOMES)

    def _key(self, task: EvalTask) -> str:
        recipes = (task.env.key(), task.controller.key() if task.controller is not None else None)
        text = f"{recipes!r}|{task.body.hash}|{task.seed}"
        if task.parents:  # an inheriting controller's reward depends on the parents' files too
            text += "|" + ",".join(
                str(p.relative_to(self.run_path)) if p.is_relative_to(self.run_path) else str(p) for p in task.parents
            )
        return hashlib.sha256(text.encode()).hexdigest()

    def get(self, task: EvalTask) -> EvalOutcome | None:
        """The outcome recorded for ``task`` (its files copied to the task's workdir), or None."""
        entry = self.load(self._key(task)) or {}
        try:
            outcome = EvalOutcome(float(entry["reward"]), OK, "", float(entry["seconds"]), dict(entry["info"]))
            source = self.run_path / entry["workdir"] if entry["workdir"] else None
        except (ValueError, KeyError, TypeError):
            return None
        if source is not None and task.workdir is not None and source != task.workdir and source.is_dir():
            shutil.copytree(source, task.workdir, dirs_exist_ok=True)
        return outcome

    def put(self, task: EvalTask, outcome: EvalOutcome) -> None:
        """Record a successful outcome computed in this run (not one taken from ``--cache``)."""
        workdir = None
        if task.workdir is not None and task.workdir.is_relative_to(self.run_path):
            workdir = str(task.workdir.relative_to(self.run_path))
        if self.store(self._key(task), outcome, body=task.body.text, seed=task.seed, workdir=workdir):
            faults.point("outcome-stored")

    def discard(self) -> None:
        """Remove the record (the run is complete: nothing is left to resume or share)."""
        shutil.rmtree(self.root, ignore_errors=True)
