"""The shared policy's pooled PPO (``modular-ppo``'s training): one network drives bodies of different layouts,
and a training is repeatable."""

from __future__ import annotations

import math

from gdabench.body import as_body
from gdabench.controllers.modular.observation import modular_view
from gdabench.controllers.modular.policy import fresh_policy
from gdabench.controllers.modular.train import train_pooled
from gdabench.controllers.ppo import PPOConfig
from gdabench.envs.voxel.env import VoxelTask

BODIES = ["00000/44444/44444/40004/40004", "33333/30103/32223/04140/44044", "03300/03300/44444/40104/40004"]


def pooled(seed: int):
    env = VoxelTask()
    bodies = env.bodies([as_body(b) for b in BODIES])
    views = []
    for make_env in bodies.make_envs:
        gym_env = make_env()
        views.append(modular_view(gym_env))
        gym_env.close()
    policy = fresh_policy(len(views[0].other), (64, 64), seed)
    config = PPOConfig(timesteps=256, eval_interval=128)
    return train_pooled(config, policy, lambda n: bodies.make_batch(range(3), n), views, [1, 2, 3], seed)


def test_one_policy_learns_three_bodies_together_and_a_training_repeats_exactly():
    first, again, other = pooled(7), pooled(7), pooled(8)
    assert [[e.scores for e in h] for h in first.evaluations] == [[e.scores for e in h] for h in again.evaluations]
    assert [[e.scores for e in h] for h in first.evaluations] != [[e.scores for e in h] for h in other.evaluations]
    assert first.timesteps == 256 and len(first.states) == 3  # evaluations at 128, 256 and the end
    assert all(math.isfinite(first.reward(b)) for b in range(3))
    assert len({first.reward(b) for b in range(3)}) == 3  # one network, three bodies, three gaits
