"""Evolution Gym's tasks on the voxel engine (``voxel/<task>``): parity with Evolution Gym 2.0, per task.

Parity numbers come from ``tests/fixtures/tasks/<task>.npz``, recorded from Evolution Gym 2.0's own
Gymnasium environments with ``benchmarks/compare/evogym_record.py tests/fixtures/tasks --tasks`` (CI never needs
Evolution Gym): for every task and two bodies, the first steps of an episode under a fixed gait.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from gdabench.envs.tasks import CATALOG, task
from gdabench.envs.tasks.sense import Frame
from gdabench.envs.tasks.shape import hull_area
from gdabench.envs.voxel.batch import TaskBatch

FIXTURES = Path(__file__).parent / "fixtures" / "tasks"
RECORDINGS = sorted({"/".join(k.split("/")[:2]) for f in FIXTURES.glob("*.npz") for k in np.load(f)})
#: the bar: agreement with Evolution Gym over the first ten env steps, in double precision
TOLERANCE, STEPS = 1e-6, 10


def object_points(batch: TaskBatch, name: str) -> np.ndarray:
    """Object ``name``'s points in environment 0, as Evolution Gym's ``object_pos_at_time`` gives them."""
    if name == "robot":
        start = batch.tables.robot_start
        return batch.state.pos[0, start:start + batch.robot_points[0]]
    return batch.frame().positions(name)[0]


def replay(key: str) -> dict[str, list[float]]:
    """Play recording ``key`` on the voxel engine; the largest gaps to Evolution Gym's numbers, per step."""
    task = key.split("/")[0]
    data = {k.removeprefix(key + "/"): v for k, v in np.load(FIXTURES / f"{task}.npz").items()
            if k.startswith(key + "/")}
    batch = TaskBatch(task, [str(data["body"])])
    batch.seed([0])
    size = batch.obs_sizes[0]
    setup = {k: data[k].tolist() for k in ("offset", "goals") if k in data}  # Evolution Gym's random draw
    obs = batch.reset(options=setup)[0, :size]
    gaps = {"start": [float(np.abs(obs - data["obs0"]).max())] + [
        float(np.abs(object_points(batch, k.removeprefix("pos0/")) - v).max())
        for k, v in data.items() if k.startswith("pos0/")]}
    gaps |= {"pos": [], "obs": [], "reward": [], "done": []}
    for t, action in enumerate(data["actions"]):
        obs, reward, terminated, _ = batch.step(action[None])
        gaps["pos"].append(max(float(np.abs(object_points(batch, str(m)) - data[f"pos/{m}"][t]).max())
                               for m in data["moving"]))
        gaps["obs"].append(float(np.abs(obs[0, :size] - data["obs"][t]).max()))
        gaps["reward"].append(abs(float(reward[0]) - float(data["reward"][t])))
        gaps["done"].append(float(bool(terminated[0]) != bool(data["done"][t])))
    return gaps


@pytest.mark.parametrize("key", RECORDINGS)
def test_the_first_ten_steps_match_evolution_gym_to_1e6(key):
    gaps = replay(key)
    assert max(gaps["start"]) <= TOLERANCE, "the first observation, or where objects start"
    for what in ("pos", "obs", "reward", "done"):
        assert max(gaps[what][:STEPS]) <= TOLERANCE, what


def test_the_fixture_records_two_bodies_of_every_task_defined_here():
    recorded = {key.split("/")[0] for key in RECORDINGS}
    defined = set()
    for name in CATALOG:
        try:
            task(name)
        except KeyError:
            continue
        defined.add(name)
    assert recorded == defined
    assert all(f"{name}/1" in RECORDINGS for name in recorded)


WALKER = "11111/13331/40004/40004/40004"


def setup_of(env) -> tuple:
    """The random set-up an environment drew: Catcher-v0's offset and package, BidirectionalWalker-v0's goals."""
    task = env.unwrapped.batch.task
    if hasattr(task, "offset"):
        return tuple(task.offset[0]), tuple(object_points(env.unwrapped.batch, "package").ravel())
    return tuple(task.goals[0, : task.n_goals[0]])


