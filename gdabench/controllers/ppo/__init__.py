"""``ppo``: Evolution Gym 2.0's inner loop, PPO learning each body's gait, built on TorchRL.

Modules: ``config`` (settings and their checks), ``networks`` (SB3's default actor-critic, one
per body, stacked for a batch), ``update`` (one PPO minibatch step for every body of a batch),
``train`` (a batch of bodies trained in lockstep: rollouts, GAE, minibatches, periodic
evaluation), ``evaluation`` (how episodes are scored), ``policy_file`` (saved policies),
``controller`` (the gdabench controller and :func:`replay`).
"""

from .config import FAITHFUL_TIMESTEPS, LAPTOP_TIMESTEPS, PPOConfig
from .controller import PPO, replay

__all__ = ["FAITHFUL_TIMESTEPS", "LAPTOP_TIMESTEPS", "PPO", "PPOConfig", "replay"]
