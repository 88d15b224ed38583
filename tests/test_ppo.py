"""The ``ppo`` controller: learning, action range, seeding, saved policies, bad input.

Budgets are a few rollouts so that the whole file stays fast; what the controller reaches with
real budgets is measured by ``benchmarks/compare/ppo_vs_sb3.py``.
"""

from __future__ import annotations

import functools
import json
import subprocess
import sys

import gymnasium
import numpy as np
import pandas as pd
import pytest
import torch
from typer.testing import CliRunner

from gdabench.batched import ArrayBodies, GymBodies
from gdabench.body import as_body
from gdabench.cli import app
from gdabench.controllers.ppo import PPO, PPOConfig, replay
from gdabench.controllers.ppo.evaluation import episode_score
from gdabench.controllers.ppo.policy_file import META_FILE, WEIGHTS_FILE
from gdabench.controllers.ppo.train import train
from gdabench.controllers.ppo.update import LockstepUpdate
from gdabench.envs.voxel import engine
from gdabench.envs.voxel.batch import TaskBatch
from gdabench.envs.walker.env import Walker, make_walker
from gdabench.envs.walker.sim import WalkerPhysics
from gdabench.errors import ConfigError

WALKER = as_body("00000/44444/44444/40004/40004")
SMALL = {"timesteps": 256, "eval_interval": 128}  # two rollouts, three evaluations


class Target(gymnasium.Env):
    """A one-step task: reward 5 - sum((action - 1.3)^2), actions in [0.6, 1.6].

    SB3's initial policy has its mean near 0, so at first most clipped actions are 0.6; learning
    moves the mean up, and the value function has the constant part of the reward to learn."""

    def __init__(self, n_act: int = 2):
        self.observation_space = gymnasium.spaces.Box(-1.0, 1.0, (3,), np.float64)
        self.action_space = gymnasium.spaces.Box(0.6, 1.6, (n_act,), np.float64)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return np.array([1.0, 0.0, -1.0]), {}

    def step(self, action):
        return np.array([1.0, 0.0, -1.0]), 5.0 - float(np.sum((np.asarray(action) - 1.3) ** 2)), True, False, {}


class ActionLog(gymnasium.Wrapper):
    """Records every action the environment receives."""

    log: list[np.ndarray] = []

    def step(self, action):
        ActionLog.log.append(np.array(action, dtype=float))
        return self.env.step(action)


def gym(make_env):
    """A batch maker for one body's Gymnasium environments."""
    return lambda n: GymBodies([make_env], n)


def test_loss_decreases_and_reward_rises_on_a_toy_task():
    config = PPOConfig(timesteps=128 * 8, eval_interval=128 * 2, n_evals=8, learning_rate=1e-3, episode_end="full")
    [result] = train(config, gym(Target), [0])
    total, value = np.array(result.losses).T
    assert len(total) == 8 and np.isfinite(total).all()
    assert total[-2:].mean() < 0.25 * total[0] and value[-2:].mean() < 0.25 * value[0]
    first, last = result.evaluations[0].mean, result.evaluations[-1].mean
    assert last > first
    assert result.reward == max(e.mean for e in result.evaluations)
    mean_action = result.nets.mean(torch.tensor([[1.0, 0.0, -1.0]]))
    assert (mean_action > 0.1).all()  # moved up from about 0, towards the range


def test_actions_stay_inside_the_actuator_range():
    ActionLog.log = []
    make_env = lambda: ActionLog(make_walker(WALKER))  # noqa: E731
    PPO(**SMALL).evaluate(make_env, seed=1)
    actions = np.concatenate(ActionLog.log)
    assert len(ActionLog.log) >= 256
    assert actions.min() >= 0.6 and actions.max() <= 1.6
    assert (actions == 0.6).any() and (actions > 0.6).any()  # the Gaussian does leave the range: clipping is exercised


def test_same_seed_same_reward_and_the_caller_rng_is_untouched():
    walker = Walker()
    torch.manual_seed(123)
    before = torch.rand(1)
    torch.manual_seed(123)
    a = walker.evaluate(WALKER, seed=7, controller=PPO(**SMALL))
    assert torch.rand(1) == before
    b = walker.evaluate(WALKER, seed=7, controller=PPO(**SMALL))
    c = walker.evaluate(WALKER, seed=8, controller=PPO(**SMALL))
    assert a.reward == b.reward and a.info["env_steps"] == 256
    assert c.reward != a.reward


