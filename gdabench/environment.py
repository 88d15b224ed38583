"""The environment and controller interfaces: how a body gets its reward.

An :class:`Environment` scores one body.  Cheap analytic environments (``simple``) compute
the reward directly; physics environments hand the body to a :class:`Controller`, which learns
or defines how it acts and reports the reward it reaches.
"""

from __future__ import annotations

import abc
import functools
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, ClassVar, Mapping, Sequence, cast

from .body import DEFAULT_SHAPE, Body

if TYPE_CHECKING:
    from .strategy import EvaluationStrategy


@dataclass(frozen=True)
class Evaluation:
    """A reward plus optional scalar extras that become result columns (e.g. steps trained)."""

    reward: float
    info: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Bodies:
    """A batch of bodies as a controller sees them (:meth:`Controller.evaluate_bodies`)."""

    #: per body, a factory of fresh Gymnasium environments of it
    make_envs: Sequence[Callable[[], Any]]
    #: ``make_batch(indices, n)``: ``n`` environments of each of those bodies as one
    #: :class:`~gdabench.batched.BodyBatch`, stepped in one call; None where the environment has no
    #: array simulator (a controller then batches ``make_envs``' environments itself)
    make_batch: Callable[[Sequence[int], int], Any] | None = None
    #: (observations, actions) that every batch of this environment is padded to, so that what a
    #: controller computes for a body does not depend on which bodies share its batch; None: none
    pad: tuple[int, int] | None = None
    #: per body, the work directories of the bodies it came from, nearest first (the designer's
    #: :meth:`~gdabench.Designer.proposal_parents`, where they were evaluated in the same trial); None: not known.
    #: Given only to a controller that :attr:`~Controller.inherits`.
    parents: Sequence[Sequence[Path]] | None = None

    def __len__(self) -> int:
        return len(self.make_envs)


class Controller(abc.ABC):
    """Makes a body act in a Gymnasium environment and returns the reward it reaches."""

    #: bodies the harness hands :meth:`evaluate_bodies` in one call, at most, unless the run says otherwise
    #: (``--batch``); 1 unless the controller gains from having several together
    bodies_at_once: ClassVar[int] = 1
    #: a child's evaluation starts from what its parents' left in their work directories (``Bodies.parents``),
    #: as ``ppo[init=parent]`` does; the harness then hands the parents on and keeps no cross-run cache
    inherits: bool = False
    #: a body's reward depends on the other new bodies of its generation and on the trial's earlier generations
    #: (one policy learnt by a whole generation and carried on, ``modular-ppo``): the harness hands a generation
    #: in one call, refuses execution options that would split it, and lets neither ``--cache`` nor another
    #: trial's outcome stand in for an evaluation
    learns_across_bodies: bool = False

    @abc.abstractmethod
    def evaluate(self, make_env: Callable[[], Any], *, seed: int, workdir: Path | None = None) -> Evaluation:
        """Score the body wrapped by ``make_env()`` (a fresh Gymnasium env per call).

        ``workdir``, when given, is a directory (created on demand by whoever writes to it) where
        the controller may keep artifacts such as a trained policy.
        """

    def evaluate_bodies(
        self, bodies: Bodies, *, seeds: Sequence[int], workdirs: Sequence[Path | None]
    ) -> list[Evaluation | BaseException]:
        """Score a batch of bodies (part of a generation); entry ``i`` is body ``i``'s evaluation, or the
        exception that failed it, never the batch's.  Override to learn the bodies together; the default
        scores them one at a time with :meth:`evaluate`."""
        return [
            _caught(functools.partial(self.evaluate, make_env, seed=seed, workdir=workdir))
            for make_env, seed, workdir in zip(bodies.make_envs, seeds, workdirs)
        ]

    def evaluate_alone(self, make_env: Callable[[], Any], *, seed: int, workdir: Path | None = None) -> Evaluation:
        """:meth:`evaluate` as a batch of one, for a controller whose :meth:`evaluate_bodies` is the real one
        (it learns bodies together): ``evaluate = Controller.evaluate_alone`` in its class."""
        [result] = self.evaluate_bodies(Bodies([make_env]), seeds=[seed], workdirs=[workdir])
        if isinstance(result, BaseException):
            raise result
        return result

    def evaluation_strategy(self) -> EvaluationStrategy | None:
        """How a whole generation is evaluated (see :mod:`gdabench.strategy`); None:
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
    #: bodies the harness hands :meth:`evaluate_bodies` in one call, at most, unless the run says otherwise
    #: (``--batch``); with a controller, the controller's figure is used instead
    bodies_at_once: ClassVar[int] = 1

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

    def evaluate_bodies(
        self,
        bodies: Sequence[Body],
        *,
        seeds: Sequence[int],
        controller: Controller | None = None,
        workdirs: Sequence[Path | None],
    ) -> list[float | Evaluation | BaseException]:
        """Score a batch of valid bodies (a generation's, or an executor's share of it): entry ``i`` is
        body ``i``'s result, or the exception that failed it.  The harness calls this; the default scores
        the bodies one at a time with :meth:`evaluate`.  Override it to simulate them together."""
        return [
            _caught(functools.partial(self.evaluate, body, seed=seed, controller=controller, workdir=workdir))
            for body, seed, workdir in zip(bodies, seeds, workdirs)
        ]

    def render_frames(
        self, body: Body, *, seed: int, controller: Controller | None = None, workdir: Path | None = None
    ) -> list[Any] | None:
        """RGB frames (H, W, 3 uint8 arrays) of the body acting, for animations in reports.

        ``workdir`` is the directory the body's evaluation used (e.g. where a trained policy was
        saved).  Environments with nothing to show return None (the default).
        """
        return None


def _caught(call: Callable[[], Any]) -> Any:
    """``call()``, or the exception it raised (``sys.exit`` included): one body's failure is its own."""
    try:
        return call()
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - a failing evaluation is data, not a crash
        return exc
