"""The environment and controller interfaces: how a body gets its reward.

An :class:`Environment` scores one body.  Cheap analytic environments (``simple``) compute
the reward directly; physics environments hand the body to a :class:`Controller`, which learns
or defines how it acts and reports the reward it reaches.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, ClassVar, Mapping, cast

from .body import DEFAULT_SHAPE, Body

if TYPE_CHECKING:
    from .execution.strategy import EvaluationStrategy


@dataclass(frozen=True)
class Evaluation:
    """A reward plus optional scalar extras that become result columns (e.g. steps trained)."""

    reward: float
    info: Mapping[str, Any] = field(default_factory=dict)


class Controller(abc.ABC):
    """Makes a body act in a Gymnasium environment and returns the reward it reaches."""

    @abc.abstractmethod
    def evaluate(self, make_env: Callable[[], Any], *, seed: int, workdir: Path | None = None) -> Evaluation:
        """Score the body wrapped by ``make_env()`` (a fresh Gymnasium env per call).

        ``workdir``, when given, is a directory (created on demand by whoever writes to it) where
        the controller may keep artifacts such as a trained policy.
        """

    def evaluation_strategy(self) -> EvaluationStrategy | None:
        """How a whole generation is evaluated (see :mod:`gdabench.execution.strategy`); None:
        every body once, fully (the default)."""
        return None


class Environment(abc.ABC):
    """Scores bodies of one shape."""

    #: bodies can only be scored with a controller (mirrors ``EnvironmentSpec.requires_controller``)
    requires_controller: ClassVar[bool] = False
    #: the same body, seed and controller always give the same reward (enables caching)
    deterministic: ClassVar[bool] = True
    #: which version of the dynamics or scoring this environment implements (e.g. the Gymnasium id
    #: ``gdabench/Walker-v1``); recorded in every result row and in ``run.json`` so that runs made
    #: before a change of dynamics stay interpretable.  None: the environment declares no version.
    version: str | None = None

    def __init__(self, *, shape: tuple[int, int] = DEFAULT_SHAPE):
        self.shape: tuple[int, int] = cast("tuple[int, int]", tuple(shape))

    def invalid_reason(self, body: Body) -> str | None:
        """Why this environment cannot score ``body``, or None.  Default: Evolution Gym's rule."""
        if body.shape != self.shape:
            return (
                f"shape {body.shape[0]}x{body.shape[1]} differs from the environment's {self.shape[0]}x{self.shape[1]}"
            )
        return body.invalid_reason()

    @property
    def optimum(self) -> float | None:
        """The best reward any valid body can reach, when known (used for evaluations-to-optimum)."""
        return None

    @abc.abstractmethod
    def evaluate(
        self, body: Body, *, seed: int, controller: Controller | None = None, workdir: Path | None = None
    ) -> float | Evaluation:
        """Score a valid body; ``seed`` drives any randomness of the evaluation."""

    def render_frames(
        self, body: Body, *, seed: int, controller: Controller | None = None, workdir: Path | None = None
    ) -> list[Any] | None:
        """RGB frames (H, W, 3 uint8 arrays) of the body acting, for animations in reports.

        ``workdir`` is the directory the body's evaluation used (e.g. where a trained policy was
        saved).  Environments with nothing to show return None (the default).
        """
        return None

