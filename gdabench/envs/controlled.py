"""Base class of physics tasks: a body acts in a Gymnasium environment under a controller.

Subclasses only say how to make the Gymnasium environment of a body (``make_env``).  Scoring
hands the controller a factory of fresh environments, so any controller written against
Gymnasium (open-loop, PPO, yours) drives any such task; report animations re-play the
controller on environments that record the frames of its best episode.
"""

from __future__ import annotations

import abc
import dataclasses
import functools
import math
from pathlib import Path
from typing import Any, ClassVar, Sequence

import gymnasium

from ..body import Body
from ..environment import Bodies, Controller, Environment, Evaluation
from ..errors import ConfigError


class ControlledEnvironment(Environment):
    """An environment whose bodies are scored by a controller acting in a Gymnasium env."""

    requires_controller = True
    #: report animations keep every ``frame_every``-th step
    frame_every: ClassVar[int] = 4

    @abc.abstractmethod
    def make_env(self, body: Body, **kwargs: Any) -> gymnasium.Env:
        """A fresh Gymnasium environment for ``body``; ``kwargs`` such as ``render_mode``."""

    def require(self, controller: Controller | None) -> Controller:
        if controller is None:
            raise ConfigError(f"{type(self).__name__} needs a controller: add --controller NAME")
        return controller

    def bodies(self, bodies: Sequence[Body]) -> Bodies:
        """``bodies`` as a controller sees them: Gymnasium environments of each.  Environments with an
        array simulator add it here (``make_batch``) and the padding every batch shares."""
        return Bodies([functools.partial(self.make_env, body) for body in bodies])

    def evaluate(
        self, body: Body, *, seed: int, controller: Controller | None = None, workdir: Path | None = None
    ) -> float | Evaluation:
        [result] = self.evaluate_bodies([body], seeds=[seed], controller=controller, workdirs=[workdir])
        if isinstance(result, BaseException):
            raise result
        return result

    def evaluate_bodies(
        self,
        bodies: Sequence[Body],
        *,
        seeds: Sequence[int],
        controller: Controller | None = None,
        workdirs: Sequence[Path | None],
        parents: Sequence[Sequence[Path]] | None = None,
    ) -> list[float | Evaluation | BaseException]:
        """The controller scores the bodies, together where it can (:meth:`Controller.evaluate_bodies`);
        ``parents`` (the parents' work directories per body) are handed on in :attr:`Bodies.parents`."""
        batch = self.bodies(bodies)
        if parents is not None:
            batch = dataclasses.replace(batch, parents=[tuple(p) for p in parents])
        return list(self.require(controller).evaluate_bodies(batch, seeds=seeds, workdirs=workdirs))

    def render_frames(
        self, body: Body, *, seed: int, controller: Controller | None = None, workdir: Path | None = None
    ) -> list[Any] | None:
        """Frames of the best episode the controller plays when it scores ``body`` again."""
        recorders: list[BestEpisodeFrames] = []

        def make_env() -> gymnasium.Env:
            recorder = BestEpisodeFrames(self.make_env(body, render_mode="rgb_array"), self.frame_every)
            recorders.append(recorder)
            return recorder

        self.require(controller).evaluate(make_env, seed=seed, workdir=workdir)
        finished = [r for r in recorders if r.best is not None]
        return max(finished, key=lambda r: r.best_return).best if finished else None


class BestEpisodeFrames(gymnasium.Wrapper):
    """Keeps every ``every``-th rendered frame of the highest-return finished episode."""

    def __init__(self, env: gymnasium.Env, every: int = 1):
        super().__init__(env)
        self.every = every
        self.best: list[Any] | None = None
        self.best_return = -math.inf
        self._frames: list[Any] = []
        self._return, self._t = 0.0, 0

    def reset(self, **kwargs: Any) -> Any:
        out = self.env.reset(**kwargs)
        self._frames, self._return, self._t = [self.env.render()], 0.0, 0
        return out

    def step(self, action: Any) -> Any:
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._return += float(reward)
        self._t += 1
        if self._t % self.every == 0:
            self._frames.append(self.env.render())
        if (terminated or truncated) and self._return > self.best_return:
            self.best, self.best_return = self._frames, self._return
        return obs, reward, terminated, truncated, info
