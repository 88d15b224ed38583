"""The walker task: pymunk soft-voxel simulator, gdabench/Walker-v1, the walker env, open-loop."""

from __future__ import annotations

import dataclasses
import io
import math
import subprocess
import sys
import warnings
from dataclasses import replace

import gymnasium
import numpy as np
import pandas as pd
import pytest
from gymnasium.utils.env_checker import check_env
from PIL import Image

import gdabench
from gdabench import Body, ConfigError, Evaluation, make_controller, make_env
from gdabench.controllers.open_loop import OpenLoop, Pattern
from gdabench.envs.walker import ENV_ID, RETIRED_IDS, gym_env
from gdabench.envs.walker.mesh import DIAGONAL, build_mesh
from gdabench.envs.walker.sim import WalkerPhysics
from gdabench.report.animation import frames_to_gif
from gdabench.running.runner import compare as run_experiment

VOXEL = 0.1
WALKER_BODY = "33333/40004/40004"  # a bridge of horizontal actuators on two vertical-actuator legs


def make(body: str, **kwargs) -> gymnasium.Env:
    return gymnasium.make(ENV_ID, body=body, **kwargs)


def com(env: gymnasium.Env) -> np.ndarray:
    return env.unwrapped.sim.positions.mean(axis=0)


def hold(env: gymnasium.Env, ratio: float, steps: int) -> float:
    """Hold every actuator at ``ratio``; returns the summed reward."""
    total = 0.0
    action = np.full(env.action_space.shape, ratio)
    for _ in range(steps):
        _, reward, terminated, truncated, _ = env.step(action)
        total += reward
        assert not (terminated or truncated)
    return total


def inchworm_action(cells: np.ndarray, t: int, *, mirrored: bool = False, period: int = 40) -> np.ndarray:
    """A hand-made gait: lift the right leg while the bridge extends, plant it, then lift the left
    leg while the bridge contracts.  ``mirrored`` swaps the legs' roles."""
    bridge = cells[:, 2] == 3
    legs = cells[:, 2] == 4
    front = legs & (cells[:, 1] == (cells[:, 1].min() if mirrored else cells[:, 1].max()))
    back = legs & ~front
    s = (t % period) / period
    action = np.ones(len(cells))
    action[bridge] = 1.5 if s < 0.5 else 0.7
    action[front] = 0.7 if s < 0.25 else 1.1
    action[back] = 0.7 if 0.5 <= s < 0.75 else 1.1
    return action


def inchworm(env: gymnasium.Env, *, mirrored: bool = False, steps: int = 500) -> float:
    """Play the hand-made gait; returns the summed reward."""
    total = 0.0
    for t in range(steps):
        _, reward, terminated, truncated, _ = env.step(
            inchworm_action(env.unwrapped.actuator_voxels, t, mirrored=mirrored)
        )
        total += reward
        if terminated or truncated:
            break
    return total


# -- registration and input checking -------------------------------------------------------------
def test_import_registers_the_env_without_importing_pymunk():
    code = (
        "import sys, gymnasium, gdabench; assert 'gdabench/Walker-v1' in gymnasium.registry;"
        " assert 'pymunk' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_the_retired_v0_id_fails_with_one_line_naming_v2_and_v1():
    assert ENV_ID == "gdabench/Walker-v1" and RETIRED_IDS == ("gdabench/Walker-v0",)
    with pytest.raises(ConfigError, match="use gdabench/Walker-v2 .* or gdabench/Walker-v1") as info:
        gymnasium.make("gdabench/Walker-v0", body=WALKER_BODY)
    assert "\n" not in str(info.value) and "retired" in str(info.value)


def test_the_walker_environment_records_its_physics_version():
    assert make_env("walker", engine="pymunk").version == "gdabench/Walker-v1"


@pytest.mark.parametrize(
    "body, message",
    [
        ([1, 2, 3], "2-D"),  # wrong shape: not a grid
        (np.ones((2, 2, 2), dtype=int), "2-D"),
        ("33/35", "'5' is not a voxel code"),
        ([[1, 2], [2, 7]], "not one of 0-4"),
        ("11/22", "no actuator"),
        ("30/03", "not connected"),
        ("3" * 100, "wider than"),
        (None, "2-D"),
    ],
)
def test_bad_bodies_raise_a_clear_value_error_before_simulating(monkeypatch, body, message):
    def no_simulation(*args, **kwargs):
        raise AssertionError("a simulation was built for a bad body")

    monkeypatch.setattr(gym_env, "VoxelSim", no_simulation)
    with pytest.raises(ValueError, match=message) as info:
        gymnasium.make(ENV_ID, body=body)
    assert isinstance(info.value, gdabench.GdabenchError)
    assert "\n" not in str(info.value)


def test_bad_actions_raise():
    env = make("33")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="expects 2 actions"):
        env.step(np.ones(3))
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([1.0, np.nan]))


