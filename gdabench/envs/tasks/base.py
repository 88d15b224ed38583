"""A task of Evolution Gym 2.0, stated over arrays: its world, observation, reward, termination and reset.

A task never sees a simulator.  It is told where things are (:class:`~gdabench.envs.tasks.sense.Frame`,
every environment of a batch at once) and answers with arrays, so the same definition serves one
Gymnasium environment, a vector of them and a co-design batch of different bodies.  A task object holds
the per-environment state that some tasks keep between steps (goals, counters), one row per environment.
"""

from __future__ import annotations

import json
from functools import cache
from importlib.resources import files
from typing import Any, ClassVar, Mapping, Sequence, Union

import numba
import numpy as np

from ...body import Body, as_body
from ...errors import GdabenchError, MalformedBodyError
from .catalog import CATALOG
from .sense import Frame

#: Evolution Gym's actuator range: every action is clipped into it
ACTION_LOW, ACTION_HIGH = 0.6, 1.6
#: what Evolution Gym's tasks add when the simulation became unstable (the step is undone)
UNSTABLE_PENALTY = -3.0

#: what a Gymnasium environment's ``body`` is when none was given (None is a malformed body, said as such)
NO_BODY: Any = type("NoBody", (), {"__repr__": lambda self: "no body"})()
#: an observation part: an ``(N, w)`` array, or ``(array, widths)`` where environment ``i`` uses ``widths[i]`` columns
Part = Union[np.ndarray, tuple[np.ndarray, np.ndarray]]


def penalised(reward: np.ndarray, unstable: np.ndarray) -> np.ndarray:
    """The reward with :data:`UNSTABLE_PENALTY` added where the step was unstable."""
    return np.where(unstable, reward + UNSTABLE_PENALTY, reward)


@cache
def worlds() -> dict[str, Any]:
    """Evolution Gym's task worlds (``envs/sim_files``), as ``benchmarks/ops/evogym_worlds.py`` wrote them."""
    return json.loads(files(__package__).joinpath("worlds.json").read_text())["worlds"]


def world_objects(name: str) -> dict[str, tuple[np.ndarray, tuple[int, int]]]:
    """The objects of world ``name``: cells (rows top to bottom) and the voxel of their bottom-left corner."""
    return {obj: (np.array([[int(c) for c in row] for row in spec["rows"]]), tuple(spec["at"]))
            for obj, spec in worlds()[name]["objects"].items()}


class Task:
    """One Evolution Gym task (subclasses fill in the class attributes and the three methods).

    ``n`` environments; ``robot_points[i]`` is the robot's point count in environment ``i`` (bodies differ,
    and so do observation sizes).
    """

    #: Evolution Gym's id; its grade (easy, medium, hard), step limit and summary come from the catalog
    id: ClassVar[str]
    difficulty: ClassVar[str]
    max_episode_steps: ClassVar[int]
    summary: ClassVar[str]
    #: the sim file, and where the robot goes (its bottom-left voxel)
    world: ClassVar[str]
    robot_at: ClassVar[tuple[int, int]]
    #: objects simulated in every environment although made of fixed voxels (placed per environment)
    moving: ClassVar[tuple[str, ...]] = ()
    #: what a user may impose on an episode's random set-up through ``reset(options=...)`` (none: fixed set-up)
    reset_options: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "id" in cls.__dict__:
            entry = CATALOG[cls.id]
            cls.difficulty, cls.max_episode_steps, cls.summary = entry.difficulty, entry.max_episode_steps, \
                entry.summary

    def __init__(self, robot_points: np.ndarray):
        self.robot_points = np.asarray(robot_points, dtype=np.int64)
        self.n = len(self.robot_points)

    @classmethod
    def objects(cls) -> dict[str, tuple[np.ndarray, tuple[int, int]]]:
        """The world's objects without the robot (a task adding objects to its sim file extends this)."""
        return world_objects(cls.world)

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        """The observation's length for a robot of ``robot_points`` points."""
        raise NotImplementedError

    def placements(self, rng: Sequence[np.random.Generator], mask: np.ndarray,
                   options: Mapping[str, Any] | None = None) -> dict[str, np.ndarray] | None:
        """Where the environments in ``mask`` place the objects named in ``moving`` this episode: name ->
        ``(N, 2)`` voxel positions (rows outside ``mask`` ignored); None: where the world puts them.
        ``options`` (keys of ``reset_options``) impose a set-up instead of drawing it from ``rng``."""
        return None

    def reset(self, frame: Frame, mask: np.ndarray, rng: Sequence[np.random.Generator],
              options: Mapping[str, Any] | None = None) -> None:
        """Start the episodes of the environments in ``mask`` (their task state; ``frame`` is their first;
        ``options`` as for :meth:`placements`)."""

    def observe(self, frame: Frame) -> list[Part]:
        """The observation's parts, in Evolution Gym's order (joined by :func:`observation`)."""
        raise NotImplementedError

    def reward(self, before: Frame, after: Frame, unstable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The step's reward and whether the episode ended (Evolution Gym's ``done``), for every environment.

        An unstable step is undone (``after`` equals ``before`` there); the task adds the penalty as
        Evolution Gym's does.  Rows of environments whose episode had ended are computed too and ignored
        until their reset (which must restart any task state)."""
        raise NotImplementedError



def finish(reward: np.ndarray, unstable: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How Evolution Gym's tasks end a step: the penalty where the simulation became unstable, then 1 more
    and the episode over where the goal is met (both can happen)."""
    reward = penalised(reward, unstable)
    return np.where(goal, reward + 1.0, reward), unstable | goal


