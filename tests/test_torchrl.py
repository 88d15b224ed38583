"""What a TorchRL user expects: ``torchrl.envs.GymEnv("gdabench/Walker-v2", body=...)`` is the walker, and
the documented TorchRL training loop on a batch of bodies runs (docs/examples/torchrl_batch.py)."""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import gymnasium
import numpy as np
import pytest
import torch

import gdabench  # noqa: F401 - registers gdabench/Walker-v2

torchrl_envs = pytest.importorskip("torchrl.envs")
ROOT = Path(__file__).resolve().parents[1]
BODY = "44444/44444/44444/40004/40004"


def test_torchrl_gymenv_steps_the_walker_as_gymnasium_does():
    env = torchrl_envs.GymEnv("gdabench/Walker-v2", body=BODY)
    plain = gymnasium.make("gdabench/Walker-v2", body=BODY)
    assert env.observation_spec["observation"].shape == plain.observation_space.shape
    assert env.action_spec.shape == plain.action_space.shape
    env.set_seed(3)
    td = env.reset()
    obs, _ = plain.reset(seed=3)
    np.testing.assert_array_equal(td["observation"].numpy(), obs)
    rng = np.random.default_rng(0)
    for _ in range(20):
        action = rng.uniform(0.6, 1.6, plain.action_space.shape)
        td["action"] = torch.as_tensor(action)
        td = env.step(td)
        obs, reward, terminated, truncated, _ = plain.step(action)
        np.testing.assert_array_equal(td["next", "observation"].numpy(), obs)
        assert float(td["next", "reward"]) == pytest.approx(reward, rel=1e-6)  # TorchRL keeps float32 rewards
        assert bool(td["next", "terminated"]) == terminated and bool(td["next", "truncated"]) == truncated
        td = td["next"]


def test_the_documented_torchrl_loop_trains_a_batch_of_bodies():
    script = ROOT / "docs" / "examples" / "torchrl_batch.py"
    assert f'--8<-- "{script.relative_to(ROOT)}"' in (ROOT / "docs" / "controllers" / "ppo.md").read_text()
    out = subprocess.run([sys.executable, str(script), "--frames", "600", "--per-batch", "300"],
                         capture_output=True, text=True, timeout=600, check=True).stdout  # fmt: skip
    lines = re.findall(r"iteration (\d+): mean reward per step by body \[(.*)\], loss (\S+)", out)
    assert [int(i) for i, _, _ in lines] == [0, 1], out
    for _, rewards, loss in lines:
        assert len(rewards.split(",")) == 3 and math.isfinite(float(loss))


def test_clip_ppo_loss_over_stacked_bodies_gives_the_hand_written_numbers():
    """The measurement behind keeping the hand-written loss (docs/benchmarks/ppo.md): ClipPPOLoss, vmapped over
    the bodies' stacked parameters, computes each body's loss and value loss as ``LockstepUpdate`` does."""
    from support.scripts import load_script

    assert load_script("compare/ppo_clip_loss").check(seeds=2) < 1e-6
