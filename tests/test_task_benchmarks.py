"""The task benchmarks' comparisons (``benchmarks/compare/``: ``task_parity.py``, ``task_fidelity.py``,
``task_stability.py``).

CI has no Evolution Gym, so the voxel engine stands in for it (``evogym_twin.VoxelEnv`` answers the calls
``EvogymEnv`` answers): the same simulator on both sides must give gaps of zero and perfect agreement, a
perturbed one must not, and the statistics are checked on numbers set by hand.
"""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import gdabench

from support.scripts import load_script

parity = load_script("compare/task_parity")
fidelity = load_script("compare/task_fidelity")
stability = load_script("compare/task_stability")
twin = importlib.import_module("evogym_twin")  # the module the scripts import (load_script put it on the path)

WALKER = gdabench.Body.from_text("11111/13331/40004/40004/40004")
#: walker_fidelity's wave40 gait drives this body unstable at step 63 on Walker-v0, in both simulators
UNSTABLE = gdabench.Body.from_text("11111/44444/40404/40404/40404")


def alone(task, body, actions, seed):
    """The voxel engine as the other simulator (:func:`own_draw`), one episode."""
    return twin.play(own_draw(task, body, seed), actions)


class Nudged(twin.VoxelEnv):
    """The voxel engine with every action changed by ``nudge``: a simulator that drifts away."""

    nudge = 1e-7

    def step(self, action):
        return super().step(np.asarray(action) + self.nudge)


def own_draw(task, body, setup_seed):
    """The voxel engine as the second simulator, drawing its own random set-up as Evolution Gym draws its (from
    generators other than the first simulator's: only imposing the set-up makes them agree)."""
    return twin.VoxelEnv(task, body, setup_seed + 12345)


@pytest.mark.parametrize("task", ["Walker-v0", "Catcher-v0"])
def test_parity_of_the_engine_with_itself_is_exact_with_the_others_setup_imposed(task):
    result = parity.run_task(task, [WALKER], steps=12, make_theirs=own_draw)
    body = result["per_body"][0]
    assert body["steps"] == 12 and body["start_gap"] == 0.0
    assert body["first_over"] == {"0": None, "1e-12": None, "1e-6": None, "1e-3": None}
    assert result["parity_steps"] == 12 and result["parity_all_steps"] and result["ends_agree"]
    assert set(result["gap_up_to"]["pos"]) == {"10", "12"}


def test_parity_finds_the_first_step_a_drifting_simulator_leaves_each_tolerance():
    result = parity.run_task("Walker-v0", [WALKER], steps=30, make_theirs=lambda t, b, s: Nudged(t, b, s))
    first = result["first_over"]
    assert first["0"] == 1  # a different action shows at once
    assert first["1e-6"] is None or first["1e-6"] > first["0"]
    assert result["parity_steps"] == (30 if first["1e-6"] is None else first["1e-6"] - 1)
    gaps = result["gap_up_to"]["pos"]
    assert 0 < gaps["10"] <= gaps["30"]


def test_first_over_counts_steps_from_one_and_the_start_as_zero():
    assert parity.first_over([0.0, 1e-9, 1e-4], 0.0, 1e-6) == 3
    assert parity.first_over([0.0, 1e-9, 1e-4], 0.0, 1e-3) is None
    assert parity.first_over([0.0], 1e-5, 1e-6) == 0


def test_fidelity_against_the_same_engine_alone_agrees_and_meets_the_goal():
    todo = fidelity.cases("Catcher-v0", 2, 0, ["wave20", "random"])
    assert [c["part"] for c in todo] == ["calibration"] * 2 + ["held-out"] * 2
    alone = lambda task, case, steps: twin.play(own_draw(task, gdabench.Body.from_text(case["body"]),  # noqa: E731
                                                         case["setup_seed"]), fidelity.episode_actions(case, steps))
    result = fidelity.run_task("Catcher-v0", todo, 40, twin.Rows(None), theirs_player=alone)
    for e in result["episodes"]:  # the batch of all episodes plays each as it plays alone
        assert e["ours"]["return"] == e["evogym"]["return"] and e["ours"]["trace"] == e["evogym"]["trace"]
    held = result["parts"]["held-out"]
    assert held["spearman"] == pytest.approx(1.0) and held["sign_agreement"] == 1.0 and held["goal_met"]


