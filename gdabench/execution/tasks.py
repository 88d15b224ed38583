"""What an evaluation is given and what it gives back: the vocabulary executors, caches and strategies share.

Kept apart from :mod:`.evaluation` (which calls environments) so that the interfaces that mention
these types (:mod:`gdabench.environment` through :mod:`.strategy`) do not import the machinery.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from ..body import Body
from ..specs import Factory


@dataclass(frozen=True)
class EvalTask:
    body: Body
    seed: int
    env: Factory
    controller: Factory | None = None
    workdir: Path | None = None
    #: work directories of the bodies this one came from, nearest first (what the designer said, for a
    #: controller that inherits a parent's policy, ``ppo[init=parent]``); empty otherwise
    parents: tuple[Path, ...] = ()


@dataclass(frozen=True)
class EvalOutcome:
    reward: float
    status: str
    message: str = ""
    seconds: float = 0.0
    info: Mapping[str, Any] = field(default_factory=dict)
    #: the reward was taken from the evaluation cache instead of being computed
    cached: bool = False


#: what evaluates a generation's tasks (an executor's ``map``, possibly behind a cache): outcome ``i`` is task ``i``'s
Evaluate = Callable[[Sequence[EvalTask]], list[EvalOutcome]]