@pytest.mark.parametrize("name", ["Catcher-v0", "BidirectionalWalker-v0"])
def test_reset_seed_draws_the_random_setup_the_same_seed_the_same(name):
    import gymnasium

    env = gymnasium.make(f"voxel/{name}", body=WALKER)
    drawn = []
    for seed in (0, 0, 1, 2, 3):
        env.reset(seed=seed)
        drawn.append(setup_of(env))
    assert drawn[0] == drawn[1]
    assert len(set(drawn[1:])) == 4
    vec = gymnasium.make_vec(f"voxel/{name}", num_envs=3, vectorization_mode="vector_entry_point", body=WALKER)
    first, _ = vec.reset(seed=7)
    again, _ = vec.reset(seed=7)
    np.testing.assert_array_equal(first, again)
    assert len({tuple(row) for row in first}) == 3  # each environment its own draw


def test_reset_options_impose_a_setup_and_reject_what_a_task_cannot_take():
    import gymnasium

    catcher = gymnasium.make("voxel/Catcher-v0", body=WALKER)
    catcher.reset(seed=0, options={"offset": (-6, 5)})
    # Evolution Gym puts the package at voxel (21 + dx, 41 + dy): its bottom-left point there
    assert object_points(catcher.unwrapped.batch, "package").min(axis=0) == pytest.approx([1.5, 4.6])
    walker = gymnasium.make("voxel/BidirectionalWalker-v0", body=WALKER)
    obs, _ = walker.reset(options={"goals": [20, 49]})
    assert obs[-2] == pytest.approx(2.0)
    with pytest.raises(ValueError, match=r"offset must be two whole numbers \(dx, dy\) in -6..4 and 0..5"):
        catcher.reset(options={"offset": (5, 0)})
    with pytest.raises(ValueError, match="goals must be a non-empty list"):
        walker.reset(options={"goals": []})
    with pytest.raises(ValueError, match=r"Walker-v0 has no reset option 'goals' \(its options: none\)"):
        gymnasium.make("voxel/Walker-v0", body=WALKER).reset(options={"goals": [30]})


def test_bidirectional_walker_meets_goals_as_evolution_gym_does():
    batch = TaskBatch("BidirectionalWalker-v0", [WALKER])
    batch.reset(options={"goals": [36, 34, 45, 35]})  # the robot's centre starts at x 3.55 m
    x1 = float(batch.frame().pos[0, batch.tables.robot_start:].mean(axis=0)[0])
    obs, reward, done, _ = batch.step(np.ones((1, 9)))
    x2 = float(batch.frame().pos[0, batch.tables.robot_start:].mean(axis=0)[0])
    # the first two goals are met at once: the step is rewarded for the third, the observation still shows
    # the first (it is made before the goals move on), the next one the third
    assert batch.task.current[0] == 2
    assert reward[0] == pytest.approx(abs(4.5 - x1) - abs(4.5 - x2), abs=1e-12)
    assert obs[0, 62:65].tolist() == pytest.approx([0, 3.6, 3.6 - x2])
    obs, _, _, _ = batch.step(np.ones((1, 9)))
    assert obs[0, 62:64].tolist() == pytest.approx([2, 4.5])
    assert not done[0]


def test_an_autoreset_episode_starts_at_its_first_goal():
    import gymnasium

    vec = gymnasium.make_vec("voxel/BidirectionalWalker-v0", num_envs=1, vectorization_mode="vector_entry_point",
                             body=WALKER, max_episode_steps=1)
    task = vec.unwrapped.batch.task
    for seed in range(40):  # a seed whose second episode's first goal is met where the robot starts
        vec.reset(seed=seed)
        vec.step(np.ones((1, 9)))
        obs, reward, _, _, _ = vec.step(np.ones((1, 9)))  # the autoreset
        if abs(task.goals[0, 0] * 0.1 - 3.55) < 0.2:
            break
    else:
        pytest.fail("no seed drew a first goal by the robot")
    assert task.current[0] == 0 and obs[0, 62] == 0 and reward[0] == 0