def checked_body(body: Any, task: type[Task]) -> Body:
    """The body as a :class:`Body`, or a one-line ``ValueError`` saying why ``task`` cannot take it: it is
    malformed, invalid, or it would overlap the task's objects where the task places it."""
    try:
        parsed = as_body(body)
    except GdabenchError:
        raise
    except Exception as exc:  # noqa: BLE001 - anything as_body chokes on is a malformed body
        raise MalformedBodyError(f"malformed body for {task.id}: {exc}") from None
    reason = parsed.invalid_reason()
    if reason is not None:
        raise MalformedBodyError(f"invalid body for {task.id} ({parsed.text}): {reason}")
    x0, y0 = task.robot_at
    h, _ = parsed.shape
    taken = {(x0 + c, y0 + h - 1 - r) for r, c in zip(*np.nonzero(parsed.voxels))}
    for name, (grid, (ox, oy)) in task.objects().items():
        rows = grid.shape[0]
        if any((ox + c, oy + rows - 1 - r) in taken for r, c in zip(*np.nonzero(grid))):
            raise MalformedBodyError(
                f"body {parsed.shape[0]}x{parsed.shape[1]} overlaps {task.id}'s object {name!r} where the task "
                f"places the robot (voxel {task.robot_at})")
    return parsed


@numba.njit(cache=True, boundscheck=False)
def _place(part, used, starts, out):
    """Row ``i``'s first ``used[i]`` values of ``part`` at column ``starts[i]`` of ``out``; moves ``starts`` on."""
    for i in range(part.shape[0]):
        for c in range(used[i]):
            out[i, starts[i] + c] = part[i, c]
        starts[i] += used[i]


def observation(parts: Sequence[Part], width: int) -> np.ndarray:
    """Each environment's parts one after the other, the row padded with zeros to ``width``.

    While every row's parts so far have the same width, a part is copied as one block (a part of varying
    width is zero beyond each row's own, as :func:`~gdabench.envs.tasks.sense.relative` makes it); after
    one of varying width, row by row."""
    n = len(parts[0][0] if isinstance(parts[0], tuple) else parts[0])
    out = np.zeros((n, width))
    at: int | np.ndarray = 0  # where the next part starts: one column for every row, or each row's own
    for part in parts:
        array, used = part if isinstance(part, tuple) else (part, None)
        array = np.asarray(array, dtype=np.float64).reshape(n, -1)
        if isinstance(at, int):
            out[:, at:at + array.shape[1]] = array
            at = at + array.shape[1] if used is None else at + used.astype(np.int64)
        else:
            _place(array, np.full(n, array.shape[1], dtype=np.int64) if used is None else used, at, out)
    return out
