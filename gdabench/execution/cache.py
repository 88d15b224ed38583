"""An opt-in cache of rewards, shared across runs (``--cache DIR``).

Evaluations with PPO take minutes; the same body under the same evaluation seed and
configuration scores the same in a deterministic environment, so a repeated or extended
comparison need not pay again.  Only environments that declare ``deterministic = True`` are
cached, and only successful evaluations (errors and timeouts may be transient).

A key covers everything the reward depends on: the environment (its factory, parameters
including the body shape, and the name and version of the package that provides it), the
controller (the same), the body hash and the evaluation seed.  Change an environment's code
without bumping its package version and you must clear the cache yourself.

One small JSON file per entry, written atomically (temporary file, then rename), so any number
of runs can read and write the same cache at once, on one machine or a shared file system,
and a killed run never leaves a half-written entry.  A cached row still counts as an
evaluation; its ``cached`` column says where the reward came from.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any, Mapping

from ..errors import ConfigError
from ..results import atomic_write_bytes, utc_now
from ..specs import Factory
from ..statuses import OK
from ..strategy import EvalOutcome, EvalTask

FORMAT = "gdabench-cache/1"


def recipe_identity(recipe: Factory | None, package: tuple[str, str] | None = None) -> dict[str, Any] | None:
    """A JSON-able description of an environment or controller recipe for cache keys."""
    if recipe is None:
        return None
    factory = (
        recipe.factory
        if isinstance(recipe.factory, str)
        else f"{recipe.factory.__module__}:{recipe.factory.__qualname__}"
    )
    return {"factory": factory, "params": plain(dict(recipe.params)), "package": list(package) if package else None}


def plain(value: Any) -> Any:
    """JSON-compatible copy: tuples become lists, numpy scalars Python numbers; else TypeError."""
    if isinstance(value, Mapping):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if hasattr(value, "item") and callable(value.item):  # numpy scalar
        return plain(value.item())
    raise TypeError(f"{type(value).__name__} is not a plain value")


class OutcomeStore:
    """Successful outcomes on disk under ``root``, one small JSON file per key (``root/ab/ab….json``).

    Shared by the cache and the run's own record (:mod:`gdabench.running.outcomes`), which differ in
    what a key covers.  Entries are written atomically (a temporary file, then a rename), so any
    number of processes may read and write at once and a kill never leaves half an entry.
    """

    def __init__(self, root: str | Path):
        self.root = Path(root)

    def path(self, key: str) -> Path:
        return self.root / key[:2] / f"{key}.json"

    def load(self, key: str) -> dict[str, Any] | None:
        """The entry under ``key``, or None (missing or unreadable)."""
        try:
            entry = json.loads(self.path(key).read_text())
        except (OSError, ValueError):
            return None
        return entry if isinstance(entry, dict) else None

    def store(self, key: str, outcome: EvalOutcome, **fields: Any) -> bool:
        """Write ``outcome`` (and ``fields``) under ``key`` if it is worth keeping: successful, computed here
        (not taken from a cache), with an ``info`` that survives JSON; returns whether it was written."""
        if outcome.status != OK or outcome.cached:
            return False
        try:
            info = plain(dict(outcome.info))
        except TypeError:
            return False  # an extra column that does not survive JSON would come back different
        entry = {"reward": outcome.reward, "seconds": outcome.seconds, "info": info, **fields}
        atomic_write_bytes(self.path(key), (json.dumps(entry, sort_keys=True) + "\n").encode())
        return True


class EvaluationCache(OutcomeStore):
    """Rewards on disk under ``root``, keyed by configuration, body hash and evaluation seed."""

    def __init__(self, root: str | Path, context: Mapping[str, Any]):
        super().__init__(root)
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ConfigError(f"cannot use {self.root} as the evaluation cache: {exc.strerror or exc}") from None
        if not os.access(self.root, os.W_OK):
            raise ConfigError(f"cannot use {self.root} as the evaluation cache: not writable")
        self.context = {"format": FORMAT, **context}
        self._context_json = json.dumps(self.context, sort_keys=True)

    def key(self, task: EvalTask) -> str:
        text = f"{self._context_json}|{task.body.hash}|{task.seed}"
        return hashlib.sha256(text.encode()).hexdigest()

    def get(self, task: EvalTask) -> EvalOutcome | None:
        """The cached outcome of ``task`` (marked ``cached``), or None; unreadable entries are misses."""
        entry = self.load(self.key(task)) or {}
        try:
            return EvalOutcome(float(entry["reward"]), OK, "", 0.0, dict(entry["info"]), cached=True)
        except (ValueError, KeyError, TypeError):
            return None

    def put(self, task: EvalTask, outcome: EvalOutcome) -> bool:
        """Store a successful outcome; returns False when it is not cacheable."""
        fields = {"body": task.body.text, "seed": task.seed, "created": utc_now(), "context": self.context}
        return self.store(self.key(task), outcome, **fields)