def one_robot(points: np.ndarray, init: np.ndarray | None = None) -> Frame:
    """A frame of one environment whose robot is ``points`` (``(P, 2)``, metres), started at ``init``."""
    pos = np.asarray(points, dtype=np.float64)[None]
    return Frame(pos=pos, vel=np.zeros_like(pos), init=pos if init is None else np.asarray(init)[None],
                 robot_start=0, robot_count=np.array([len(points)]), objects={}, static={})


def test_the_shape_tasks_hull_keeps_evolution_gyms_choice_among_points_in_line():
    # a 1 x 2 body's six points in two orders: Evolution Gym's march (ShapeBase.jarvis_march, then
    # convex_poly_area) keeps different points of the edges in line, and its areas differ in the last bit
    points = np.array([[0.7, 0.2], [0.7999999999999999, 0.30000000000000004], [0.7999999999999999, 0.2],
                       [0.7, 0.1], [0.7999999999999999, 0.1], [0.7, 0.30000000000000004]])
    assert hull_area(one_robot(points), "robot")[0] == 0.019999999999999997
    assert hull_area(one_robot(points[[3, 4, 2, 1, 5, 0]]), "robot")[0] == 0.020000000000000004


def test_the_shape_tasks_hull_where_evolution_gyms_march_never_closes():
    # Evolution Gym's march walks back and forth along the bottom row of these 1 x 3 grid points and raises
    # IndexError; the true hull's area stands in
    points = np.array([[1.0, 0.2], [0.7999999999999999, 0.2], [0.7, 0.2], [0.7999999999999999, 0.1], [0.9, 0.2],
                       [0.9, 0.1], [0.7, 0.1], [1.0, 0.1]])
    assert hull_area(one_robot(points), "robot")[0] == pytest.approx(0.03, abs=1e-15)


@pytest.mark.parametrize("turn", [0.4, -0.4])
def test_flipper_counts_its_turns_on_over_whole_turns(turn):
    start = np.array([[x, y] for y in (0.1, 0.2) for x in (3.0, 3.1, 3.2)])  # none at the centre
    centre = start.mean(axis=0)

    def turned(angle: float) -> Frame:
        c, s = np.cos(angle), np.sin(angle)
        return one_robot(centre + (start - centre) @ np.array([[c, s], [-s, c]]), init=start)

    flipper = task("Flipper-v0")(np.array([len(start)]))
    flipper.reset(turned(0.0), np.array([True]), [])
    total = 0.0
    for k in range(40):  # 16 radians: two whole turns and a half
        reward, done = flipper.reward(turned(k * turn), turned((k + 1) * turn), np.array([False]))
        total += reward[0]
        assert not done[0]
    # to within the orientation's noise near a whole turn (Evolution Gym clamps a cosine above 1 to 0.99999)
    assert total == pytest.approx(40 * turn, abs=0.01)
    assert flipper.flips[0] == (2 if turn > 0 else -3)
    flipper.reset(turned(0.0), np.array([True]), [])
    assert flipper.flips[0] == 0


# -- how episodes end: the fixtures' first steps never reach an end, so each is checked on a step set up to --
def moved(task: str, centre: tuple[float | None, float | None] = (None, None), turn: float = 0.0):
    """Task ``task``'s reward and end for a step that turns its robot by ``turn`` (radians, counter-clockwise)
    about its centre and puts that centre at ``centre`` (metres; None keeps a coordinate)."""
    batch = TaskBatch(task, [WALKER])
    before = batch.frame()
    start, count = batch.tables.robot_start, batch.robot_points[0]
    pos = before.pos.copy()
    points = pos[0, start:start + count]
    c = points.mean(axis=0)
    to = np.array([c[k] if centre[k] is None else centre[k] for k in (0, 1)])
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    pos[0, start:start + count] = (points - c) @ rotation.T + to
    reward, done = batch.task.reward(before, replace(before, pos=pos), np.zeros(1, dtype=bool))
    return float(reward[0]), bool(done[0]), to - c


