"""``ppo``: Evolution Gym 2.0's inner loop, PPO learning each body's gait (TorchRL's GAE, the loss written out).

Modules: ``config`` (settings and their checks), ``networks`` (SB3's default actor-critic, one
per body, stacked for a batch), ``update`` (one PPO minibatch step for every body of a batch),
``train`` (a batch of bodies trained in lockstep: rollouts, GAE, minibatches, periodic
evaluation), ``evaluation`` (how episodes are scored), ``policy_file`` (saved policies),
``controller`` (the gdabench controller and :func:`replay`).
"""

from __future__ import annotations

from typing import Any

from .config import DEFAULT_TIMESTEPS, FAITHFUL_TIMESTEPS, PPOConfig

__all__ = ["DEFAULT_TIMESTEPS", "FAITHFUL_TIMESTEPS", "PPO", "PPOConfig", "replay"]


def __getattr__(name: str) -> Any:
    """The controller (torch, TorchRL) is imported on first use: checking settings needs only ``config``."""
    if name in ("PPO", "replay"):
        from . import controller

        return getattr(controller, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
