"""``ppo``: Evolution Gym 2.0's inner loop, PPO learning each body's gait, built on TorchRL.

Modules: ``config`` (settings and their checks), ``networks`` (SB3's default actor-critic as
TorchRL modules), ``envs`` (the body's Gymnasium env as a TorchRL env), ``update`` (one
ClipPPOLoss minibatch step, compiled or eager), ``train`` (collector, GAE, minibatches,
periodic evaluation), ``evaluation`` (how episodes are scored), ``policy_file`` (saved policies),
``controller`` (the gdabench controller and :func:`replay`).
"""

from .config import FAITHFUL_TIMESTEPS, LAPTOP_TIMESTEPS, PPOConfig
from .controller import PPO, replay

__all__ = ["FAITHFUL_TIMESTEPS", "LAPTOP_TIMESTEPS", "PPO", "PPOConfig", "replay"]