#: (task, finishing line or None, its axis, its bonus)
LINES = [("UpStepper-v0", 6.9, 0, 2.0), ("DownStepper-v0", 7.4, 0, 2.0), ("ObstacleTraverser-v0", 7.9, 0, 2.0),
         ("ObstacleTraverser-v1", 5.9, 0, 2.0), ("Traverser-v0", 5.9, 0, 2.0), ("Hurdler-v0", None, 0, 0.0),
         ("PlatformJumper-v0", None, 0, 0.0), ("GapJumper-v0", None, 0, 0.0), ("Climber-v0", 8.6, 1, 1.0),
         ("Climber-v1", 6.5, 1, 1.0), ("Climber-v2", None, 1, 0.0)]


@pytest.mark.parametrize("task,line,axis,bonus", LINES)
def test_crossing_the_finishing_line_ends_the_episode_with_its_bonus(task, line, axis, bonus):
    for at, past in ((line or 9.0) - 0.01, False), ((line or 9.0) + 0.01, line is not None):
        centre = (at, None) if axis == 0 else (None, at)
        reward, done, shift = moved(task, centre)
        gain = shift[axis] + (0.2 * shift[0] if task == "Climber-v2" else 0.0)
        assert done == past
        assert reward == pytest.approx(gain + (bonus if past else 0.0), abs=1e-9)


@pytest.mark.parametrize("task", ["PlatformJumper-v0", "GapJumper-v0"])
def test_falling_below_the_lowest_platform_ends_the_episode_with_a_penalty(task):
    assert moved(task, (None, 0.41))[:2] == (pytest.approx(0.0, abs=1e-9), False)
    assert moved(task, (None, 0.39))[:2] == (pytest.approx(-3.0, abs=1e-9), True)


TURNERS = {"UpStepper-v0", "DownStepper-v0", "ObstacleTraverser-v0", "Hurdler-v0", "PlatformJumper-v0"}


@pytest.mark.parametrize("task", [line[0] for line in LINES])
def test_turning_over_ends_the_terrain_tasks_that_check_it_with_a_penalty(task):
    upside_down = moved(task, turn=np.pi)[:2]
    assert upside_down == ((pytest.approx(-3.0, abs=1e-9), True) if task in TURNERS else
                           (pytest.approx(0.0, abs=1e-9), False))
    # UpStepper-v0's band is pi / 12 wider on either side: 80 degrees ends it, no other
    assert moved(task, turn=np.radians(80))[1] == (task == "UpStepper-v0")
    assert moved(task, turn=np.radians(280))[1] == (task == "UpStepper-v0")
    assert not moved(task, turn=np.radians(70))[1]


# -- every task as a Gymnasium environment, deterministic in any batch ------------------------------------
OTHERS = ["32423/22443/04213/01412/31233", "33333/40004/40004/44444/40004", "00000/00000/44444/43434/44444"]


@pytest.mark.parametrize("name", list(CATALOG))
def test_every_task_passes_gymnasiums_checker_and_renders(name):
    import gymnasium
    from gymnasium.utils.env_checker import check_env

    env = gymnasium.make(f"voxel/{name}", body=WALKER, render_mode="rgb_array")
    check_env(env.unwrapped, skip_render_check=True)
    env.reset(seed=1)
    assert env.render().shape == (240, 480, 3)
    assert env.spec.max_episode_steps == CATALOG[name].max_episode_steps


def _trajectory(name: str, bodies: list[str], steps: int = 8) -> np.ndarray:
    batch = TaskBatch(name, bodies)
    batch.seed(list(range(len(bodies))))
    batch.reset()
    ours, others = np.random.default_rng(3), np.random.default_rng(4)
    width, n_act, size = batch.tables.max_actuators, int(batch.tables.n_act[0]), batch.obs_sizes[0]
    out = []
    for _ in range(steps):
        actions = others.uniform(0.6, 1.6, size=(len(bodies), width))
        actions[0, :n_act] = ours.uniform(0.6, 1.6, size=n_act)  # the same in every batch
        obs, reward, *_ = batch.step(actions)
        out.append(np.concatenate([obs[0, :size], [reward[0]], batch.state.pos[0, : batch.tables.n_points[0]].ravel()]))
    return np.array(out)