def episode(ret, unstable=False):
    return {"return": ret, "unstable": unstable, "trace": [0.0, 0.1]}


def test_fidelity_statistics_and_the_goal_on_numbers_set_by_hand():
    ours = [1.0, 2.0, 3.0, -4.0]
    theirs = [1.5, 2.5, -0.5, 3.5]  # ranks 1 2 3 0 against 1 2 0 3: Spearman 1 - 6 * 18 / 60; two signs differ
    rows = [{"body": f"b{i}", "part": "held-out", "gait": "g", "ours": episode(o), "evogym": episode(t, i == 3)}
            for i, (o, t) in enumerate(zip(ours, theirs))]
    held = fidelity.part_tables(rows)["held-out"]
    assert held["spearman"] == pytest.approx(-0.8)
    assert held["sign_agreement"] == 0.5
    assert (held["unstable_ours_only"], held["unstable_evogym_only"]) == (0.0, 0.25)
    assert not held["goal_met"]
    same = [{**r, "evogym": r["ours"]} for r in rows]
    assert fidelity.part_tables(same)["held-out"]["goal_met"]
    assert fidelity.part_tables([{**same[0], "evogym": episode(1.0, True)}, *same[1:]])["held-out"]["goal_met"] is False


def test_fidelity_resumes_from_its_rows(tmp_path):
    rows = twin.Rows(tmp_path / "rows.jsonl")
    todo = fidelity.cases("Walker-v0", 2, 0, ["pulse12"])
    calls = []

    def counted(task, case, steps):
        calls.append(case["body"])
        body = gdabench.Body.from_text(case["body"])
        return twin.play(own_draw(task, body, 0), fidelity.episode_actions(case, steps))

    first = fidelity.run_task("Walker-v0", todo, 20, rows, theirs_player=counted)
    again = fidelity.run_task("Walker-v0", todo, 20, twin.Rows(tmp_path / "rows.jsonl"), theirs_player=counted)
    assert len(calls) == 2  # the second run read Evolution Gym's episodes back
    assert [e["evogym"]["return"] for e in again["episodes"]] == [e["evogym"]["return"] for e in first["episodes"]]