def test_gymnasium_check_env_passes():
    env = make(WALKER_BODY, render_mode="rgb_array")
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*symmetric and normalized space.*")  # [0.6, 1.6] is Evolution Gym's
        check_env(env.unwrapped)


# -- spaces, observation, reward ------------------------------------------------------------------
def test_spaces_follow_evolution_gym():
    env = make("33333/31113/31013/31013/31013")
    sim = env.unwrapped.sim
    assert env.action_space.shape == (13,)
    assert (env.action_space.low == 0.6).all() and (env.action_space.high == 1.6).all()
    assert env.observation_space.shape == (2 + 2 * sim.mesh.n_points,)
    assert env.spec.max_episode_steps == 500
    # grid starts at voxel (1, 1): lower-left corner of the body at (0.1, 0.1), resting on the terrain
    assert sim.positions[:, 0].min() == pytest.approx(VOXEL)
    assert sim.positions[:, 1].min() == pytest.approx(VOXEL)
    # actuators in action order: row-major from the top row, (row, col, code)
    cells = env.unwrapped.actuator_voxels
    assert cells[:5].tolist() == [[0, c, 3] for c in range(5)]
    assert cells[5].tolist() == [1, 0, 3]


def test_observation_is_com_velocity_then_relative_positions():
    env = make(WALKER_BODY)
    env.reset(seed=0)
    obs, *_ = env.step(np.full(env.action_space.shape, 1.4))
    sim = env.unwrapped.sim
    rel = sim.positions - sim.positions.mean(axis=0)
    # scaled by the voxel size, as Evolution Gym's benchmark tasks scale theirs
    np.testing.assert_allclose(obs[:2], VOXEL * sim.velocities.mean(axis=0))
    np.testing.assert_allclose(obs[2:], VOXEL * np.concatenate([rel[:, 0], rel[:, 1]]))
    assert np.abs(obs[:2]).max() > 0.0  # the body moves


def test_reward_equals_centre_of_mass_displacement_over_the_episode():
    env = make(WALKER_BODY)
    env.reset(seed=0)
    start = com(env)[0]
    total = inchworm(env, steps=200)
    assert total == pytest.approx(com(env)[0] - start, abs=1e-9)
    assert abs(total) > 0.05


def test_goal_gives_bonus_and_ends_the_episode():
    env = make(WALKER_BODY)
    env.reset(seed=0)
    env.unwrapped.goal_x = com(env)[0] + 0.05  # the real goal (x = 9.9) is too far for a test
    for t in range(300):
        before = com(env)[0]
        _, reward, terminated, truncated, _ = env.step(inchworm_action(env.unwrapped.actuator_voxels, t, mirrored=True))
        if terminated:
            break
    assert terminated and not truncated
    assert reward == pytest.approx(com(env)[0] - before + 1.0)