@pytest.mark.parametrize("name", list(CATALOG))
def test_a_body_plays_a_task_bit_for_bit_the_same_alone_in_a_mixed_batch_and_on_any_thread_count(name):
    import numba

    alone = _trajectory(name, [WALKER])
    mixed = _trajectory(name, [WALKER, *OTHERS])
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        parallel = _trajectory(name, [WALKER] + OTHERS * 3)  # enough environments for the parallel kernel
    finally:
        numba.set_num_threads(threads)
    assert np.array_equal(alone, mixed) and np.array_equal(alone, parallel)
    assert np.isfinite(alone).all()


# -- what a Gymnasium user can get wrong: one clear error, as the single environment gives ------------------
def vector(num_envs=4, **kwargs):
    import gymnasium

    return gymnasium.make_vec("voxel/Walker-v0", num_envs=num_envs, vectorization_mode="vector_entry_point",
                              body=WALKER, **kwargs)


@pytest.mark.parametrize("actions, message", [
    (np.full((4, 9), np.nan), "must be finite numbers"),
    (np.full((4, 9), np.inf), "must be finite numbers"),
    (np.ones((4, 3)), r"must have shape \(4, 9\)"),
    (np.ones((4, 100)), r"must have shape \(4, 9\)"),
    (np.ones((3, 9)), r"must have shape \(4, 9\)"),
    ([["a"] * 9] * 4, "must be numbers"),
])
def test_the_vector_env_refuses_actions_the_single_env_refuses(actions, message):
    envs = vector()
    envs.reset(seed=0)
    with pytest.raises(ValueError, match=message) as info:
        envs.step(actions)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("num_envs", [0, -1, 2.5, "4", True])
def test_the_vector_env_refuses_a_number_of_environments_that_is_not_one_or_more(num_envs):
    with pytest.raises(ValueError, match="num_envs must be a whole number of at least 1"):
        vector(num_envs=num_envs)


def test_a_gymnasium_env_without_a_body_says_what_it_needs():
    import gymnasium

    with pytest.raises(TypeError, match=r"voxel/Carrier-v0 needs a body: gymnasium.make\('voxel/Carrier-v0', body="):
        gymnasium.make("voxel/Carrier-v0")
    with pytest.raises(TypeError, match="gdabench/Walker-v2 needs a body|voxel/Walker-v0 needs a body"):
        gymnasium.make("gdabench/Walker-v2")
    with pytest.raises(TypeError, match="gdabench/Walker-v1 needs a body"):
        gymnasium.make("gdabench/Walker-v1")


def test_the_vector_env_marks_unstable_environments_in_info():
    import gymnasium

    envs = gymnasium.make_vec("voxel/Walker-v0", num_envs=2, vectorization_mode="vector_entry_point",
                              body="11111/44444/40404/40404/40404")
    envs.reset(seed=0)
    columns = np.array([0, 1, 2, 3, 4, 0, 2, 4, 0, 2, 4, 0, 2, 4])  # the fixture's unstable gait (step 63)
    for t in range(80):
        wave = 1.1 + 0.5 * np.sin(2 * np.pi * t / 40 - columns - np.pi / 2)
        _, reward, terminated, _, info = envs.step(np.stack([wave, np.ones(14)]))
        if terminated[0]:
            break
    assert t == 62 and reward[0] < -2.9
    assert info["unstable"].tolist() == [True, False] and info["_unstable"].tolist() == [True, False]


def test_a_small_vector_env_steps_on_one_thread_by_default_and_the_user_can_choose():
    assert vector(num_envs=8).unwrapped.threads == 1
    assert vector(num_envs=8, threads=2).unwrapped.threads == 2
    with pytest.raises(ValueError, match="threads must be a whole number of at least 1"):
        vector(threads=0)
