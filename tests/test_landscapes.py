"""The analytic landscapes: two-peaks, target and nk (issue 10)."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gdabench import ConfigError, Experiment, PluginChoice, make_env, registry
from gdabench.body import Body, is_connected, random_body
from gdabench.cli import app
from gdabench.envs import nk_optimum
from gdabench.envs.target import DEFAULT_TARGET
from gdabench.errors import InvalidBodyError
from gdabench.running.runner import compare
from gdabench.testing import check_environment

# the peaks exactly as issue 10 states them (rows top to bottom, Evolution Gym codes)
ISSUE_P1 = [0, 4, 0, 4, 4, 1, 1, 4, 3, 3, 2, 0, 0, 0, 2, 2, 0, 0, 0, 3, 4, 4, 4, 4, 3]
ISSUE_P2 = [0, 3, 2, 0, 0, 1, 3, 4, 0, 0, 3, 4, 3, 0, 1, 3, 2, 2, 0, 1, 0, 0, 4, 1, 1]
DISCONNECTED = Body.from_text("44000/00000/00000/00000/00044")
NO_ACTUATOR = Body.from_text("11111/11111/11111/11111/11111")


def body_of(flat: list[int], shape=(5, 5)) -> Body:
    return Body(np.array(flat).reshape(shape))


# -- registration and validity -------------------------------------------------------------------
def test_landscapes_are_registered_builtins():
    names = registry().names("environment")
    assert {"two-peaks", "target", "nk"} <= set(names)
    for name in ("two-peaks", "target", "nk"):
        assert registry().get("environment", name).distribution == "gdabench"


@pytest.mark.parametrize("name", ["two-peaks", "target", "nk"])
@pytest.mark.parametrize("bad", [DISCONNECTED, NO_ACTUATOR, Body.from_text("444/444/444")])
def test_invalid_bodies_are_refused_not_scored(name, bad):
    env = make_env(name)
    assert env.invalid_reason(bad) is not None
    with pytest.raises(InvalidBodyError, match=name):
        env.evaluate(bad, seed=0)


# -- two-peaks -----------------------------------------------------------------------------------
def two_peaks_formula(x: np.ndarray) -> float:
    x = np.asarray(x, dtype=float).ravel()
    return max(100 - 10 * math.dist(x, ISSUE_P1), 50 - 3 * math.dist(x, ISSUE_P2))


def test_two_peaks_scores_100_at_p1_and_50_at_p2():
    env = make_env("two-peaks")
    assert env.evaluate(body_of(ISSUE_P1), seed=0) == 100.0
    assert env.evaluate(body_of(ISSUE_P2), seed=0) == 50.0
    assert env.optimum == 100.0


def test_two_peaks_matches_the_formula_on_random_bodies():
    env = make_env("two-peaks")
    rng = np.random.default_rng(7)
    bodies = [random_body(rng) for _ in range(200)]
    # also bodies near each peak, where the other branch of the max matters
    for peak in (ISSUE_P1, ISSUE_P2):
        for _ in range(50):
            x = np.array(peak)
            x[rng.integers(25)] = rng.integers(5)
            if Body(x.reshape(5, 5)).is_valid():
                bodies.append(Body(x.reshape(5, 5)))
    rewards = [env.evaluate(b, seed=0) for b in bodies]
    assert rewards == pytest.approx([two_peaks_formula(b.voxels) for b in bodies], abs=1e-12)
    assert max(rewards) <= 100.0
    # both branches of the max were exercised: near p1 (>= 60) and on the wide slope of p2 (38-50)
    assert any(60.0 <= r < 100.0 for r in rewards) and any(38.0 <= r < 50.0 for r in rewards)


def test_two_peaks_refuses_other_shapes():
    with pytest.raises(ConfigError, match="5x5 bodies only.*4x6"):
        make_env("two-peaks", shape=(4, 6))


# -- target --------------------------------------------------------------------------------------
def test_default_target_is_a_valid_non_uniform_body_scoring_100():
    env = make_env("target")
    assert DEFAULT_TARGET.is_valid()
    assert len(np.unique(DEFAULT_TARGET.voxels)) == 5, "the default target uses every material"
    assert env.evaluate(DEFAULT_TARGET, seed=0) == 100.0
    assert env.optimum == 100.0


def test_target_reward_counts_matching_voxels():
    env = make_env("target")
    x = np.array(DEFAULT_TARGET.voxels)
    x[1, 1] = 4  # horizontal -> vertical actuator: wrong material, right class
    x[2, 2] = 2  # hole filled: wrong class
    near = Body(x)
    assert env.evaluate(near, seed=0) == pytest.approx(100 * 23 / 25)
    partial = make_env("target", class_credit=0.5)
    assert partial.evaluate(near, seed=0) == pytest.approx(100 * 23.5 / 25)
    assert partial.evaluate(DEFAULT_TARGET, seed=0) == 100.0


def test_target_only_the_target_scores_100():
    env = make_env("target", class_credit=0.9)
    rng = np.random.default_rng(3)
    assert all(env.evaluate(b, seed=0) < 100.0 for b in (random_body(rng) for _ in range(300)))


def test_target_from_text_and_from_file_for_any_shape(tmp_path):
    text = "0330/1441/1001"
    by_text = make_env("target", shape=(3, 4), target=text)
    path = tmp_path / "target.txt"
    path.write_text("0330\n1441\n1001\n")
    by_file = make_env("target", shape=(3, 4), target=str(path))
    goal = Body.from_text(text)
    assert by_text.evaluate(goal, seed=0) == by_file.evaluate(goal, seed=0) == 100.0
    other = Body.from_text("0330/1441/1011")
    assert by_file.evaluate(other, seed=0) == pytest.approx(100 * 11 / 12)


@pytest.mark.parametrize(
    "params, message",
    [
        (
            {"shape": (4, 4), "target": "11111/13241/14031/20002/40004"},
            "target .* is 5x5 but bodies are 4x4; give target=",
        ),
        ({"target": "11111/00000/11111/11111/11113"}, "not a valid body \\(voxels not connected\\)"),
        ({"target": "11111/11111/11111/11111/11111"}, "not a valid body \\(no actuator\\)"),
        ({"target": "no-such-file.txt"}, "nor is it an existing file"),
        ({"class_credit": 1.5}, "class_credit must be a number between 0 and 1"),
        ({"class_credit": "x"}, "class_credit"),
    ],
)
def test_target_bad_parameters(params, message):
    with pytest.raises(ConfigError, match=message):
        make_env("target", **params)


# -- nk ------------------------------------------------------------------------------------------
def test_nk_is_deterministic_per_table_seed():
    rng = np.random.default_rng(0)
    bodies = [random_body(rng) for _ in range(50)]
    a, b, c = make_env("nk", k=2, table_seed=5), make_env("nk", k=2, table_seed=5), make_env("nk", k=2, table_seed=6)
    ra = [a.evaluate(x, seed=1) for x in bodies]
    assert ra == [b.evaluate(x, seed=99) for x in bodies]  # the run's seed does not matter
    assert ra != pytest.approx([c.evaluate(x, seed=1) for x in bodies])
    assert a.optimum == b.optimum != c.optimum
    assert all(0.0 <= r < 100.0 for r in ra)


@pytest.mark.parametrize("k", [0, 1, 3])
def test_nk_voxel_depends_on_itself_and_the_k_before_it(k):
    env = make_env("nk", k=k, table_seed=2)
    rng = np.random.default_rng(k)
    base = np.array(random_body(rng).voxels)
    for j in rng.choice(25, size=6, replace=False):
        changed = base.copy()
        changed.flat[j] = (changed.flat[j] + 1 + rng.integers(4)) % 5
        moved = np.flatnonzero(env.contributions(changed) != env.contributions(base))
        assert set(moved) == set(range(j, min(j + k + 1, 25)))


def all_bodies(shape: tuple[int, int]) -> np.ndarray:
    n = shape[0] * shape[1]
    digits = (np.arange(5**n)[:, None] // 5 ** np.arange(n - 1, -1, -1)) % 5
    return digits.reshape((-1, *shape)).astype(np.int8)


def valid_mask(bodies: np.ndarray) -> np.ndarray:
    """Validity of every body, with connectivity looked up per occupancy pattern."""
    n = bodies.shape[1] * bodies.shape[2]
    flat = bodies.reshape(len(bodies), n)
    occupancy = (flat != 0).astype(np.int64) @ (1 << np.arange(n))
    connected = np.array(
        [m > 0 and is_connected(((m >> np.arange(n)) & 1).reshape(bodies.shape[1:])) for m in range(1 << n)]
    )
    return connected[occupancy] & ((flat == 3) | (flat == 4)).any(axis=1)


@pytest.mark.parametrize(
    "shape, ks",
    [((2, 3), (0, 1, 2, 5)), ((3, 2), (1, 3)), ((1, 6), (0, 1, 2)), ((6, 1), (2,)), ((2, 4), (1, 4)), ((4, 2), (2,))],
)
def test_nk_optimum_is_the_best_valid_body_by_brute_force(shape, ks):
    bodies = all_bodies(shape)
    valid = valid_mask(bodies)
    free_differs = 0
    for k in ks:
        for table_seed in range(4):
            env = make_env("nk", shape=shape, k=k, table_seed=table_seed)
            rewards = env.score_batch(bodies)
            best_valid = rewards[valid].max()
            assert env.optimum == pytest.approx(best_valid, abs=1e-9)
            assert env.optimum_body.is_valid() and env.evaluate(env.optimum_body, seed=0) == env.optimum
            assert env.upper_bound == pytest.approx(rewards.max(), abs=1e-9)
            # the validity-aware DP on its own, whichever path the environment took
            codes, total = nk_optimum.best_body(shape, k, env.table, valid=True)
            assert Body(codes).is_valid() and 100 * total / codes.size == pytest.approx(best_valid, abs=1e-9)
            free_differs += rewards.max() > best_valid + 1e-9
    if shape in ((1, 6), (2, 3)):
        assert free_differs, "these cases include tables whose unconstrained best body is invalid"


def test_nk_optimum_on_3x3_by_brute_force():
    bodies = all_bodies((3, 3))
    valid = valid_mask(bodies)
    env = make_env("nk", shape=(3, 3), k=2, table_seed=11)
    assert env.optimum == pytest.approx(env.score_batch(bodies)[valid].max(), abs=1e-9)


def greedy_ascent(env, start: Body) -> float:
    """Best-improvement hill climbing over valid single-voxel changes."""
    x, current = np.array(start.voxels), env.evaluate(start, seed=0)
    while True:
        neighbours = []
        for i in range(x.size):
            for code in range(5):
                if code != x.flat[i]:
                    y = x.copy()
                    y.flat[i] = code
                    if Body(y).is_valid():
                        neighbours.append(y)
        rewards = env.score_batch(np.array(neighbours))
        best = int(np.argmax(rewards))
        if rewards[best] <= current:
            return current
        x, current = neighbours[best], float(rewards[best])


def test_nk_k0_is_smooth_and_larger_k_rugged():
    rng = np.random.default_rng(1)
    for table_seed in range(3):
        smooth = make_env("nk", k=0, table_seed=table_seed)
        assert smooth.upper_bound == smooth.optimum  # its unconstrained best is valid (docs/environments/nk.md)
        assert all(greedy_ascent(smooth, random_body(rng)) == smooth.optimum for _ in range(5))
    rugged = make_env("nk", k=3, table_seed=0)
    peaks = {round(greedy_ascent(rugged, random_body(rng)), 9) for _ in range(8)}
    assert len(peaks) >= 4 and max(peaks) < rugged.optimum - 1e-9


def test_nk_optimum_is_unknown_when_too_costly():
    env = make_env("nk", shape=(5, 5), k=9, table_seed=0)
    assert env.optimum is None and env.upper_bound is None
    assert 0 < env.evaluate(random_body(np.random.default_rng(0)), seed=0) < 100


@pytest.mark.parametrize(
    "params, message",
    [
        ({"k": -1}, "k must be an integer between 0 and 24, got -1"),
        ({"k": 25}, "between 0 and 24"),
        ({"k": 1.5}, "k must be an integer"),
        ({"k": True}, "k must be an integer"),
        ({"table_seed": -3}, "table_seed must be an integer at least 0"),
        ({"shape": (2, 2), "k": 4}, "between 0 and 3"),
    ],
)
def test_nk_bad_parameters(params, message):
    with pytest.raises(ConfigError, match=message):
        make_env("nk", **params)


# -- through the harness -------------------------------------------------------------------------
@pytest.mark.parametrize(
    "env, extra, message",
    [
        ("two-peaks", ["--shape", "4x4"], "two-peaks is defined for 5x5 bodies only"),
        ("nk[k=-2]", [], "nk: k must be an integer"),
        ("nk[K=2]", [], "has no parameter 'K'"),
        ("target[target=12x]", [], "target text: malformed body text"),
        ("target[class_credit=2]", [], "class_credit must be a number between 0 and 1"),
    ],
)
def test_cli_reports_bad_landscape_parameters_in_one_line(env, extra, message, tmp_path):
    result = CliRunner().invoke(
        app, ["compare", "--designers", "ga", "--env", env, "-q", "-o", str(tmp_path / "run"), *extra]
    )
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0]
    assert not (tmp_path / "run").exists()


def test_summary_reports_evaluations_to_the_nk_optimum(tmp_path):
    """On a 2x3 body (15,625 bodies) the GA finds the exact optimum, and the summary says when."""
    experiment = Experiment(
        designers=(PluginChoice("ga"),),
        envs=PluginChoice("nk", {"k": 1}, "nk[k=1]"),
        shape=(2, 3),
        population=10,
        budget=300,
        seeds=(0, 1),
    )
    run = compare(experiment, tmp_path / "run")
    optimum = make_env("nk", shape=(2, 3), k=1).optimum
    assert json.loads((run.path / "run.json").read_text())["env_optimum"] == optimum
    frame = run.load_evaluations()
    summary = pd.read_csv(run.path / "summary.csv")
    hits = frame[(frame["status"] == "ok") & (frame["reward"] >= optimum - 1e-9)]
    assert summary.loc[0, "seeds_reached"] == hits["seed"].nunique() >= 1
    assert frame.loc[frame["status"] == "ok", "reward"].max() == pytest.approx(optimum)


@pytest.mark.parametrize(
    "name, params, shape",
    [("two-peaks", {}, (5, 5)), ("target", {"class_credit": 0.5}, (5, 5)), ("nk", {"k": 3, "table_seed": 4}, (4, 6))],
)
def test_landscapes_pass_the_environment_conformance_checks(name, params, shape):
    check_environment(registry().get("environment", name).spec.load(), params=params, shape=shape, bodies=30)


def test_the_default_target_scales_to_other_shapes():
    from gdabench.envs.target import DEFAULT_TARGET, default_target

    big = make_env("target", shape=(10, 10))
    assert (
        big.target == default_target((10, 10)) and big.target.is_valid() and big.evaluate(big.target, seed=0) == 100.0
    )
    blocks = np.asarray(big.target.voxels).reshape(5, 2, 5, 2)
    assert (blocks == np.asarray(DEFAULT_TARGET.voxels)[:, None, :, None]).all()  # each voxel a 2x2 block
    assert default_target((5, 5)) == DEFAULT_TARGET and default_target((8, 12)).shape == (8, 12)
