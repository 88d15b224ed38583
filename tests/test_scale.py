"""Scale and reliability: executors agree, faults stay isolated, killed runs resume, the cache.

The environments that fail on purpose come from a real plugin package
(``tests/fixtures/faulty_plugin``), installed once into a temporary directory, so that worker
processes, Ray workers and ``gdabench`` subprocesses import it as they would a user's plugin.
"""

from __future__ import annotations

import json
import math
import multiprocessing
import os
import signal
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gdabench import Experiment, PluginChoice
from gdabench.body import Body
from gdabench.errors import ConfigError
from gdabench.execution import OK, EvalOutcome, EvalTask, Execution, make_executor
from gdabench.execution.cache import EvaluationCache
from gdabench.results import RunDirectory
from gdabench.running.runner import compare
from gdabench.specs import Factory

from support.listeners import KillAt, Killed
from support.processes import cli, table


@pytest.fixture(scope="module")
def ray_cluster(faulty_site):
    """One local Ray instance for this module; the ray executor joins it instead of starting its own."""
    ray = pytest.importorskip("ray", reason="ray is not installed (pip install -e '.[ray]')")
    path = os.pathsep.join([str(faulty_site), *filter(None, sys.path)])
    ray.init(
        num_cpus=2, include_dashboard=False, logging_level="WARNING", runtime_env={"env_vars": {"PYTHONPATH": path}}
    )
    yield ray
    ray.shutdown()


def voxel_sum(text: str) -> float:
    return float(Body.from_text(text).voxels.sum())


# -- executors agree --------------------------------------------------------------------------
def _noisy_expected(frame: pd.DataFrame) -> pd.Series:
    """``noisy``'s reward computed here from the run seed and the body hash alone (seeding's contract)."""
    import numpy as np

    def reward(row) -> float:
        seed = np.random.SeedSequence(int(row.seed), spawn_key=(1, int(row.body_hash, 16))).generate_state(
            1, dtype=np.uint32
        )[0]
        return voxel_sum(row.body) + float(np.random.default_rng(int(seed)).normal())

    return frame.apply(reward, axis=1)


@pytest.mark.xdist_group("ray_cluster")  # one Ray instance per module, not one per xdist worker
def test_same_table_with_every_executor_on_an_environment_that_uses_its_seed(tmp_path, reg, ray_cluster):
    """Serial, trials in parallel, evaluations in parallel, Ray: one table, rewards from (seed, body) alone."""
    exp = Experiment(
        designers=(PluginChoice("ga"), PluginChoice("random")), envs=PluginChoice("noisy"), budget=75, seeds=(0, 1)
    )
    serial = compare(exp, tmp_path / "serial", reg=reg, execution=Execution(jobs=1))
    assert serial.meta["execution"] == Execution(jobs=1).to_json()
    reference = table(tmp_path / "serial")
    ok = reference[reference["status"] == "ok"]
    assert np.allclose(ok["reward"], _noisy_expected(ok))
    same_body = ok.groupby(["seed", "body_hash"])["reward"].nunique()
    assert (same_body == 1).all()  # a body scores the same whichever designer found it
    options = {
        "trials in parallel": Execution(jobs=2),
        "evaluations in parallel": Execution(jobs=1, workers=2),
        "both": Execution(jobs=2, workers=2),
        "ray": Execution("ray", jobs=2),
        "ray with evaluation actors": Execution("ray", jobs=1, workers=2),
    }
    for name, execution in options.items():
        compare(exp, tmp_path / name, reg=reg, execution=execution)
        pd.testing.assert_frame_equal(table(tmp_path / name), reference, obj=name)


# -- fault isolation ----------------------------------------------------------------------------
FAULTS = {"raise_on": 1, "nan_on": 2, "inf_on": 3, "hang_on": 4, "exit_on": 5, "kill_on": 6}
EXPECTED = {
    "raise_on": ("error", "RuntimeError: simulator exploded on "),
    "nan_on": ("error", "environment returned a non-finite reward (nan)"),
    "inf_on": ("error", "environment returned a non-finite reward (-inf)"),
    "hang_on": ("timeout", "evaluation did not finish within the "),
    "exit_on": ("error", "worker process died"),
    "kill_on": ("error", "worker process died"),
}