#: Evolution Gym 1.0's schedule: 4 environments, 4 minibatches, linear learning-rate decay, normalised observations
EVOGYM1 = {"n_envs": 4, "batch_size": 128, "lr_schedule": "linear", "normalize_obs": True}


@pytest.mark.parametrize("schedule", [{}, EVOGYM1], ids=["evogym2", "evogym1"])
def test_saved_policy_reloads_and_reproduces_its_reward(tmp_path, schedule):
    settings = dict(
        timesteps=256 * schedule.get("n_envs", 1), eval_interval=128 * schedule.get("n_envs", 1), **schedule
    )
    walker, controller = Walker(), PPO(**settings)
    scored = walker.evaluate(WALKER, seed=3, controller=controller, workdir=tmp_path)
    assert (tmp_path / WEIGHTS_FILE).is_file() and (tmp_path / META_FILE).is_file()
    meta = json.loads((tmp_path / META_FILE).read_text())
    assert (
        meta["reward"] == scored.reward and len(meta["evaluations"]) == 3 and meta["timesteps"] == settings["timesteps"]
    )
    saved = torch.load(tmp_path / WEIGHTS_FILE, weights_only=True)["state_dict"]
    assert (saved["obs_var"] != 1).any() == bool(schedule)  # the statistics learned travel with the policy

    assert replay(tmp_path, functools.partial(make_walker, WALKER)) == scored.reward
    again = walker.evaluate(WALKER, seed=3, controller=PPO(**settings), workdir=tmp_path)
    assert again.reward == scored.reward and again.info["replayed"] == 1
    frames = walker.render_frames(WALKER, seed=3, controller=controller, workdir=tmp_path)
    assert frames and frames[0].ndim == 3
    retrained = walker.evaluate(WALKER, seed=3, controller=PPO(timesteps=256, eval_interval=256), workdir=tmp_path)
    assert retrained.info["replayed"] == 0  # other settings: trained anew, and the new policy saved
    assert json.loads((tmp_path / META_FILE).read_text())["trained_with"]["settings"]["eval_interval"] == 256


def test_parallel_environments_train_seeded_with_finite_rewards(monkeypatch):
    config = PPOConfig(timesteps=512, n_envs=2, eval_interval=256)  # two rollouts of 2 x 128 steps
    make_env = functools.partial(make_walker, WALKER)
    threads, step = set(), LockstepUpdate.__call__
    monkeypatch.setattr(
        LockstepUpdate, "__call__", lambda self, b: threads.add(torch.get_num_threads()) or step(self, b)
    )
    [a] = train(config, gym(make_env), [5])
    assert threads == {config.threads}
    [b] = train(config, gym(make_env), [5])
    assert a.timesteps == 512 and len(a.losses) == 2 and np.isfinite(a.losses).all()
    assert [e.scores for e in a.evaluations] == [e.scores for e in b.evaluations] and len(a.evaluations) == 3
    assert np.isfinite(a.reward) and a.reward == b.reward


class Ticks(gymnasium.Env):
    """Observation [steps so far, first action]; reward = steps so far; terminates after ``length`` steps."""

    def __init__(self, length: int):
        self.length, self.t = length, 0
        self.observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (2,), np.float64)
        self.action_space = gymnasium.spaces.Box(0.6, 1.6, (1,), np.float64)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return np.array([0.0, 0.0]), {}

    def step(self, action):
        self.t += 1
        return np.array([self.t, action[0]]), float(self.t), self.t == self.length, False, {}


def test_a_batch_clips_actions_resets_ended_episodes_and_tells_truncation_from_termination():
    # body 0: truncated by a time limit every 2 steps; body 1: terminates every 3 steps
    makers = [lambda: gymnasium.wrappers.TimeLimit(Ticks(10), max_episode_steps=2), lambda: Ticks(3)]
    batch = GymBodies(makers)
    assert batch.reset()[:, 0].tolist() == [0.0, 0.0]
    steps = [batch.step(np.array([[0.0], [9.0]])) for _ in range(6)]
    assert [s.truncated.tolist() for s in steps] == [[False, False], [True, False]] * 3
    assert [s.terminated.tolist() for s in steps] == [[False, False], [False, False], [False, True]] * 2
    assert [s.next_obs[1, 0] for s in steps] == [1, 2, 3, 1, 2, 3]  # the last observation of an episode, for GAE
    assert [s.obs[1, 0] for s in steps] == [1, 2, 0, 1, 2, 0]  # then the next episode's first
    assert {s.next_obs[0, 1] for s in steps} == {0.6} and {s.next_obs[1, 1] for s in steps} == {1.6}  # clipped