def test_unstable_simulation_ends_with_minus_three_and_a_finite_observation():
    env = make(WALKER_BODY, physics=WalkerPhysics(max_speed=1e-3), render_mode="rgb_array")  # any motion is a blow-up
    obs0, _ = env.reset(seed=0)
    frame0 = env.render()
    obs, reward, terminated, truncated, info = env.step(np.full(env.action_space.shape, 1.6))
    assert reward == -3.0 and terminated and not truncated
    assert "faster" in info["unstable"]
    np.testing.assert_array_equal(obs, obs0)  # the last trustworthy observation ...
    np.testing.assert_array_equal(env.render(), frame0)  # ... and the last trustworthy picture


def test_episodes_are_truncated_after_500_steps():
    env = make(WALKER_BODY)
    env.reset(seed=0)
    for step in range(1, 501):
        *_, terminated, truncated, _ = env.step(inchworm_action(env.unwrapped.actuator_voxels, step))
        assert not terminated
        assert truncated == (step == 500)


def test_reset_restarts_the_episode_and_episodes_are_deterministic():
    env = make(WALKER_BODY)
    returns = []
    for _ in range(2):
        env.reset(seed=0)
        returns.append(inchworm(env, steps=300))
    fresh = make(WALKER_BODY)
    fresh.reset(seed=0)
    assert returns[0] == returns[1] == inchworm(fresh, steps=300)


# -- physics --------------------------------------------------------------------------------------
def test_mesh_shares_corners_and_edges_like_evolution_gym():
    tables = WalkerPhysics().tables()
    full = build_mesh(np.full((5, 5), 2), tables, voxel_size=VOXEL, origin=(0.1, 0.1))
    assert full.n_points == 36
    assert len(full.spring_ends) == 60 + 50  # 60 shared edges, 2 diagonals per voxel
    # voxels (1, 2) and (2, 1) touch only at a corner: two coincident points, as in Evolution Gym
    corner_only = build_mesh(np.array([[3, 1, 1], [1, 0, 1], [1, 1, 0]]), tables, voxel_size=VOXEL, origin=(0.1, 0.1))
    assert corner_only.n_points == 15 + 1
    env = make("311/101/110")
    env.reset(seed=0)
    # they do not push each other apart: the body only creeps, as in Evolution Gym (0.019 there)
    assert hold(env, 1.0, 100) == pytest.approx(0.0, abs=0.02)


def edge_between(mesh, a: tuple[float, float], b: tuple[float, float]) -> int:
    """Index of the spring joining the points at positions a and b."""
    index = {tuple(np.round(p, 6)): i for i, p in enumerate(mesh.points)}
    ends = {tuple(sorted(e)): s for s, e in enumerate(mesh.spring_ends.tolist())}
    return ends[tuple(sorted((index[a], index[b])))]


def test_actuators_drive_their_edges_as_evolution_gym_does():
    tables = WalkerPhysics().tables()
    # horizontal actuators: top and bottom edges only, never diagonals; a shared edge takes the mean
    mesh = build_mesh(np.array([[3, 0], [3, 2]]), tables, voxel_size=VOXEL, origin=(0.0, 0.0))
    top, shared, bottom = (edge_between(mesh, (0.0, y), (0.1, y)) for y in (0.2, 0.1, 0.0))
    assert set(mesh.driven.tolist()) == {top, shared, bottom}
    assert not (mesh.spring_kind[mesh.driven] == DIAGONAL).any()
    rest = dict(zip(mesh.driven.tolist(), mesh.rest_lengths(np.array([1.6, 0.8]))))
    assert rest[top] == pytest.approx(0.16) and rest[bottom] == pytest.approx(0.08)
    assert rest[shared] == pytest.approx(0.12)
    # an actuator beside a soft voxel drives the whole shared edge; beside a rigid voxel it cannot
    soft = build_mesh(np.array([[4, 2]]), tables, voxel_size=VOXEL, origin=(0.0, 0.0))
    assert edge_between(soft, (0.1, 0.1), (0.1, 0.0)) in soft.driven
    rigid = build_mesh(np.array([[4, 1]]), tables, voxel_size=VOXEL, origin=(0.0, 0.0))
    assert edge_between(rigid, (0.1, 0.1), (0.1, 0.0)) not in rigid.driven
    assert rigid.rigid_edge[edge_between(rigid, (0.1, 0.1), (0.1, 0.0))]