@pytest.fixture
def faulty_experiment(tmp_path, reg):
    """A GA run on `faulty` whose first generation holds one body for each kind of fault."""
    plain = Experiment(designers=(PluginChoice("ga"),), envs=PluginChoice("faulty"), population=10, budget=30)
    first = compare(plain, tmp_path / "plain", reg=reg).load_evaluations().query("generation == 0")["body"].tolist()
    params = {fault: [first[i]] for fault, i in FAULTS.items()} | {"record_pid": True}
    return Experiment(
        designers=(PluginChoice("ga"),), envs=PluginChoice("faulty", params), population=10, budget=30
    ), first


def check_faults(frame: pd.DataFrame, first: list[str]) -> None:
    assert len(frame) == 30 and frame["n_evals"].tolist() == list(
        range(1, 31)
    )  # failures use budget, nothing else does
    g0 = frame[frame["generation"] == 0].set_index("index")
    assert g0["body"].tolist() == first
    for fault, index in FAULTS.items():
        status, message = EXPECTED[fault]
        assert g0.loc[index, "status"] == status, fault
        assert g0.loc[index, "message"].startswith(message), (fault, g0.loc[index, "message"])
        assert math.isnan(g0.loc[index, "reward"])
    ok = frame[frame["status"] == "ok"]
    assert len(ok) == 30 - len(FAULTS)  # only the faulty bodies failed, in their generation and after it
    assert (ok["reward"] == ok["body"].map(voxel_sum)).all()


def test_faults_are_recorded_and_the_run_goes_on(tmp_path, reg, faulty_experiment):
    exp, first = faulty_experiment
    run = compare(exp, tmp_path / "process", reg=reg, execution=Execution(workers=2, timeout=2))
    assert run.meta["status"] == "complete"
    frame = run.load_evaluations()
    check_faults(frame, first)
    assert frame[frame["generation"] == 0]["pid"].nunique() >= 2  # bodies of one generation ran in parallel
    # one worker with a timeout: one worker process, replaced after each hang or death
    serial = compare(exp, tmp_path / "serial", reg=reg, execution=Execution(timeout=2))
    assert serial.meta["execution"]["workers"] == 1 and serial.meta["status"] == "complete"
    assert os.getpid() not in set(serial.load_evaluations()["pid"].dropna())
    # the same table: no outcome depends on which other evaluations failed, or where
    pd.testing.assert_frame_equal(table(tmp_path / "serial", drop=["pid"]), table(tmp_path / "process", drop=["pid"]))


@pytest.mark.xdist_group("ray_cluster")  # one Ray instance per module, not one per xdist worker
def test_faults_on_ray(tmp_path, reg, faulty_experiment, ray_cluster):
    exp, first = faulty_experiment
    # Ray notices a dead actor in about a second, later on a loaded machine: a longer timeout keeps
    # a death from being reported as a timeout
    run = compare(exp, tmp_path / "run", reg=reg, execution=Execution("ray", workers=2, timeout=6))
    assert run.meta["status"] == "complete" and run.meta["execution"]["timeout"] == 6
    check_faults(run.load_evaluations(), first)


def test_serial_without_timeout_evaluates_in_the_driver(tmp_path, reg):
    exp = Experiment(
        designers=(PluginChoice("random"),), envs=PluginChoice("faulty", {"record_pid": True}), population=5, budget=5
    )
    frame = compare(exp, tmp_path / "run", reg=reg).load_evaluations()
    assert set(frame["pid"]) == {os.getpid()}


@pytest.mark.skipif(os.cpu_count() < 2, reason="one core: every process has one Numba thread anyway")
def test_worker_processes_run_their_kernels_on_one_thread(tmp_path, reg):
    """Workers run side by side, one per core: Numba's thread per CPU in each made two walker trials 1.6x slower."""
    exp = Experiment(designers=(PluginChoice("random"),), envs=PluginChoice("faulty", {"record_pid": True}),
                     seeds=(0, 1), population=5, budget=10)  # fmt: skip
    for name, execution in {"trials": Execution(jobs=2), "evaluations": Execution(jobs=1, workers=2)}.items():
        frame = compare(exp, tmp_path / name, reg=reg, execution=execution).load_evaluations()
        assert os.getpid() not in set(frame["pid"]) and set(frame["numba_threads"]) == {1}, name


