"""``modular-ppo``: one per-voxel policy learnt by a generation's bodies together and carried on to the next
generation; registered, checked early, reproducible, and resumable after a kill with the same numbers."""

from __future__ import annotations

import signal

import pandas as pd
import torch
from typer.testing import CliRunner

from gdabench.body import as_body
from gdabench.cli import app
from gdabench.controllers.modular.controller import ModularPPO, generation_seed
from gdabench.controllers.modular.observation import modular_view
from gdabench.controllers.modular.policy import fresh_policy
from gdabench.controllers.modular.train import train_pooled
from gdabench.envs.voxel.env import VoxelTask
from gdabench.results import RunDirectory

from support.processes import cli, error_lines, table

BODIES = ["00000/44444/44444/40004/40004", "33333/30103/32223/04140/44044", "03300/03300/44444/40104/40004"]
#: the smallest training: one rollout of 64 steps, one evaluation (at the end)
TINY = {"timesteps": 64, "n_steps": 64, "eval_interval": 128}
CONTROLLER = "modular-ppo[timesteps=64,n_steps=64,eval_interval=128]"
#: what differs between identical runs besides the harness's own timings
TIMES = ["modular_train_seconds"]


def train(controller, bodies, seeds, workdirs):
    results = controller.evaluate_bodies(
        VoxelTask().bodies([as_body(b) for b in bodies]), seeds=seeds, workdirs=workdirs
    )
    assert not any(isinstance(r, BaseException) for r in results), results
    return results


def test_the_policy_is_carried_on_the_same_in_memory_and_from_disk_and_a_saved_body_replays(tmp_path):
    """Generation 1 (two bodies), then generation 2 (one): in one process, and with generation 2 in a new
    controller that reads the policy generation 1 left from the trial's folder, as a resumed run does."""
    dirs = [tmp_path / as_body(b).hash for b in BODIES]
    memory, elsewhere = ModularPPO(**TINY), [tmp_path / "memory" / as_body(b).hash for b in BODIES]
    first = train(memory, BODIES[:2], [1, 2], elsewhere[:2])
    second = train(memory, BODIES[2:], [3], elsewhere[2:])
    assert [r.info["modular_generation"] for r in (*first, *second)] == [1, 1, 2]
    assert first[0].info["modular_bodies"] == 2 and first[0].info["env_steps"] == 64
    assert first[0].reward != first[1].reward  # one network, two bodies, two gaits
    on_disk = train(ModularPPO(**TINY), BODIES[:2], [1, 2], dirs[:2])
    resumed = train(ModularPPO(**TINY), BODIES[2:], [3], dirs[2:])
    assert [r.reward for r in (*on_disk, *resumed)] == [r.reward for r in (*first, *second)]
    # generation 2 is PPO from the network generation 1 ended with, kept in the trial's folder
    [ended] = tmp_path.glob("modular-ppo/*/generation-0001.pt")
    policy = fresh_policy(2, (64, 64), generation_seed([3], 1))
    policy.load_state_dict(torch.load(ended, weights_only=True))
    bodies = VoxelTask().bodies([as_body(BODIES[2])])
    direct = train_pooled(
        ModularPPO(**TINY).config,
        policy,
        lambda n: bodies.make_batch([0], n),
        [modular_view(bodies.make_envs[0]())],
        [3],
        generation_seed([3], 1),
    )
    assert direct.reward(0) == second[0].reward
    # a report, or a resume after the generation was saved, replays each body's saved policy
    replayed = train(ModularPPO(**TINY), BODIES, [1, 2, 3], dirs)
    assert [r.reward for r in replayed] == [r.reward for r in (*first, *second)]
    assert [r.info for r in replayed] == [r.info for r in (*on_disk, *resumed)]
    # without work directories (a re-evaluation) a body learns from a fresh policy, nothing is carried
    [fresh] = train(memory, BODIES[2:], [3], [None])
    assert fresh.info["modular_generation"] == 1 and fresh.reward != second[0].reward


