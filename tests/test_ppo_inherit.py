"""``ppo[init=parent]``: designers name a child's parents, its policy starts from its nearest parent's, rows
mapped by voxel; bit-reproducible and resumable after a kill."""

from __future__ import annotations

import signal

import gymnasium
import numpy as np
import pandas as pd
import pytest
import torch

from gdabench import make_designer
from gdabench.body import as_body
from gdabench.controllers.ppo import PPO, PPOConfig
from gdabench.controllers.ppo.layout import indexed, inherit, layout_of
from gdabench.controllers.ppo.train import initial_networks
from gdabench.designer import hamming
from gdabench.designers.cppn.designer import CppnNeat
from gdabench.designers.ga import GeneticAlgorithm
from gdabench.errors import ConfigError
from gdabench.results import RunDirectory
from gdabench.torch_runtime import torch_threads

from support.processes import cli, table

PARENT = "00000/44444/44444/40004/40004"
#: PARENT with its top-left actuator (row 1, column 0) made rigid and a new actuator at (0, 2)
CHILD = "00300/14444/44444/40004/40004"


def env_of(body: str) -> gymnasium.Env:
    return gymnasium.make("voxel/Walker-v0", body=body)


def layout(body: str):
    env = env_of(body)
    try:
        return layout_of(env), env.observation_space.shape[0], env.action_space.shape[0]
    finally:
        env.close()


def trained_like(seed: int, n_obs: int, n_act: int):
    """Networks whose every number differs from a fresh initialisation's (as a trained policy's do)."""
    nets = initial_networks(seed, n_obs, n_act, (64, 64))
    with torch.no_grad():
        for p in nets.parameters():
            p.add_(torch.randn(p.shape, generator=torch.Generator().manual_seed(seed)))
        nets.obs_mean.add_(0.5)
        nets.obs_var.mul_(2.0)
    return nets


def test_the_layout_keys_the_observation_rows_of_point_masses_by_their_corner():
    lay, n_obs, n_act = layout(PARENT)
    env = env_of(PARENT)
    obs, _ = env.reset(seed=0)
    robot = env.unwrapped.batch.tables.robots[0]
    points = len(robot.pos)
    assert n_obs == 2 + 2 * points and lay.obs[:2] == (("before", 0), ("before", 1))
    # Evolution Gym's relative positions: every x, then every y, relative to the centre of mass
    relative = robot.pos - robot.pos.mean(0)
    for row, key in enumerate(lay.obs[2:], start=2):
        axis, x, y, nth = key
        assert nth == 0  # no two voxels of this body touch only at a corner
        p = [tuple(c) for c in np.rint(robot.pos / 0.1).astype(int)].index((x, y))
        assert obs[row] == pytest.approx(relative[p, 0 if axis == "x" else 1], abs=1e-9)
    # the actions: one per actuator, row-major over the body (row 1: five vertical actuators first)
    assert lay.act[:5] == tuple(("voxel", 1, c) for c in range(5)) and len(lay.act) == n_act == 14


def test_a_child_equal_to_its_parent_starts_with_the_parents_exact_policy():
    lay, n_obs, n_act = layout(PARENT)
    parent = trained_like(1, n_obs, n_act)
    child = inherit(initial_networks(2, n_obs, n_act, (64, 64)), lay, parent, lay)
    for name, value in parent.state_dict().items():
        assert torch.equal(child.state_dict()[name], value), name