def test_dead_worker_is_replaced_and_others_keep_their_results(reg):
    """Two workers, six bodies, one kills its worker: only that body is an error, in any batch."""
    texts = ["33/00", "44/00", "34/00", "43/00", "30/30", "40/40"]
    env = Factory.of("gdabench_faulty.envs:Faulty", {"shape": (2, 2), "exit_on": ["34/00"], "record_pid": True})
    tasks = [EvalTask(Body.from_text(t), 0, env) for t in texts]
    with make_executor(Execution(workers=2), warm=[env]) as executor:
        outcomes = executor.map(tasks)
        workers = [p for p in multiprocessing.active_children() if p.name == "gdabench-worker"]
        assert len(workers) == 2  # the dead one was replaced
        again = executor.map(tasks[:2])
    assert [o.status for o in outcomes] == ["ok", "ok", "error", "ok", "ok", "ok"]
    assert outcomes[2].message == "worker process died (exit code 3)"
    assert [o.reward for i, o in enumerate(outcomes) if i != 2] == [6.0, 8.0, 7.0, 6.0, 8.0]
    assert [o.reward for o in again] == [6.0, 8.0]


# -- the generation seam: bodies in batches -------------------------------------------------------
def batched_experiment(**params) -> Experiment:
    return Experiment(designers=(PluginChoice("ga"),), envs=PluginChoice("batched", params), population=10, budget=30)


@pytest.mark.xdist_group("ray_cluster")  # one Ray instance per module, not one per xdist worker
def test_a_generation_goes_to_the_environment_in_batches_and_one_bodys_failure_is_its_own(tmp_path, reg, ray_cluster):
    first = compare(batched_experiment(), tmp_path / "plain", reg=reg).load_evaluations()
    first = first.query("generation == 0")["body"].tolist()
    exp = batched_experiment(at_once=4, raise_on=[first[1]], nan_on=[first[6]])
    serial = compare(exp, tmp_path / "serial", reg=reg).load_evaluations()
    g0 = serial[serial["generation"] == 0]
    # the environment's 4 at a time: 10 new bodies in calls of 4, 4 and 2, in order (an error row has no info)
    assert g0["batch"].fillna(0).astype(int).tolist() == [4, 0] + [4] * 6 + [2] * 2
    assert g0["status"].tolist() == ["ok", "error", "ok", "ok", "ok", "ok", "error", "ok", "ok", "ok"]
    assert g0["message"].iloc[1] == f"RuntimeError: simulator exploded on {first[1]}"
    assert g0["message"].iloc[6].startswith("environment returned a non-finite reward")
    ok = serial[serial["status"] == "ok"]
    assert (ok["reward"] == ok["body"].map(voxel_sum)).all()
    # workers share a generation's bodies evenly; --batch caps a call; the table is the same everywhere
    for name, execution, sizes in [
        ("workers", Execution(workers=2), [4] * 8 + [1] * 2),  # 8 bodies for 2 workers, then 2
        ("batch 3", Execution(batch=3), [3] * 9 + [1]),
        ("batch 1", Execution(workers=2, batch=1), [1] * 10),
        ("ray", Execution("ray", workers=2), [4] * 8 + [1] * 2),
    ]:
        frame = compare(exp, tmp_path / name, reg=reg, execution=execution).load_evaluations()
        sizes[1] = 0
        assert frame[frame["generation"] == 0]["batch"].fillna(0).astype(int).tolist() == sizes, name
        pd.testing.assert_frame_equal(
            table(tmp_path / name, drop=["batch"]), table(tmp_path / "serial", drop=["batch"])
        )


