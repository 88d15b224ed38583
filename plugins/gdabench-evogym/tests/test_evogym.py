"""The Evolution Gym plugin against the real simulator (skipped when it is not installed)."""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

with contextlib.redirect_stdout(io.StringIO()):
    evogym = pytest.importorskip(
        "evogym", reason="Evolution Gym is not installed: build it with plugins/gdabench-evogym/install.sh"
    )

from gdabench_evogym.env import EvogymTask
from gdabench_evogym.tasks import TASKS

import gdabench
from gdabench.body import Body, is_valid
from gdabench.testing import check_environment

WALKER_BODY = Body.from_text("33333/31113/31013/31013/31013")


def test_every_evolution_gym_task_is_registered():
    assert TASKS == tuple(evogym.BASELINE_ENV_NAMES)
    reg = gdabench.registry()
    for task in TASKS:
        item = reg.get("environment", f"evogym/{task}")
        assert item.distribution == "gdabench-evogym" and item.spec.requires_controller


def test_validity_is_evolution_gyms_and_agrees_with_gdabench():
    env = EvogymTask()
    rng = np.random.default_rng(0)
    for _ in range(300):
        grid = rng.choice(5, size=(5, 5), p=[0.5, 0.125, 0.125, 0.125, 0.125]).astype(np.int8)
        assert (env.invalid_reason(Body(grid)) is None) == is_valid(grid)


def test_actuator_voxels_follow_action_order():
    env = EvogymTask().make_env(WALKER_BODY)
    act = env.unwrapped.actuator_voxels
    assert len(act) == env.action_space.shape[0] == int(np.isin(WALKER_BODY.voxels, (3, 4)).sum())
    assert all(WALKER_BODY.voxels[r, c] == code for r, c, code in act)
    assert [r * 5 + c for r, c, _ in act] == sorted(r * 5 + c for r, c, _ in act)


def test_open_loop_drives_the_actuators_deterministically():
    check_environment(EvogymTask, controller=gdabench.make_controller("open-loop", trials=1), bodies=3)
    body = Body.from_text("00000/33333/33333/30003/30003")
    moving = EvogymTask().evaluate(body, seed=0, controller=gdabench.make_controller("open-loop", trials=1)).reward
    still = (
        EvogymTask()
        .evaluate(body, seed=0, controller=gdabench.make_controller("open-loop", trials=1, amplitude=0.0, center=1.0))
        .reward
    )
    assert abs(still) < 0.2 < abs(moving)  # the muscles, found through actuator_voxels, move the body


def test_compare_end_to_end_with_its_report_on_a_headless_machine(tmp_path):
    """Without a display Evolution Gym's renderer would crash the process: the report skips the animation."""
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "gdabench", "compare", "--designers", "ga,random", "--env", "evogym/Walker-v0",
           "--controller", "open-loop", "-C", "trials=1", "--budget", "30", "--seeds", "0",
           "--out", str(out), "-q"]  # fmt: skip
    headless = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    result = subprocess.run(cmd, capture_output=True, text=True, env=headless)
    assert result.returncode == 0, result.stderr
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "complete" and meta["versions"]["plugins"]["gdabench-evogym"] == "0.1.0"
    assert (out / "report" / "report.html").exists() and (out / "report" / "best_so_far.png").exists()
    assert not list((out / "report").glob("animation_*.gif"))


def test_ppo_trains_on_evolution_gym(tmp_path):
    """PPO (TorchRL) drives Evolution Gym's own Gymnasium environment; its saved policy replays."""
    ppo = gdabench.make_controller("ppo", timesteps=256, eval_interval=128)
    body = Body.from_text("00000/33333/33333/30003/30003")
    first = EvogymTask().evaluate(body, seed=1, controller=ppo, workdir=tmp_path / "policy")
    assert math.isfinite(first.reward) and (tmp_path / "policy").is_dir()
    again = EvogymTask().evaluate(body, seed=1, controller=ppo, workdir=tmp_path / "policy")
    assert again.reward == first.reward and again.info.get("replayed") == 1


def test_walker_fidelity_benchmark_compares_both_simulators(tmp_path):
    """A slice of benchmarks/compare/walker_fidelity.py (the full run takes hours on a shared machine)."""
    root = os.path.join(os.path.dirname(__file__), "..", "..", "..")
    script = os.path.join(root, "benchmarks", "compare", "walker_fidelity.py")
    cache = tmp_path / "evogym.jsonl"
    args = [
        sys.executable,
        script,
        "--random-bodies",
        "2",
        "--steps",
        "60",
        "--gaits",
        "wave20,random",
        "--evogym-cache",
        str(cache),
    ]
    out = subprocess.run(
        [*args, "--json", str(tmp_path / "rows.json")], capture_output=True, text=True, check=True
    ).stdout
    assert "calibration: 13 bodies, 26 episodes" in out and "held-out: 13 bodies, 26 episodes" in out
    assert "return Spearman" in out and "ratio" in out  # both simulators timed side by side
    rows = json.loads((tmp_path / "rows.json").read_text())
    assert len(rows) == 52 and all(len(r["evogym"]["trace"]) == 7 for r in rows)
    # the same body set again, Evolution Gym's episodes from the cache: identical figures
    again = subprocess.run(args, capture_output=True, text=True, check=True).stdout

    def tables(text: str) -> list[str]:  # Evolution Gym's C++ code may print its version first
        lines = text.splitlines()
        return lines[next(i for i, line in enumerate(lines) if line.startswith("calibration")) : -1]

    assert tables(again) == tables(out) and "from the cache" in again
    bad = subprocess.run([*args, "--gaits", "moonwalk"], capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.startswith("error: unknown gait")
