"""The gdabench environment ``walker``: a body's score is what a controller makes it walk.

The harness passes the controller chosen with ``--controller``; the environment hands it a
factory of fresh ``gdabench/Walker-v0`` Gymnasium environments for the body, so a controller
written against Gymnasium (open-loop, PPO, ...) never needs to know about pymunk.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any, Callable

import gymnasium
import numpy as np

from ...body import Body
from ...environment import Controller, Environment, Evaluation
from ...errors import ConfigError
from . import ENV_ID

#: report animations show every ``FRAME_EVERY``-th step (25 frames per simulated second)
FRAME_EVERY = 4


def make_walker(body: Body, **kwargs: Any) -> gymnasium.Env:
    """A fresh ``gdabench/Walker-v0`` for ``body`` (picklable through functools.partial)."""
    return gymnasium.make(ENV_ID, body=body.text, **kwargs)


class Walker(Environment):
    """Evolution Gym's Walker-v0 on the pymunk simulator; needs a controller."""

    requires_controller = True

    def _controller(self, controller: Controller | None) -> Controller:
        if controller is None:
            raise ConfigError("environment 'walker' needs a controller: add --controller NAME (e.g. open-loop)")
        return controller

    def evaluate(self, body: Body, *, seed: int, controller: Controller | None = None, workdir: Path | None = None) -> Evaluation:
        return self._controller(controller).evaluate(functools.partial(make_walker, body), seed=seed, workdir=workdir)

    def render_frames(
        self, body: Body, *, seed: int, controller: Controller | None = None, workdir: Path | None = None
    ) -> list[np.ndarray] | None:
        """Frames of the best episode the controller plays when it evaluates ``body`` again.

        Positions are recorded while the controller runs and drawn afterwards, so only the
        episode that is shown costs drawing time.  Returns None when the controller finished
        no episode in this process.
        """
        recorders: list[_BestEpisodeRecorder] = []

        def make_env() -> gymnasium.Env:
            recorder = _BestEpisodeRecorder(make_walker(body, render_mode="rgb_array"))
            recorders.append(recorder)
            return recorder

        self._controller(controller).evaluate(make_env, seed=seed, workdir=workdir)
        finished = [r for r in recorders if r.best is not None]
        if not finished:
            return None
        best = max(finished, key=lambda r: r.best_return)
        renderer = best.unwrapped.renderer
        return [renderer.draw(positions) for positions in best.best[::FRAME_EVERY]]


class _BestEpisodeRecorder(gymnasium.Wrapper):
    """Keeps the point positions of the highest-return finished episode played through it."""

    def __init__(self, env: gymnasium.Env):
        super().__init__(env)
        self.best: list[np.ndarray] | None = None
        self.best_return = -np.inf
        self._episode: list[np.ndarray] = []
        self._return = 0.0

    def _record(self) -> None:
        self._episode.append(self.env.unwrapped.sim.positions.copy())

    def reset(self, **kwargs: Any) -> Any:
        out = self.env.reset(**kwargs)
        self._episode, self._return = [], 0.0
        self._record()
        return out

    def step(self, action: Any) -> Any:
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._return += float(reward)
        if "unstable" not in info:  # an unstable state is not worth drawing
            self._record()
        if (terminated or truncated) and self._return > self.best_return:
            self.best, self.best_return = self._episode, self._return
        return obs, reward, terminated, truncated, info