def test_a_batch_that_fails_as_a_whole_fails_its_bodies_only(tmp_path, reg):
    first = compare(batched_experiment(), tmp_path / "plain", reg=reg).load_evaluations()
    first = first.query("generation == 0")["body"].tolist()
    frame = compare(
        batched_experiment(at_once=4, fail_batch_on=[first[5]]), tmp_path / "run", reg=reg
    ).load_evaluations()
    g0 = frame[frame["generation"] == 0]
    assert g0["status"].tolist() == ["ok"] * 4 + ["error"] * 4 + ["ok"] * 2
    assert set(g0["message"].iloc[4:8]) == {"RuntimeError: the batch of 4 failed"}
    assert (frame["generation"].max() >= 2) and (frame["status"] == "ok").sum() == 26


def test_a_trial_whose_every_evaluation_failed_says_so_and_exits_1(tmp_path, faulty_site):
    args = [
        "compare",
        "-d",
        "random",
        "--env",
        "faulty[raise_always=true],simple",
        "--budget",
        "50",
        "--jobs",
        "1",
        "-q",
        "--no-report",
    ]
    result = cli(*args, "--out", str(tmp_path / "run"), site=faulty_site)
    assert result.returncode == 1, result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert lines[-1].startswith("error: every evaluation failed in 1 trial(s), e.g. random on faulty"), result.stderr
    assert any("50 error" in line and "simulator exploded" in line for line in lines[:-1]), result.stderr
    run = RunDirectory.open(tmp_path / "run")
    assert len(run.load_evaluations()) == 100  # the simple trial is whole
    assert run.meta["status"] == "failed" and run.meta["error"] == lines[-1].removeprefix(
        "error: "
    )  # as the exit code says
    again = cli("compare", "--resume", str(tmp_path / "run"), "-q", "--no-report", site=faulty_site)
    assert again.returncode == 1 and RunDirectory.open(tmp_path / "run").meta["status"] == "failed", again.stderr
    assert len(run.load_evaluations()) == 100


# -- designer failure, kill and resume ----------------------------------------------------------
def test_designer_failure_is_one_line_and_resumable(tmp_path, faulty_site):
    flag = tmp_path / "fail-now"
    flag.touch()
    args = [
        "compare",
        "-d",
        f"fragile[fail_at=2,flag={flag}]",
        "--env",
        "faulty",
        "--budget",
        "100",
        "-q",
        "--no-report",
    ]
    failed = cli(*args, "--out", str(tmp_path / "run"), site=faulty_site)
    assert failed.returncode == 1
    lines = [line for line in failed.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "raised in ask(): RuntimeError: designer model diverged" in lines[0], failed.stderr
    assert f"gdabench compare --resume {tmp_path / 'run'}" in lines[0]
    run = RunDirectory.open(tmp_path / "run")
    assert run.meta["status"] == "failed" and sorted(run.load_evaluations()["generation"].unique()) == [0, 1]
    flag.unlink()
    resumed = cli("compare", "--resume", str(tmp_path / "run"), "-q", "--no-report", site=faulty_site)
    assert resumed.returncode == 0, resumed.stderr
    reference = cli(*args, "--out", str(tmp_path / "ref"), site=faulty_site)
    assert reference.returncode == 0, reference.stderr
    pd.testing.assert_frame_equal(table(tmp_path / "run"), table(tmp_path / "ref"))


def _children(pid: int) -> set[int]:
    found = set()
    for task in Path(f"/proc/{pid}/task").glob("*/children"):
        found |= {int(p) for p in task.read_text().split()}
    return found


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="needs Linux /proc to find the worker processes")
def test_sigkilled_run_resumes_to_the_uninterrupted_table(tmp_path, faulty_site):
    """A real `gdabench compare` with two workers is SIGKILLed halfway, then resumed serially."""
    out = tmp_path / "killed"
    args = ["compare", "-d", "ga,random", "--env", "faulty", "--budget", "100", "--seeds", "0,1", "-q", "--no-report"]
    proc = cli(
        *args,
        "--jobs",
        "2",
        "--workers",
        "2",
        "--out",
        str(out),
        site=faulty_site,
        env={"GDABENCH_FAULTY_DELAY": "0.05"},
        background=True,
    )
    deadline, workers = time.monotonic() + 120, set()
    try:
        # halfway: the first (designer, seed) run is merged and the second has two generations on disk
        while not (
            (out / "evaluations.parquet").exists() and len(list((out / "pending").glob("*/gen-*.parquet"))) >= 2
        ):
            assert proc.poll() is None, f"run ended before it could be killed: {proc.communicate()}"
            assert time.monotonic() < deadline, "run made no progress"
            workers |= _children(proc.pid)
            time.sleep(0.02)
        workers |= _children(proc.pid)
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    assert len(workers) >= 2
    for _ in range(100):  # orphaned workers notice and exit
        if not any(_alive(p) for p in workers):
            break
        time.sleep(0.1)
    assert not any(_alive(p) for p in workers), "worker processes outlived the killed run"
    assert RunDirectory.open(out).meta["status"] == "running"  # as the kill left it

    resumed = cli("compare", "--resume", str(out), "-q", "--no-report", "--jobs", "1", site=faulty_site)
    assert resumed.returncode == 0, resumed.stderr
    reference = cli(*args, "--jobs", "1", "--out", str(tmp_path / "reference"), site=faulty_site)
    assert reference.returncode == 0, reference.stderr
    got, want = table(out), table(tmp_path / "reference")
    assert len(got) == 400 and not got.duplicated(["designer", "seed", "generation", "index"]).any()
    pd.testing.assert_frame_equal(got, want)
    meta = RunDirectory.open(out).meta
    assert meta["status"] == "complete" and meta["execution"]["jobs"] == 2 and meta["resumed"][-1]["jobs"] == 1
    assert not (out / "pending").exists() and not (out / "checkpoints").exists()


