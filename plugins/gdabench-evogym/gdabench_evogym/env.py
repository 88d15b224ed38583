"""An Evolution Gym task as a gdabench environment.

The body is handed to Evolution Gym's own Gymnasium environment; the controller the harness
passes in (``open-loop``, ``ppo``, ...) drives it.  The environment also exposes
``actuator_voxels`` (one ``(row, col, code)`` row per actuator, in action order), the attribute
gdabench controllers use to know where the muscles are.
"""

from __future__ import annotations

import contextlib
import io
import os
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np

from gdabench.body import Body
from gdabench.environment import Controller
from gdabench.envs.controlled import ControlledEnvironment
from gdabench.errors import ConfigError

from .tasks import TASKS


def _evogym() -> Any:
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # it announces its version on import
            import evogym
            import evogym.envs
    except ImportError as exc:
        raise ConfigError(
            f"Evolution Gym is not installed ({exc}); build it with plugins/gdabench-evogym/install.sh"
        ) from None
    return evogym


class EvogymTask(ControlledEnvironment):
    """Evolution Gym's task ``task`` for bodies of shape ``shape``."""

    deterministic = True  # the simulator is deterministic given the actions

    def __init__(self, *, shape: tuple[int, int] = (5, 5), task: str = "Walker-v0"):
        super().__init__(shape=shape)
        if task not in TASKS:
            raise ConfigError(f"unknown Evolution Gym task {task!r}; tasks: {', '.join(TASKS)}")
        self.task = task
        _evogym()  # fail here, with one line, when Evolution Gym is missing

    def invalid_reason(self, body: Body) -> str | None:
        """Evolution Gym's own rules (``is_connected``, ``has_actuator``)."""
        if body.shape != self.shape:
            return super().invalid_reason(body)
        evogym, voxels = _evogym(), body.voxels.astype(float)
        if not evogym.has_actuator(voxels):
            return "no actuator"
        if not evogym.is_connected(voxels):
            return "voxels not connected"
        return None

    def render_frames(
        self, body: Body, *, seed: int, controller: Controller | None = None, workdir: Path | None = None
    ) -> list[Any] | None:
        """Frames for report animations, only with an X display (e.g. under ``xvfb-run``).

        Evolution Gym renders through GLFW, which crashes the whole process (SIGSEGV) when there
        is no display, so without one there is no animation (the report says so) and the run's
        results and report survive.
        """
        if not os.environ.get("DISPLAY"):
            return None
        return super().render_frames(body, seed=seed, controller=controller, workdir=workdir)

    def make_env(self, body: Body, **kwargs: Any) -> gymnasium.Env:
        env = gymnasium.make(self.task, body=body.voxels.astype(float), **kwargs)
        raw: Any = env.unwrapped  # an evogym EvoGymBase, untyped
        index = raw.get_actuator_indices("robot")
        width = body.shape[1]
        raw.actuator_voxels = np.array(
            [(i // width, i % width, body.voxels.flat[i]) for i in index], dtype=np.int64
        )
        return env