def test_spring_constants_follow_evolution_gym():
    physics = WalkerPhysics()
    tables = physics.tables()
    # a shared edge takes the constant of the last soft or actuator voxel in row-major order
    mesh = build_mesh(np.array([[2, 3], [1, 1]]), tables, voxel_size=VOXEL, origin=(0.0, 0.0))
    assert mesh.stiffness[edge_between(mesh, (0.1, 0.2), (0.1, 0.1))] == tables[3].edge_stiffness  # soft, then actuator
    assert mesh.stiffness[edge_between(mesh, (0.0, 0.1), (0.1, 0.1))] == tables[2].edge_stiffness  # soft over rigid
    assert mesh.stiffness[edge_between(mesh, (0.0, 0.0), (0.1, 0.0))] == tables[1].edge_stiffness  # rigid only
    assert tables[2].edge_stiffness == pytest.approx(0.006 * 3e8 / 6)
    assert tables[2].diagonal_stiffness == pytest.approx(tables[2].edge_stiffness / 4)
    assert tables[3].diagonal_stiffness == pytest.approx(tables[3].edge_stiffness / 2)


def test_resting_bodies_settle_and_stay_above_ground():
    for body in ["22222/22222/22232/22222/22222", "11111/12221/13331/13031/13031", "00400/03330/22222"]:
        env = make(body)
        env.reset(seed=0)
        hold(env, 1.0, 300)
        sim = env.unwrapped.sim
        assert np.abs(sim.velocities).max() < 1e-3, body  # settled
        assert sim.positions[:, 1].min() > VOXEL - 0.003, body  # on the terrain, not sunk into it
        top = sim.positions[:, 1].max()
        hold(env, 1.0, 100)
        assert sim.positions[:, 1].max() == pytest.approx(top, abs=1e-4), body  # and stays there


def test_horizontal_actuator_lengthens_along_x_only_within_the_strain_clamp():
    # ratio 1.2 reaches Evolution Gym's width (its unactuated diagonals hold it back); 1.6 and 0.6
    # stop at the +-25% clamp, as there
    for ratio, expected in ((1.2, 0.1164), (1.6, 0.125), (0.6, 0.075)):
        env = make("3")
        env.reset(seed=0)
        hold(env, ratio, 30)
        p = env.unwrapped.sim.positions  # TL, TR, BL, BR
        width = (p[1, 0] - p[0, 0] + p[3, 0] - p[2, 0]) / 2
        height = (p[0, 1] - p[2, 1] + p[1, 1] - p[3, 1]) / 2
        assert width == pytest.approx(expected, rel=0.02)
        assert height == pytest.approx(VOXEL, rel=0.1)


def test_actuators_follow_at_evolution_gyms_pace():
    """Width of one horizontal actuator after each of the first steps at ratio 1.2, as measured
    on Evolution Gym 2.0 (0.1048, 0.1083, 0.1107, 0.1124)."""
    env = make("3")
    env.reset(seed=0)
    widths = []
    for _ in range(4):
        hold(env, 1.2, 1)
        p = env.unwrapped.sim.positions
        widths.append((p[1, 0] - p[0, 0] + p[3, 0] - p[2, 0]) / 2)
    np.testing.assert_allclose(widths, [0.1048, 0.1083, 0.1107, 0.1124], rtol=0.01)


def test_vertical_actuator_lengthens_along_y_only():
    env = make("4")
    env.reset(seed=0)
    hold(env, 1.6, 30)
    p = env.unwrapped.sim.positions
    assert p[0, 1] - p[2, 1] == pytest.approx(1.25 * VOXEL, rel=0.02)
    assert p[1, 0] - p[0, 0] == pytest.approx(VOXEL, rel=0.1)