# -- evaluation cache ---------------------------------------------------------------------------
def test_cache_hits_across_runs_and_counts_them_as_evaluations(tmp_path, reg):
    cache = tmp_path / "cache"
    exp = Experiment(designers=(PluginChoice("ga"),), envs=PluginChoice("faulty"), budget=60, seeds=(0,))
    first = compare(exp, tmp_path / "first", reg=reg, execution=Execution(cache=str(cache)))
    assert first.meta["execution"]["cache"] == str(cache)
    a = first.load_evaluations()
    assert not a["cached"].any()
    ok = a[a["status"] == "ok"]
    assert len(list(cache.rglob("*.json"))) == ok["body_hash"].nunique() == 60
    second = compare(
        exp, tmp_path / "second", reg=reg, execution=Execution(cache=str(cache), workers=2)
    ).load_evaluations()
    assert second["cached"].tolist() == (second["status"] == "ok").tolist()
    assert second.loc[second["cached"], "eval_seconds"].eq(0).all()
    pd.testing.assert_frame_equal(
        table(tmp_path / "second", drop=["cached"]), table(tmp_path / "first", drop=["cached"])
    )
    # another seed gives other evaluation seeds: nothing to reuse, even for bodies seen before
    other = compare(
        Experiment(exp.designers, exp.envs, budget=60, seeds=(1,)),
        tmp_path / "other",
        reg=reg,
        execution=Execution(cache=str(cache)),
    ).load_evaluations()
    assert not other["cached"].any() and len(list(cache.rglob("*.json"))) == 120