def test_parameters_are_checked_before_a_run_in_one_line_and_info_lists_them(tmp_path):
    runner = CliRunner()
    base = ["compare", "-d", "ga", "--env", "walker", "--budget", "3", "--population", "3", "-q", "--no-report"]
    for controller, says in (
        (
            "modular-ppo[init=parent]",
            "error: controller 'modular-ppo[init=parent]' has no parameter 'init'; its "
            "parameters: batch_size, clip_range, deterministic_eval, ent_coef, episode_end, eval_interval, gae_lambda, "
            "gamma, hidden, learning_rate, lr_schedule, max_grad_norm, n_envs, n_epochs, n_evals, n_steps, threads, "
            "timesteps, vf_coef",
        ),
        ("modular-ppo[timesteps=0]", "error: modular-ppo: timesteps must be a positive integer, got 0"),
    ):
        bad = runner.invoke(app, [*base, "--controller", controller, "--out", str(tmp_path / "bad")])
        assert bad.exit_code == 2 and error_lines(bad) == [says], bad.stderr
    assert not (tmp_path / "bad").exists()
    for split in (["--workers", "2"], ["--batch", "2"]):  # a generation of 3 would be split
        refused = runner.invoke(app, [*base, "--controller", CONTROLLER, *split, "--out", str(tmp_path / "s")])
        assert refused.exit_code == 2, refused.stderr
        assert error_lines(refused) == [
            f"error: controller {CONTROLLER!r} learns a generation's bodies together: use --workers 1 and no --batch "
            "below the population (3)"
        ]
    info = runner.invoke(app, ["info", "modular-ppo"])
    assert info.exit_code == 0 and "batch_size" in info.stdout and "minibatch size per body" in info.stdout
    assert "init" not in info.stdout.split()


ARGS = [
    "compare",
    "-d",
    "ga",
    "--env",
    "walker",
    "--controller",
    CONTROLLER,
    "--budget",
    "4",
    "--population",
    "3",
    "--jobs",
    "1",
    "--reevaluate",
    "off",
    "-q",
    "--no-report",
]


def test_a_co_design_run_is_reproducible_and_resumes_after_a_kill_with_the_same_numbers(tmp_path):
    """An experiment file selects the controller (uninterrupted run); the command line runs it again, killed
    after generation 1's child saved its policy but before the trial's chain recorded that generation, and
    resumed: generation 1 is trained again from the policy generation 0 left, and the table is the same."""
    experiment = tmp_path / "modular.toml"
    experiment.write_text(
        f'designers = ["ga"]\nenv = "walker"\ncontroller = "{CONTROLLER}"\npopulation = 3\nbudget = 4\nseeds = "0"\n'
        "reevaluate = false\n"
    )
    whole = tmp_path / "whole"
    done = CliRunner().invoke(
        app, ["compare", "--config", str(experiment), "--jobs", "1", "-q", "--no-report", "--out", str(whole)]
    )
    assert done.exit_code == 0, done.stderr
    reference = table(whole, drop=TIMES)
    assert reference["controller"].unique().tolist() == [CONTROLLER]
    # the GA's generation 0 learns together; each later generation has one new child (the survivors stay)
    assert reference["modular_generation"].tolist() == [1, 1, 1, 2]
    assert reference["modular_bodies"].tolist() == [3, 3, 3, 1]
    assert reference["env_steps"].tolist() == [64] * 4
    killed = tmp_path / "killed"
    dead = cli(*ARGS, "--out", str(killed), site=tmp_path, env={"GDABENCH_FAULT": "modular-ppo-saved:4"})
    assert dead.returncode == -signal.SIGKILL, dead.stderr
    assert len(RunDirectory.open(killed).load_evaluations()) == 3  # generation 1 was being saved
    resumed = cli("compare", "--resume", str(killed), "--jobs", "1", "-q", "--no-report", site=tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    pd.testing.assert_frame_equal(table(killed, drop=TIMES), reference)