def test_rows_are_mapped_by_voxel_and_rows_without_a_counterpart_start_from_scratch():
    lay_p, obs_p, act_p = layout(PARENT)
    lay_c, obs_c, act_c = layout(CHILD)
    parent = trained_like(1, obs_p, act_p)
    fresh = initial_networks(2, obs_c, act_c, (64, 64))
    child = inherit(initial_networks(2, obs_c, act_c, (64, 64)), lay_c, parent, lay_p)
    # actions by hand: the child's actuators are (0,2) then rows 1.. without (1,0); the parent's start at (1,0)
    assert lay_c.act[0] == ("voxel", 0, 2) and lay_c.act[1] == ("voxel", 1, 1) and lay_p.act[1] == ("voxel", 1, 1)
    head_c, head_p, head_f = (n.mean[-1] for n in (child, parent, fresh))
    assert torch.equal(head_c.weight[1], head_p.weight[1]) and torch.equal(head_c.bias[1], head_p.bias[1])
    assert torch.equal(head_c.weight[0], head_f.weight[0])  # the new actuator: as from scratch
    assert child.log_std[1] == parent.log_std[1] and child.log_std[0] == fresh.log_std[0]
    for c in range(2, act_c):  # every other actuator of the child is one of the parent's, one row further on
        assert torch.equal(head_c.weight[c], head_p.weight[lay_p.act.index(lay_c.act[c])])
    # observations: the centre-of-mass velocity and every corner both bodies have come from the parent
    first_c, first_p, first_f = (n.mean[0].weight for n in (child, parent, fresh))
    shared = [(i, lay_p.obs.index(k)) for i, k in enumerate(lay_c.obs) if k in lay_p.obs]
    new = [i for i, k in enumerate(lay_c.obs) if k not in lay_p.obs]
    assert new and len(shared) == len(lay_c.obs) - len(new) > 2
    # by hand: the robot's bottom-left voxel is (1, 1), so the new voxel (row 0, column 2 of 5 rows) spans x 3..4,
    # y 5..6; its top corners (y 6) are the only points the parent (empty top row) lacks
    assert [lay_c.obs[i] for i in new] == [("x", 3, 6, 0), ("x", 4, 6, 0), ("y", 3, 6, 0), ("y", 4, 6, 0)]
    for i, j in shared:
        assert torch.equal(first_c[:, i], first_p[:, j]) and child.obs_mean[i] == parent.obs_mean[j]
    for i in new:
        assert torch.equal(first_c[:, i], first_f[:, i]) and child.obs_mean[i] == fresh.obs_mean[i]
    assert torch.equal(child.mean[2].weight, parent.mean[2].weight)  # hidden layers whole
    assert torch.equal(child.value[-1].weight, parent.value[-1].weight)


def test_voxels_touching_only_at_a_corner_keep_a_point_each_there():
    lay, _, _ = layout("03300/30300/33300/00000/00000")  # (0,1) and (1,0) touch at one corner only
    assert len(set(lay.obs)) == len(lay.obs)
    # that corner (x 2, y 5: the body's top is y 4 + 1 + 1) has two points, one per voxel
    assert ("x", 2, 5, 0) in lay.obs and ("x", 2, 5, 1) in lay.obs


def test_an_environment_without_a_layout_inherits_by_index_only_between_bodies_of_one_size():
    parent = trained_like(1, 3, 2)
    same = inherit(initial_networks(2, 3, 2, (64, 64)), indexed(3, 2), parent, indexed(3, 2))
    assert all(torch.equal(same.state_dict()[k], v) for k, v in parent.state_dict().items())
    with pytest.raises(ValueError, match="hidden"):
        inherit(initial_networks(2, 3, 2, (32,)), indexed(3, 2), parent, indexed(3, 2))


def test_init_is_checked_and_scratch_keeps_the_fingerprint_it_had():
    with pytest.raises(ConfigError, match="init must be one of scratch, parent"):
        PPOConfig(init="grandparent")
    assert "init" not in PPO().fingerprint(3)["settings"] and PPO().inherits is False
    inheriting = PPO(init="parent")
    assert inheriting.inherits and inheriting.fingerprint(3, "abc")["parent"] == "abc"


def test_ga_names_the_survivor_a_child_was_mutated_from():
    ga = GeneticAlgorithm(population=6, budget=30, seed=1)
    first = ga.ask()
    assert ga.proposal_parents() == [()] * 6
    ga.tell(first, [float(i) for i in range(6)])
    children = ga.ask()
    parents = ga.proposal_parents()
    assert len(parents) == len(children)
    for child, (parent,), info in zip(children, parents, ga.proposal_info()):
        assert parent.hash == info["parent"] and parent.hash in {b.hash for b, _ in ga.survivors}
        assert 0 < hamming(child, parent) < 25


def test_cppn_names_the_genomes_neat_python_bred_a_child_from_and_survives_a_checkpoint():
    import pickle

    cppn = CppnNeat(population=10, budget=100, seed=3)
    first = cppn.ask()
    cppn.tell(first, [float(b.voxels.sum()) for b in first])
    restored = pickle.loads(pickle.dumps(cppn))
    children = restored.ask()
    parents = restored.proposal_parents()
    told = {b.hash for b in first}
    bred = [(c, ps) for c, ps in zip(children, parents) if ps]
    assert bred and all(1 <= len(ps) <= 2 and {p.hash for p in ps} <= told for _, ps in bred)
    for child, ps in bred:  # nearest first
        assert [hamming(child, p) for p in ps] == sorted(hamming(child, p) for p in ps)
    fresh = [info["cppn_fresh"] for info in restored.proposal_info()]
    assert all(not ps for ps, f in zip(parents, fresh) if f)