def test_ground_friction_slows_sliding_points_in_proportion_to_their_load():
    env = make("22222/22232")
    env.reset(seed=0)
    hold(env, 1.0, 20)
    sim = env.unwrapped.sim
    for body in sim._bodies:
        body.velocity = (1.0, float(body.velocity[1]))
    hold(env, 1.0, 1)
    slowed = sim.velocities[:, 0].mean()
    assert 0.0 < slowed < 0.98  # friction acts ...
    light = make("22222/22232", physics=replace(WalkerPhysics(), ground_friction=0.0))
    light.reset(seed=0)
    hold(light, 1.0, 20)
    for body in light.unwrapped.sim._bodies:
        body.velocity = (1.0, float(body.velocity[1]))
    hold(light, 1.0, 1)
    assert light.unwrapped.sim.velocities[:, 0].mean() > 0.99  # ... and only friction (and drag)


def test_self_collision_count_follows_evolution_gym():
    env = make("33333")  # five surface voxels from x = 0.1 to 0.6
    sim = env.unwrapped.sim
    assert sim.self_overlaps() == 0  # at rest, only neighbours touch
    tl, tr, br, bl = sim.mesh.voxel_corners[4]
    folded = sim.positions.copy()
    folded[[tr, br], 0] = 0.35  # the last voxel's right side folds back over the middle voxel
    sim.positions = folded
    assert sim.self_overlaps() == 2  # one pair, counted both ways as Evolution Gym does
    assert "overlaps itself" not in sim.instability()  # not more than the 5 surface voxels (but inside out)
    folded[[tr, br], 0] = 0.15  # ... and over the first three
    sim.positions = folded
    assert sim.self_overlaps() == 6
    assert "overlaps itself" in sim.instability()


def test_rigid_block_with_one_actuator_does_not_drift():
    for ratio in (0.6, 1.0, 1.6):
        env = make("11111/11111/11111/11111/11113")
        env.reset(seed=0)
        hold(env, ratio, 100)  # let the actuator reach its length
        start = com(env)
        total = hold(env, ratio, 390)
        assert np.abs(com(env) - start).max() < 1e-3, ratio
        assert abs(total) < 1e-3, ratio
    rigid = env.unwrapped.sim.positions[:4]  # a rigid voxel keeps its shape
    assert np.linalg.norm(rigid[1] - rigid[0]) == pytest.approx(VOXEL, rel=0.01)


def test_voxels_that_are_not_joined_collide_instead_of_overlapping():
    physics = WalkerPhysics()
    env = make("303/333")  # a U: the slot between the prongs is one voxel wide
    env.reset(seed=0)
    hold(env, 0.6, 100)  # the middle actuator would close the slot to 0.6 voxels
    p = env.unwrapped.sim.positions
    left = [i for i, (x, y) in enumerate(env.unwrapped.sim.mesh.points) if x == pytest.approx(0.2) and y > 0.25]
    right = [i for i, (x, y) in enumerate(env.unwrapped.sim.mesh.points) if x == pytest.approx(0.3) and y > 0.25]
    gaps = [np.linalg.norm(p[a] - p[b]) for a in left for b in right]
    # the prongs' points touch (without contact the slot would close to about 0.075 m) and stop there
    assert min(gaps) == pytest.approx(2 * physics.point_radius, abs=0.003)


def test_hand_made_gait_moves_the_way_evolution_gym_moves_it():
    """On Evolution Gym 2.0 this gait returns -0.28 and its mirror +1.09 (the body walks towards
    the leg it lifts while the bridge contracts); the uncalibrated v0 physics had both signs the
    other way round."""
    env = make(WALKER_BODY)
    env.reset(seed=0)
    backward = inchworm(env)
    env.reset(seed=0)
    forward = inchworm(env, mirrored=True)
    assert forward > 0.5
    assert backward < -0.1


def test_random_actions_on_random_bodies_stay_stable():
    rng = np.random.default_rng(0)
    for _ in range(5):
        env = make(gdabench.random_body(rng).text)
        env.reset(seed=0)
        for _ in range(200):
            obs, reward, terminated, truncated, info = env.step(rng.uniform(0.6, 1.6, env.action_space.shape))
            assert np.isfinite(obs).all() and np.isfinite(reward)
            assert "unstable" not in info