def test_step_problems_flag_what_slipped_through():
    obs = np.array([[0.0, 1.0], [np.nan, 0.0], [150.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
    reward = np.array([0.1, 0.0, 0.0, -3.0, 0.0, -2.5])
    terminated = np.array([False, False, False, True, True, True])
    unstable = np.array([False, False, False, True, True, True])
    still = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.5])  # the last task rewards a still step 0.5
    moved = np.array([0.01, 0.0, 0.0, 0.0, 0.0, 0.0])
    found = stability.step_problems(obs, reward, terminated, unstable, still, moved, 100.0)
    assert found["nan"].tolist() == [False, True, False, False, False, False]
    assert found["outside"].tolist() == [False, True, True, False, False, False]
    assert found["bad_penalty"].tolist() == [False, False, False, False, True, False]
    moved[0] = 0.5
    assert stability.step_problems(obs, reward, terminated, unstable, still, moved, 100.0)["implausible"][0]


def test_stability_checks_an_unstable_episode_and_sets_it_beside_the_other_simulator():
    bodies = [UNSTABLE, WALKER]
    checks = stability.Checks(2)
    actions = [stability.actions_for("wave40", twin.actuators(b), 0, 80) for b in bodies]
    episodes = twin.play_batch("Walker-v0", bodies, actions, [{}, {}], watch=checks)
    assert [e["unstable"] for e in episodes] == [True, False]
    assert episodes[0]["steps"] == 63 and checks.first_unstable.tolist() == [63, -1]
    assert not any(flags.any() for flags in checks.found.values())
    result = stability.run_task("Walker-v0", bodies, 0, 80, None, theirs_player=alone)
    assert result["problems"] == dict.fromkeys(stability.PROBLEMS, 0)
    assert result["unstable_voxel"] == result["unstable_evogym"]
    assert result["unstable_voxel_only"] == result["unstable_evogym_only"] == 0


def test_a_body_whose_batch_raises_is_found_and_the_others_kept(monkeypatch):
    real = twin.TaskBatch.step

    def failing(self, actions):
        if any(b.text == UNSTABLE.text for b in self.bodies):
            raise FloatingPointError("boom")
        return real(self, actions)

    monkeypatch.setattr(twin.TaskBatch, "step", failing)
    actions = [np.ones((5, len(twin.actuators(b)))) for b in (WALKER, UNSTABLE)]
    episodes, found = stability.check_bodies("Walker-v0", [WALKER, UNSTABLE], actions, [{}, {}])
    assert found["exception"].tolist() == [False, True]
    assert episodes[0]["steps"] == 5 and episodes[1] is None


def test_nudged_runs_count_each_simulators_unstable_runs():
    assert (twin.nudges(5) / twin.NUDGE).round().tolist() == [1, -1, 2, -2, 3]
    for body, unstable in ((UNSTABLE, 3), (WALKER, 0)):
        actions = stability.actions_for("wave40", twin.actuators(body), 0, 80)
        out = stability.nudged_runs("Walker-v0", body, actions, 0, 3, alone)
        assert (out["runs"], out["voxel"], out["evogym"]) == (3, unstable, unstable)
        assert out["voxel_steps"] == out["evogym_steps"] == [63] * unstable


def test_only_episodes_unstable_in_one_simulator_are_nudged():
    result = {"unstable_bodies_voxel": [UNSTABLE.text, WALKER.text], "unstable_bodies_evogym": [UNSTABLE.text]}
    out = stability.nudged_mismatches("Walker-v0", [UNSTABLE, WALKER], 0, 10, result, 2, alone)
    assert [n["body"] for n in out] == [WALKER.text] and out[0]["runs"] == 2


def test_fidelity_nudges_only_held_out_disagreements_and_counts_each_simulators_outcomes():
    case = {"body": UNSTABLE.text, "gait": "wave40", "seed": 0, "setup_seed": 0}
    played = twin.play(twin.VoxelEnv("Walker-v0", UNSTABLE), fidelity.episode_actions(case, 80))
    flipped = {**played, "return": -played["return"]}
    shorter, later = {**played, "steps": 80}, {**played, "steps": 70}  # to the limit; ended early, at another step
    episodes = [
        {**case, "part": "held-out", "ours": played, "evogym": played},  # they agree: not played again
        {**case, "part": "calibration", "ours": played, "evogym": flipped},  # not held out
        {**case, "part": "held-out", "ours": played, "evogym": flipped},  # signs differ
        {**case, "part": "held-out", "ours": played, "evogym": shorter},  # one ends early, the other not
        {**case, "part": "held-out", "ours": played, "evogym": later},  # both end early: they agree
    ]
    assert [fidelity.disagree(e, 80) for e in episodes] == [False, True, True, True, False]
    out = fidelity.nudged_disagreements("Walker-v0", {"episodes": episodes}, 80, 3, alone)
    assert len(out) == 2 and all(n["runs"] == 3 and n["gait"] == "wave40" for n in out)
    for n in out:  # the engine stands in for Evolution Gym: the same outcomes, every run unstable at step 63
        assert n["voxel"] == n["evogym"]
        assert (n["voxel"]["ended_early"], n["voxel"]["unstable"], n["voxel"]["steps"]) == (3, 3, [63] * 3)
        assert n["p_positive"] == n["p_ended_early"] == n["p_unstable"] == 1.0


def test_nudged_outcomes_and_the_fisher_p_of_their_rates():
    runs = [{"return": 2.0, "steps": 80, "unstable": False}, {"return": -1.0, "steps": 50, "unstable": True},
            {"return": 0.0, "steps": 79, "unstable": False}]
    out = fidelity.outcomes(runs, 80)
    assert (out["positive"], out["ended_early"], out["unstable"], out["return_median"]) == (1, 2, 1, 0.0)
    assert out["return_range"] == [-1.0, 2.0] and out["steps"] == [80, 50, 79]
    assert fidelity.fisher_p(4, 4, 100) == 1.0
    assert fidelity.fisher_p(0, 100, 100) < 1e-50
    assert 0.05 < fidelity.fisher_p(2, 6, 100) < 0.3