def test_an_unstable_body_is_scored_not_crashed():
    exploding = functools.partial(make_walker, WALKER, "pymunk", physics=WalkerPhysics(max_speed=1e-9))
    out = PPO(timesteps=256, episode_end="full").evaluate(exploding, seed=0)
    assert out.reward == -3.0  # every episode ends unstable after one step
    assert out.info["ppo_unstable_episodes"] >= 256


def test_episode_end_conventions():
    assert episode_score([0.5, 0.25, 1.0], "full") == 1.75
    assert episode_score([0.5, 0.25, 1.0], "evogym2") == 0.75  # Evolution Gym 2.0 drops the last step's reward


@pytest.mark.parametrize(
    "params, message",
    [
        ({"timesteps": 100}, "less than one rollout"),
        ({"timesteps": 512, "n_envs": 8}, "less than one rollout"),
        ({"learning_rate": -1e-3}, "learning_rate must be positive"),
        ({"device": "tpu"}, "unknown device 'tpu'"),
        ({"device": "quantum:0"}, "unknown device"),
        ({"clip_range": 0}, "clip_range"),
        ({"episode_end": "sometimes"}, "episode_end"),
        ({"wings": 2}, "unexpected keyword"),
    ],
)
def test_bad_settings_fail_at_configuration_in_one_line(params, message):
    with pytest.raises(ConfigError, match=message) as err:
        PPO(**params)
    assert "\n" not in str(err.value)


@pytest.mark.skipif(torch.cuda.is_available(), reason="checks the message on a machine without a GPU")
def test_asking_for_a_missing_gpu_is_one_line():
    with pytest.raises(ConfigError, match="no CUDA GPU"):
        PPO(device="cuda")


def test_cli_rejects_bad_settings_before_running(tmp_path):
    result = CliRunner().invoke(
        app,
        [
            "compare",
            "--designers",
            "ga",
            "--env",
            "walker",
            "--controller",
            "ppo",
            "-C",
            "learning_rate=-1",
            "--out",
            str(tmp_path / "r"),
            "-q",
        ],
    )
    assert result.exit_code == 2
    assert "learning_rate must be positive" in result.stderr and "Traceback" not in result.stderr


