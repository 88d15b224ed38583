"""The gdabench environment ``walker``: a body's score is what a controller makes it walk.

The harness passes the controller chosen with ``--controller``; scoring and report animations
come from :class:`~gdabench.envs.controlled.ControlledEnvironment`, which hands the controller
fresh ``gdabench/Walker-v1`` Gymnasium environments, so a controller written against Gymnasium
(open-loop, PPO, ...) never needs to know about pymunk.
"""

from __future__ import annotations

from typing import Any

import gymnasium

from ...body import Body
from ..controlled import ControlledEnvironment
from . import ENV_ID


def make_walker(body: Body, **kwargs: Any) -> gymnasium.Env:
    """A fresh ``gdabench/Walker-v1`` for ``body`` (picklable through functools.partial)."""
    return gymnasium.make(ENV_ID, body=body.text, **kwargs)


class Walker(ControlledEnvironment):
    """Evolution Gym's Walker-v0 on the pymunk simulator; needs a controller."""

    #: the physics every row records (``env_version``)
    version = ENV_ID

    def make_env(self, body: Body, **kwargs: Any) -> gymnasium.Env:
        return make_walker(body, **kwargs)
