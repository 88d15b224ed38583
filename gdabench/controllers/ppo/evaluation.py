"""Evaluation episodes: how trained policies are scored, the way Evolution Gym 2.0 scores them.

Evolution Gym 2.0 (``examples/ppo/eval.py``) plays ``n_evals`` fresh episodes and sums each
episode's rewards with the reward of the step that ends the episode set to zero: the
``evogym2`` convention here, the default.  A body that crosses Walker-v0's course so scores
about 9.55 rather than about 10.5 (the +1 goal bonus and the last step's progress are
dropped), and an episode ended by an unstable simulation loses its -3 with that last step.
``full`` sums every reward (Evolution Gym 1.0, and the return ``gdabench/Walker-v0`` reports).

Evolution Gym 2.0 samples actions while evaluating (its callback leaves ``eval_policy``'s
``deterministic_policy=False``), and so does gdabench by default, from a generator seeded per
body and evaluation, so an evaluation is exactly repeatable on the deterministic simulator and a
saved policy replays to the reward it was scored with.  ``deterministic_eval=True`` plays the
Gaussian's mean instead; with SB3's initialisation (mean near 0, below the actuator range) that
policy keeps every actuator at the lower bound until training has moved the mean into range.

Every body's ``n_evals`` episodes are played side by side, all bodies of a batch in one batch of
environments; a body's actions depend only on its own observations and generator.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
import torch

from ...sdk import BodyBatch
from .networks import Stacked


def episode_score(rewards: Sequence[float], episode_end: str) -> float:
    """The score of one finished episode under the ``episode_end`` convention."""
    if episode_end == "evogym2":
        return float(np.sum(rewards[:-1]))
    return float(np.sum(rewards))


def as_input(obs: np.ndarray, nets: Stacked, envs_per_body: int, learn: bool = False) -> torch.Tensor:
    """A batch's observations ``(N, width)`` as the networks' input ``(B, E, O)``, normalised where the
    networks normalise (``learn``: training's observations update the running statistics)."""
    x = torch.zeros(nets.n_bodies, envs_per_body, nets.n_obs, device=nets.log_std.device)
    x[:, :, : obs.shape[1]] = torch.from_numpy(obs.astype(np.float32)).view(nets.n_bodies, envs_per_body, -1)
    return nets.observe(x, learn)


def evaluate_policies(
    nets: Stacked,
    make_batch: Callable[[int], BodyBatch],
    *,
    n_evals: int,
    episode_end: str,
    generators: Sequence[torch.Generator | None],
) -> list[list[float]]:
    """Per body, the scores of its ``n_evals`` episodes in fresh environments from ``make_batch(n_evals)``.

    Body ``b`` samples its actions from ``generators[b]``, or plays its mean action where that is None.
    """
    batch = make_batch(n_evals)
    try:
        obs = batch.reset()
        n = len(obs)
        rewards: list[list[float]] = [[] for _ in range(n)]
        finished = np.zeros(n, dtype=bool)
        while not finished.all():
            actions, _ = nets.act(as_input(obs, nets, n_evals), generators)
            step = batch.step(actions.reshape(n, -1).cpu().numpy().astype(np.float64))
            for i in np.flatnonzero(~finished):
                rewards[i].append(float(step.reward[i]))
            finished |= step.done
            obs = step.obs
    finally:
        batch.close()
    scores = [episode_score(r, episode_end) for r in rewards]
    return [scores[b * n_evals : (b + 1) * n_evals] for b in range(nets.n_bodies)]