def test_gda_names_the_survivors_nearest_by_voxel_distance_first():
    gda = make_designer("gda", seed=0, shape=(5, 5), population=10, budget=1000, steps=50, epochs=2)
    first = gda.ask()
    assert gda.proposal_parents() == [()] * 10  # generation 0 is random
    gda.tell(first, [float(np.asarray(b.voxels).sum()) for b in first])
    children = gda.ask()
    survivors = {s.body.hash for s in gda.survivors}
    for child, parents, info in zip(children, gda.proposal_parents(), gda.proposal_info()):
        if info["source"] == "random":
            assert parents == ()
            continue
        assert {p.hash for p in parents} == survivors
        distances = [hamming(child, p) for p in parents]
        assert distances == sorted(distances) and distances[0] == min(hamming(child, s.body) for s in gda.survivors)


def test_a_child_learns_the_same_from_its_parent_in_memory_and_read_back_from_disk(tmp_path):
    """In memory in the process that trained the parent, or from the run directory in a new one (a resume),
    whatever torch's thread count outside the training."""
    import dataclasses

    from gdabench.envs.voxel.env import VoxelTask

    env, parent, child = VoxelTask(), as_body(PARENT), as_body(CHILD)
    ppo = PPO(timesteps=128, init="parent")
    [trained] = ppo.evaluate_bodies(env.bodies([parent]), seeds=[1], workdirs=[tmp_path / parent.hash])
    bodies = dataclasses.replace(env.bodies([child]), parents=[(tmp_path / "missing", tmp_path / parent.hash)])
    with torch_threads(2):
        [in_memory] = ppo.evaluate_bodies(bodies, seeds=[2], workdirs=[tmp_path / "one"])
    [from_disk] = PPO(timesteps=128, init="parent").evaluate_bodies(bodies, seeds=[2], workdirs=[tmp_path / "two"])
    [scratch] = PPO(timesteps=128).evaluate_bodies(env.bodies([child]), seeds=[2], workdirs=[None])
    assert in_memory.info["ppo_inherited"] == from_disk.info["ppo_inherited"] == 1
    assert in_memory.reward == from_disk.reward != scratch.reward
    assert trained.info["ppo_inherited"] == 0
    # a report replays a child alone, its parents unknown: the policy it saved, not a new training
    replayed = PPO(timesteps=128, init="parent").evaluate(lambda: env.make_env(child), seed=2, workdir=tmp_path / "one")
    assert replayed.info["replayed"] == 1 and replayed.reward == in_memory.reward


CONTROLLER = "ppo[timesteps=128,init=parent]"
#: what differs between identical runs besides the harness's own timings
PPO_TIMES = ["ppo_train_seconds", "ppo_eval_seconds"]
ARGS = [
    "compare",
    "-d",
    "ga",
    "--env",
    "walker",
    "--controller",
    CONTROLLER,
    "--budget",
    "6",
    "--population",
    "3",
    "--jobs",
    "1",
    "--reevaluate",
    "off",
    "-q",
    "--no-report",
]


def test_inheriting_runs_are_reproducible_and_resume_after_a_kill_with_the_same_numbers(tmp_path):
    """Generation 0 trains from scratch, each later child from its parent (in memory in the uninterrupted run,
    read back from the run directory after the kill); the uninterrupted run comes from an experiment file that
    selects the controller, the killed and resumed one from the command line: both give the same table."""
    experiment = tmp_path / "inherit.toml"
    experiment.write_text(
        f'designers = ["ga"]\nenv = "walker"\ncontroller = "{CONTROLLER}"\npopulation = 3\nbudget = 6\nseeds = "0"\n'
        "reevaluate = false\n"
    )
    whole = tmp_path / "whole"
    done = cli(
        "compare", "--config", str(experiment), "--jobs", "1", "-q", "--no-report", "--out", str(whole), site=tmp_path
    )
    assert done.returncode == 0, done.stderr
    reference = table(whole, drop=PPO_TIMES)
    assert reference["controller"].unique().tolist() == [CONTROLLER]
    assert reference["ppo_inherited"].tolist() == [0, 0, 0, 1, 1, 1]
    killed = tmp_path / "killed"
    dead = cli(*ARGS, "--out", str(killed), site=tmp_path, env={"GDABENCH_FAULT": "outcome-stored:5"})
    assert dead.returncode == -signal.SIGKILL, dead.stderr
    assert len(RunDirectory.open(killed).load_evaluations()) == 4  # generation 2's child was stored, not written
    resumed = cli("compare", "--resume", str(killed), "--jobs", "1", "-q", "--no-report", site=tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    got = table(killed, drop=PPO_TIMES)
    pd.testing.assert_frame_equal(got, reference)
    assert got["body"].map(lambda b: as_body(b).hash).is_unique
