"""Evaluation episodes: how a trained policy is scored, the way Evolution Gym 2.0 scores it.

Evolution Gym 2.0 (``examples/ppo/eval.py``) plays ``n_evals`` fresh episodes and sums each
episode's rewards with the reward of the step that ends the episode set to zero: the
``evogym2`` convention here, the default.  A body that crosses Walker-v0's course so scores
about 9.55 rather than about 10.5 (the +1 goal bonus and the last step's progress are
dropped), and an episode ended by an unstable simulation loses its -3 with that last step.
``full`` sums every reward (Evolution Gym 1.0, and the return ``gdabench/Walker-v0`` reports).

Evolution Gym 2.0 samples actions while evaluating (its callback leaves ``eval_policy``'s
``deterministic_policy=False``), and so does gdabench by default, from a generator seeded per
evaluation, so an evaluation is one exactly repeatable episode on the deterministic simulator
and a saved policy replays to the reward it was scored with.  ``deterministic_eval=True``
plays the Gaussian's mean instead; with SB3's initialisation (mean near 0, below the actuator
range) that policy keeps every actuator at 0.6 until training has moved the mean into range.
"""

from __future__ import annotations

from typing import Any, Callable, Sequence

import numpy as np
import torch

from .envs import clip_action
from .networks import ActorCritic

#: a safety net for environments without a time limit (Evolution Gym's episodes last 500 steps)
MAX_EPISODE_STEPS = 10_000


def episode_score(rewards: Sequence[float], episode_end: str) -> float:
    """The score of one finished episode under the ``episode_end`` convention."""
    if episode_end == "evogym2":
        return float(np.sum(rewards[:-1]))
    return float(np.sum(rewards))


def evaluate_policy(
    nets: ActorCritic,
    make_env: Callable[[], Any],
    *,
    n_evals: int,
    episode_end: str,
    generator: torch.Generator | None = None,
    device: torch.device | str = "cpu",
) -> list[float]:
    """Scores of ``n_evals`` episodes, each in a fresh environment from ``make_env``.

    The mean action is played unless ``generator`` is given, then actions are sampled from it.
    """
    scores = []
    for _ in range(n_evals):
        env = make_env()
        try:
            obs, _ = env.reset()
            rewards: list[float] = []
            for _ in range(MAX_EPISODE_STEPS):
                observation = torch.as_tensor(np.asarray(obs, dtype=np.float32), device=device)
                action = nets.act(observation.unsqueeze(0), generator)[0]
                obs, reward, terminated, truncated, _ = env.step(clip_action(env, action.cpu().numpy()))
                rewards.append(float(reward))
                if terminated or truncated:
                    break
        finally:
            env.close()
        scores.append(episode_score(rewards, episode_end))
    return scores