def test_listing_controllers_does_not_import_torchrl():
    code = (
        "import sys; from gdabench.plugins import registry; names = [i.name for i in registry().items('controller')];"
        " print('ppo' in names, 'torchrl' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["True", "False"]


def test_compare_with_ppo_saves_policies_and_replay_uses_them(tmp_path):
    run = tmp_path / "run"
    args = [
        "compare",
        "--designers",
        "random",
        "--env",
        "walker",
        "--controller",
        "ppo",
        "-C",
        "timesteps=128",
        "--reevaluate",
        "off",
        "--budget",
        "2",
        "--population",
        "2",
    ]
    result = CliRunner().invoke(app, [*args, "--out", str(run), "-q", "--no-report"], catch_exceptions=False)
    assert result.exit_code == 0, result.stderr
    policies = sorted(run.glob("artifacts/*/*/" + WEIGHTS_FILE))
    assert len(policies) == 2
    gif = tmp_path / "best.gif"
    replayed = CliRunner().invoke(app, ["replay", str(run), "--gif", str(gif)], catch_exceptions=False)
    assert replayed.exit_code == 0, replayed.stderr
    assert "reward" in replayed.stdout and gif.read_bytes()[:3] == b"GIF"
    missing = CliRunner().invoke(app, ["replay", str(run), "--body", "ffffffffffff"])
    assert missing.exit_code == 2 and "no scored body with hash" in missing.stderr


def test_a_body_two_trials_share_is_trained_once_and_both_keep_its_policy(tmp_path):
    run = tmp_path / "run"
    args = [
        "compare",
        "--designers",
        "random,ga[survivors=1]",
        "--env",
        "walker",
        "--controller",
        "ppo",
        "-C",
        "timesteps=128",
        "--reevaluate",
        "off",
        "--budget",
        "2",
        "--population",
        "2",
        "--jobs",
        "1",
    ]
    result = CliRunner().invoke(app, [*args, "--out", str(run), "-q", "--no-report"], catch_exceptions=False)
    assert result.exit_code == 0, result.stderr
    rows = pd.read_parquet(run / "evaluations.parquet")
    by_designer = rows.pivot(index="body", columns="designer", values="eval_seconds")
    assert (
        len(by_designer) == 2 and (by_designer["random"] == by_designer["ga[survivors=1]"]).all()
    )  # one training, replayed
    assert len(sorted(run.glob("artifacts/*/*/" + WEIGHTS_FILE))) == 4  # each trial has the policies of its bodies
    replayed = CliRunner().invoke(app, ["replay", str(run), "--designer", "ga[survivors=1]"], catch_exceptions=False)
    assert replayed.exit_code == 0 and "reward" in replayed.stdout, replayed.stderr


def test_a_generation_trains_in_lockstep_through_the_harness_with_the_table_of_body_by_body(tmp_path):
    args = [
        "compare",
        "--designers",
        "random",
        "--env",
        "walker",
        "--controller",
        "ppo",
        "-C",
        "timesteps=128",
        "--reevaluate",
        "off",
        "--budget",
        "3",
        "--population",
        "3",
        "-q",
        "--no-report",
    ]
    tables = {}
    for name, extra in {"lockstep": [], "one at a time": ["--batch", "1"]}.items():
        result = CliRunner().invoke(app, [*args, "--out", str(tmp_path / name), *extra], catch_exceptions=False)
        assert result.exit_code == 0, result.stderr
        tables[name] = pd.read_parquet(tmp_path / name / "evaluations.parquet")
    assert tables["lockstep"]["ppo_batch"].tolist() == [3, 3, 3] and tables["one at a time"]["ppo_batch"].tolist() == [
        1,
        1,
        1,
    ]
    assert tables["lockstep"]["reward"].tolist() == tables["one at a time"]["reward"].tolist()
    assert tables["lockstep"]["body"].tolist() == tables["one at a time"]["body"].tolist()


BODIES = ["33333/33333/33333/33333/33333", "00000/44444/44444/40004/40004", "03330/03330/33333/30003/30003"]
#: networks padded as for any 5x5 body: 36 points (74 observations), 25 actuators
PAD_5X5 = (2 + 2 * 36, 25)


def voxel(bodies):
    """A batch maker for bodies on the voxel walker, one array step for all (tables padded to 5x5)."""
    pad = engine.body_tables(["44444/44444/44444/44444/44444"])
    return lambda n: ArrayBodies(TaskBatch("Walker-v0", bodies, n, pad=pad), n, 500)


@pytest.mark.parametrize("schedule", [{}, {**EVOGYM1, "n_envs": 2}], ids=["evogym2", "evogym1"])
def test_a_body_learns_the_same_alone_and_in_any_batch(schedule):
    config = PPOConfig(**{**SMALL, "n_envs": 2, **schedule})
    [alone] = train(config, voxel(BODIES[1:2]), [11], pad=PAD_5X5)
    batch = train(config, voxel([BODIES[2], BODIES[1], BODIES[0]]), [3, 11, 4], pad=PAD_5X5)
    assert [e.scores for e in batch[1].evaluations] == [e.scores for e in alone.evaluations]
    assert batch[1].losses == alone.losses
    for name, p in alone.nets.state_dict().items():
        assert torch.equal(p, batch[1].nets.state_dict()[name]), name
    assert batch[0].reward != alone.reward and batch[2].reward != alone.reward  # the others did learn their own


def test_the_gymnasium_walker_and_the_batched_engine_train_a_body_identically():
    config = PPOConfig(**SMALL)
    [batched] = train(config, voxel(BODIES[1:2]), [2], pad=PAD_5X5)
    make_env = lambda: gymnasium.make("gdabench/Walker-v2", body=BODIES[1])  # noqa: E731
    [single] = train(config, gym(make_env), [2], pad=PAD_5X5)
    assert [e.scores for e in single.evaluations] == [e.scores for e in batched.evaluations]
    assert single.losses == batched.losses