# -- rendering -------------------------------------------------------------------------------------
def test_rgb_array_frames_render_headless_and_save_as_gif():
    env = make(WALKER_BODY, render_mode="rgb_array")
    env.reset(seed=0)
    first = env.render()
    frames = [first]
    for _ in range(3):
        hold(env, 1.6, 5)
        frames.append(env.render())
    assert first.shape == (240, 480, 3) and first.dtype == np.uint8
    assert not np.array_equal(frames[0], frames[-1])  # the body moved on screen
    with Image.open(io.BytesIO(frames_to_gif(frames))) as gif:
        assert gif.n_frames == 4
    plain = make(WALKER_BODY)
    plain.reset(seed=0)
    assert plain.render() is None  # no render mode: nothing drawn


# -- open-loop controller ------------------------------------------------------------------------
class _ActuatorProbe(gymnasium.Env):
    """A non-physics env with the walker's interface: rewards the mean action, records actions."""

    metadata = {"render_modes": []}

    def __init__(self, cells: list[list[int]], steps: int = 7):
        self.actuator_voxels = np.array(cells)
        self.action_space = gymnasium.spaces.Box(0.6, 1.6, shape=(len(cells),), dtype=np.float64)
        self.observation_space = gymnasium.spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float64)
        self.steps, self.actions = steps, []

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.actions = []
        return np.zeros(1), {}

    def step(self, action):
        self.actions.append(np.array(action))
        return np.zeros(1), float(np.mean(action)), False, len(self.actions) >= self.steps, {}


def test_open_loop_plays_the_documented_sinusoid_through_the_gymnasium_api():
    cells = [[0, 0, 3], [0, 3, 4], [2, 1, 4]]
    probe = _ActuatorProbe(cells)
    ctrl = OpenLoop(
        period=10, amplitude=0.5, center=1.1, phase_per_column=0.7, phase_per_row=0.3, vertical_phase=1.0, trials=1
    )
    result = ctrl.evaluate(lambda: probe, seed=0)
    actions = np.array(probe.actions)
    assert actions.shape == (7, 3)
    t = np.arange(7)[:, None]
    phase = np.array([0.0, 0.7 * 3 + 1.0, 0.7 * 1 + 0.3 * 2 + 1.0])
    np.testing.assert_allclose(actions, np.clip(1.1 + 0.5 * np.sin(2 * math.pi * t / 10 - phase), 0.6, 1.6))
    assert result.reward == pytest.approx(actions.mean(axis=1).sum())
    assert result.info == {"env_steps": 7, "best_trial": 0}


def test_open_loop_needs_the_actuator_attribute():
    env = _ActuatorProbe([[0, 0, 3]])
    del env.actuator_voxels
    with pytest.raises(ConfigError, match="actuator_voxels"):
        OpenLoop().evaluate(lambda: env, seed=0)


@pytest.mark.parametrize(
    "params", [{"period": 0}, {"amplitude": -1}, {"trials": 0}, {"trials": 1.5}, {"period_range": (5, 2)}]
)
def test_open_loop_rejects_bad_parameters(params):
    with pytest.raises(ConfigError):
        OpenLoop(**params)


def test_open_loop_trials_keep_the_best_pattern_and_follow_the_seed():
    one = OpenLoop(trials=1).evaluate(lambda: make(WALKER_BODY), seed=3)
    many = OpenLoop(trials=3).evaluate(lambda: make(WALKER_BODY), seed=3)
    again = OpenLoop(trials=3).evaluate(lambda: make(WALKER_BODY), seed=3)
    assert many.reward >= one.reward
    assert many == again
    assert many.info["env_steps"] == 1500
    patterns = OpenLoop(trials=3).patterns(3)
    assert patterns[0] == OpenLoop(trials=1).pattern and len(set(patterns)) == 3
    assert OpenLoop(trials=3).patterns(4)[1] != patterns[1]