def test_cache_skips_failures_and_nondeterministic_environments(tmp_path, reg, faulty_site):
    body = Body.from_text("33/44")
    cache = EvaluationCache(tmp_path / "cache", {"env": "x"})
    task = EvalTask(body, 5, Factory.of("gdabench.envs.simple:SumOfVoxels", {"shape": (2, 2)}))
    assert cache.get(task) is None
    assert not cache.put(task, EvalOutcome(math.nan, "error", "boom"))
    assert not cache.put(task, EvalOutcome(1.0, OK, info={"model": object()}))  # would not come back the same
    assert cache.get(task) is None
    assert cache.put(task, EvalOutcome(14.0, OK, info={"steps": 3}))
    assert cache.get(task) == EvalOutcome(14.0, OK, "", 0.0, {"steps": 3}, cached=True)
    assert cache.get(EvalTask(body, 6, task.env)) is None  # another evaluation seed
    assert EvaluationCache(tmp_path / "cache", {"env": "y"}).get(task) is None  # another configuration
    (tmp_path / "file").touch()
    with pytest.raises(ConfigError, match="cannot use .*file as the evaluation cache"):
        EvaluationCache(tmp_path / "file", {})
    exp = Experiment(designers=(PluginChoice("random"),), envs=PluginChoice("noisy"), budget=25)
    result = cli(
        "compare",
        "-d",
        "random",
        "--env",
        "noisy",
        "--budget",
        "25",
        "-q",
        "--no-report",
        "--cache",
        str(tmp_path / "c2"),
        "--out",
        str(tmp_path / "run"),
        site=faulty_site,
    )
    assert result.returncode == 0, result.stderr
    assert "not deterministic; the evaluation cache was not used" in result.stderr
    assert (
        not (tmp_path / "c2").exists()
        and not compare(exp, tmp_path / "api", reg=reg, execution=Execution(cache=str(tmp_path / "c2")))
        .load_evaluations()["cached"]
        .any()
    )


def _hammer(root: str, worker: int) -> list[float]:
    cache = EvaluationCache(root, {"env": "shared"})
    env = Factory.of("gdabench.envs.simple:SumOfVoxels", {"shape": (2, 2)})
    seen = []
    for i in range(60):
        task = EvalTask(Body.from_text("33/44"), (i + worker) % 20, env)
        cache.put(task, EvalOutcome(float(task.seed), OK))
        hit = cache.get(task)
        seen.append(hit.reward if hit else math.nan)
    return seen


def test_cache_is_safe_with_concurrent_writers(tmp_path):
    with multiprocessing.get_context("spawn").Pool(4) as pool:
        results = pool.starmap(_hammer, [(str(tmp_path), w) for w in range(4)])
    for worker, seen in enumerate(results):
        assert seen == [float((i + worker) % 20) for i in range(60)]
    assert len(list(tmp_path.rglob("*.json"))) == 20 and not list(tmp_path.rglob("*.tmp"))


# -- options ------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "options, fragment",
    [
        (["--executor", "threads"], "unknown executor 'threads'; known executors: local, ray"),
        (["--timeout", "0"], "timeout must be a positive number of seconds"),
        (["--ray-address", "auto"], "--ray-address needs --executor ray"),
        (["--jobs", "0"], "jobs must be a positive integer, got 0"),
        (["--workers", "0"], "workers must be a positive integer, got 0"),
        (["--batch", "0"], "batch must be a positive integer, got 0"),
    ],
)
def test_bad_execution_options_are_one_line(tmp_path, options, fragment):
    from typer.testing import CliRunner

    from gdabench.cli import app

    result = CliRunner().invoke(
        app,
        ["compare", "-d", "random", "--budget", "25", "--out", str(tmp_path / "run"), *options],
        env={"COLUMNS": "200"},
    )
    assert result.exit_code == 2
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and fragment in lines[0], result.stderr
    assert not (tmp_path / "run").exists()


def test_ray_executor_without_ray_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # as if ray were not installed
    with pytest.raises(ConfigError, match=r"needs Ray: pip install 'gdabench\[ray\]'"):
        make_executor(Execution("ray", workers=2))


def test_resume_keeps_the_timeout_and_records_each_execution(tmp_path, reg):
    exp = Experiment(designers=(PluginChoice("random"),), envs=PluginChoice("faulty"), population=5, budget=20)

    with pytest.raises(Killed):
        compare(exp, tmp_path / "run", reg=reg, execution=Execution(timeout=30), listener=KillAt("random", 0, 1))
    run = compare(None, tmp_path / "run", resume=True, reg=reg, execution=Execution(workers=2))
    meta = json.loads((tmp_path / "run" / "run.json").read_text())
    assert meta["execution"]["timeout"] == 30 and meta["execution"]["workers"] == 1
    assert meta["resumed"][-1]["timeout"] == 30 and meta["resumed"][-1]["workers"] == 2
    assert run.meta["status"] == "complete" and len(run.load_evaluations()) == 20