def test_open_loop_is_registered_and_scores_a_body_on_the_walker():
    ctrl = make_controller("open-loop", trials=1)
    result = ctrl.evaluate(lambda: make(WALKER_BODY), seed=0)
    env = make(WALKER_BODY)
    env.reset(seed=0)
    pattern: Pattern = ctrl.pattern
    phases = pattern.phases(env.unwrapped.actuator_voxels)
    manual = sum(env.step(np.clip(pattern.action(phases, t), 0.6, 1.6))[1] for t in range(500))
    assert result.reward == pytest.approx(manual)
    assert result.info["env_steps"] == 500


# -- the gdabench environment ----------------------------------------------------------------------
def test_walker_env_scores_bodies_with_the_controller_it_is_given():
    env = make_env("walker", shape=(3, 5), engine="pymunk")
    body = Body.from_text(WALKER_BODY)
    assert env.requires_controller and env.deterministic and env.invalid_reason(body) is None
    assert env.invalid_reason(Body.from_text("33333/40004")) is not None  # wrong shape
    result = env.evaluate(body, seed=0, controller=OpenLoop())
    assert isinstance(result, Evaluation)
    assert result.reward == OpenLoop().evaluate(lambda: make(WALKER_BODY), seed=0).reward
    assert result.info["env_steps"] == 4 * 500  # the default tries 4 patterns
    with pytest.raises(ConfigError, match="needs a controller"):
        env.evaluate(body, seed=0)


def test_walker_env_renders_the_best_episode():
    env = make_env("walker", shape=(3, 5))
    frames = env.render_frames(Body.from_text(WALKER_BODY), seed=0, controller=OpenLoop(trials=2))
    assert len(frames) == 126  # 501 states (reset + 500 steps), every 4th
    assert frames[0].shape == (240, 480, 3) and frames[0].dtype == np.uint8


def test_compare_runs_the_walker_with_open_loop(tmp_path):
    experiment = gdabench.Experiment(
        designers=(gdabench.PluginChoice("random"),),
        envs=gdabench.PluginChoice("walker", {"engine": "pymunk"}),
        controller=gdabench.PluginChoice("open-loop", {"trials": 1}),
        shape=(3, 3),
        population=2,
        budget=4,
    )
    run = run_experiment(experiment, tmp_path / "run")
    rows = run.load_evaluations()
    ok = rows[rows["status"] == "ok"]
    assert len(ok) == 4 and ok["reward"].notna().all()
    assert set(ok["env_steps"]) == {500}
    assert set(rows["env_version"]) == {"gdabench/Walker-v1"}  # old runs stay interpretable


def test_jobs_through_the_command_line_give_the_same_walker_table(tmp_path):
    from typer.testing import CliRunner

    from gdabench.cli import app

    from support.processes import TIMING

    args = [
        "compare",
        "-d",
        "random,ga",
        "--env",
        "walker",
        "--controller",
        "open-loop",
        "-C",
        "trials=1",
        "--shape",
        "3x3",
        "--population",
        "3",
        "--budget",
        "6",
        "--seeds",
        "0,1",
        "-q",
        "--no-report",
    ]
    tables = []
    for jobs in ("1", "2"):
        result = CliRunner().invoke(app, [*args, "--jobs", jobs, "--out", str(tmp_path / jobs)])
        assert result.exit_code == 0, result.output
        rows = gdabench.RunDirectory.open(tmp_path / jobs).load_evaluations()
        tables.append(rows.drop(columns=TIMING))
    assert len(tables[0]) == 24 and tables[0]["reward"].notna().all()
    pd.testing.assert_frame_equal(tables[0], tables[1])


def test_physics_defaults_are_one_frozen_dataclass():
    physics = WalkerPhysics()
    with pytest.raises(dataclasses.FrozenInstanceError):
        physics.ground_friction = 2.0  # type: ignore[misc]
    assert replace(physics, ground_friction=2.0).ground_friction == 2.0
    assert physics.voxel_size == VOXEL
