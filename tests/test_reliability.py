"""A run directory cannot be corrupted: one writer, kills at every phase, readers mid-run, full
disks, signals, and every input error refused in one line before anything is made.

Most tests drive real ``gdabench`` processes (``python -m gdabench``) on the faulty plugin's
``faulty`` environment, slowed by ``GDABENCH_FAULTY_DELAY`` where a test must act mid-run.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from gdabench.cli import app
from gdabench.faults import POINTS
from gdabench.results import RunDirectory

from support.processes import cli, default_sigint, error_lines, said, table

ARGS = [
    "compare",
    "-d",
    "ga,random",
    "--env",
    "faulty",
    "--budget",
    "60",
    "--population",
    "10",
    "--seeds",
    "0,1",
    "-q",
    "--no-report",
]
SLOW = {"GDABENCH_FAULTY_DELAY": "0.03"}


@pytest.fixture(scope="module")
def reference(faulty_site, tmp_path_factory) -> pd.DataFrame:
    """The uninterrupted table every damaged-then-resumed run must equal."""
    out = tmp_path_factory.mktemp("reference") / "run"
    result = cli(*ARGS, "--out", str(out), site=faulty_site)
    assert result.returncode == 0, result.stderr
    return table(out)


def wait_for(predicate, proc: subprocess.Popen, what: str, limit: float = 120) -> None:
    deadline = time.monotonic() + limit
    while not predicate():
        assert proc.poll() is None, f"the run ended before {what}: {proc.communicate()}"
        assert time.monotonic() < deadline, f"no {what} within {limit} s"
        time.sleep(0.02)


def started(out: Path) -> bool:
    return len(list(out.glob("pending/*/gen-*.parquet"))) >= 1


def assert_whole(out: Path, reference: pd.DataFrame) -> None:
    got = table(out)
    assert not got.duplicated(["designer", "seed", "generation", "index"]).any()
    pd.testing.assert_frame_equal(got, reference)
    assert RunDirectory.open(out).meta["status"] == "complete"
    assert not (out / "pending").exists() and not (out / "checkpoints").exists()
    assert not list(out.rglob("*.tmp"))


# -- one writer ---------------------------------------------------------------------------------
def test_a_second_writer_is_refused_while_a_run_is_going(tmp_path, faulty_site, reference):
    out = tmp_path / "run"
    proc = cli(*ARGS, "--out", str(out), site=faulty_site, env=SLOW, background=True)
    try:
        wait_for(lambda: started(out), proc, "a first generation")
        meta = RunDirectory.open(out).meta
        for args in (["compare", "--resume", str(out), "-q"], [*ARGS, "--out", str(out)]):
            second = cli(*args, site=faulty_site)
            assert second.returncode == 2, second.stderr
            lines = error_lines(second)
            assert len(lines) == 1 and lines[0].startswith("error: "), second.stderr
            assert (
                f"run {out} is being written by process {proc.pid} on " in lines[0]
                or "already exists and is not empty" in lines[0]
            )
        assert proc.wait(timeout=300) == 0, proc.communicate()
    finally:
        proc.kill()
    after = RunDirectory.open(out).meta
    assert (after["run_id"], after["command"], after.get("resumed")) == (
        meta["run_id"],
        meta["command"],
        None,
    )  # untouched by the others
    assert_whole(out, reference)


def test_concurrent_resumes_leave_one_writer(tmp_path, faulty_site, reference):
    out = tmp_path / "run"
    proc = cli(*ARGS, "--out", str(out), site=faulty_site, env=SLOW, background=True)
    wait_for(lambda: started(out), proc, "a first generation")
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    resumes = [
        cli("compare", "--resume", str(out), "-q", "--no-report", site=faulty_site, env=SLOW, background=True)
        for _ in range(3)
    ]
    results = [(r.wait(timeout=300), r.communicate()[1]) for r in resumes]
    codes = sorted(code for code, _ in results)
    assert codes == [0, 2, 2], results
    for code, err in results:
        if code == 2:
            assert "is being written by process" in err and len(said(err)) == 1, err
    assert_whole(out, reference)


def test_identical_runs_started_at_once_on_one_directory(tmp_path, faulty_site, reference):
    out = tmp_path / "run"
    procs = [cli(*ARGS, "--out", str(out), site=faulty_site, env=SLOW, background=True) for _ in range(2)]
    results = [(p.wait(timeout=300), p.communicate()[1]) for p in procs]
    assert sorted(code for code, _ in results) == [0, 2], results
    loser = next(err for code, err in results if code == 2)
    # the loser may meet the winner's lock before the winner has written who it is ("another process")
    assert ("is being written by" in loser or "already exists and is not empty" in loser) and len(said(loser)) == 1
    assert_whole(out, reference)


def test_labels_that_share_a_file_name_are_refused(tmp_path, faulty_site):
    result = cli(
        "compare", "-d", "ga[survivors=5],ga[survivors=5 ]", "--out", str(tmp_path / "run"), "-q", site=faulty_site
    )
    assert result.returncode == 2 and "map to the same file name" in result.stderr and not (tmp_path / "run").exists()


# -- kills at every phase -------------------------------------------------------------------------
@pytest.mark.parametrize("point", POINTS)
def test_a_kill_at_every_phase_of_finishing_a_generation_or_trial_resumes_whole(
    point, tmp_path, faulty_site, reference
):
    out = tmp_path / "run"
    dead = cli(*ARGS, "--jobs", "1", "--out", str(out), site=faulty_site, env={"GDABENCH_FAULT": f"{point}:2"})
    assert dead.returncode == -signal.SIGKILL, dead.stderr
    assert RunDirectory.open(out).meta["status"] == "running"  # as the kill left it
    RunDirectory.open(out).load_evaluations()  # readable as it is
    resumed = cli("compare", "--resume", str(out), "-q", "--no-report", site=faulty_site)
    assert resumed.returncode == 0, resumed.stderr
    assert_whole(out, reference)


def test_readers_see_a_consistent_snapshot_while_trials_finish(tmp_path, faulty_site, reference):
    out = tmp_path / "run"
    proc = cli(*ARGS, "--out", str(out), site=faulty_site, env={"GDABENCH_FAULTY_DELAY": "0.005"}, background=True)
    reads, seen = 0, pd.Series(dtype=int)
    try:
        wait_for(lambda: (out / "run.json").exists(), proc, "run.json")
        while proc.poll() is None:
            frame = RunDirectory.open(out).load_evaluations()
            assert not frame.duplicated(["designer", "seed", "generation", "index"]).any()
            counts = frame.groupby(["designer", "seed"]).size()
            assert (
                counts.reindex(seen.index, fill_value=0).to_numpy() >= seen.to_numpy()
            ).all()  # no trial's rows ever vanish
            seen, reads = counts, reads + 1
    finally:
        proc.kill()
    assert proc.returncode == 0 and reads > 10
    assert_whole(out, reference)


# -- signals ----------------------------------------------------------------------------------------
def test_sigterm_is_an_interruption_and_resumes(tmp_path, faulty_site, reference):
    out = tmp_path / "run"
    proc = cli(*ARGS, "--out", str(out), site=faulty_site, env=SLOW, background=True)
    wait_for(lambda: started(out), proc, "a first generation")
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    lines = said(err)
    assert (
        len(lines) == 1 and lines[0].startswith("error: terminated") and f"gdabench compare --resume {out}" in lines[0]
    )
    meta = RunDirectory.open(out).meta
    assert meta["status"] == "interrupted" and "SIGTERM" in meta["error"]
    assert cli("compare", "--resume", str(out), "-q", "--no-report", site=faulty_site).returncode == 0
    assert_whole(out, reference)


@pytest.mark.parametrize("lost", ["gen-000000.parquet", "gen-000002.parquet", "."])
def test_a_generation_file_missing_under_a_checkpoint_is_refused_naming_it(lost, tmp_path, faulty_site, reference):
    out = tmp_path / "run"
    dead = cli(
        *ARGS, "--jobs", "1", "--out", str(out), site=faulty_site, env={"GDABENCH_FAULT": "checkpoint-written:4"}
    )
    assert dead.returncode == -signal.SIGKILL, dead.stderr
    folder = out / "pending" / "ga-seed0"
    written = sorted(p.name for p in folder.glob("gen-*"))
    assert written == [f"gen-{g:06d}.parquet" for g in range(4)]
    left = [] if lost == "." else [name for name in written if name != lost]
    subprocess.run(["rm", "-r", str(folder if lost == "." else folder / lost)], check=True)
    first_missing = folder / ("gen-000000.parquet" if lost == "." else lost)
    for _ in range(2):  # every resume says the same, and writes no generation past the gap
        resumed = cli("compare", "--resume", str(out), "-q", "--no-report", site=faulty_site)
        lines = error_lines(resumed)
        assert resumed.returncode == 1 and len(lines) == 1, resumed.stderr
        assert lines[0].startswith("error: ") and f"{first_missing} is missing" in lines[0], resumed.stderr
        assert sorted(p.name for p in folder.glob("gen-*")) == left
    assert RunDirectory.open(out).meta["status"] == "failed"
    subprocess.run(
        ["rm", "-rf", str(folder), str(out / "checkpoints" / "ga-seed0.pkl")], check=True
    )  # what the line says to do
    assert cli("compare", "--resume", str(out), "-q", "--no-report", site=faulty_site).returncode == 0
    assert_whole(out, reference)


@pytest.mark.parametrize("batch", ["1", "3"], ids=["body by body", "batches of 3"])
def test_a_kill_mid_generation_keeps_the_bodies_it_evaluated(tmp_path, faulty_site, reference, batch):
    """Killed once 3 of the 5 new bodies of ga seed 0's generation 1 were stored (body by body, or a batch)."""
    out, log = tmp_path / "run", tmp_path / "evaluated.txt"
    dead = cli(
        *ARGS,
        "--jobs",
        "1",
        "--batch",
        batch,
        "--out",
        str(out),
        site=faulty_site,
        env={"GDABENCH_FAULT": "outcome-stored:13", "GDABENCH_FAULTY_LOG": str(log)},
    )
    assert dead.returncode == -signal.SIGKILL, dead.stderr
    assert len(RunDirectory.open(out).load_evaluations()) == 10  # generation 1 was not written
    # one trial at a time, as the killed run: ga and random trials of one seed run side by side would both
    # train the generation 0 they share before either has recorded it (a race this test is not about)
    resumed = cli(
        "compare",
        "--resume",
        str(out),
        "--jobs",
        "1",
        "-q",
        "--no-report",
        site=faulty_site,
        env={"GDABENCH_FAULTY_LOG": str(log)},
    )
    assert resumed.returncode == 0, resumed.stderr
    assert_whole(out, reference)
    evaluated = log.read_text().splitlines()
    assert len(evaluated) == len(set(evaluated))  # the bodies scored before the kill were not scored again
    assert not (out / "outcomes").exists()


def snapshot(out: Path) -> dict[str, tuple[int, int]]:
    return {str(p): (p.stat().st_mtime_ns, p.stat().st_size) for p in out.rglob("*") if p.is_file()}


def test_workers_stop_writing_the_moment_the_driver_is_killed(tmp_path, faulty_site):
    """The run directory has one writer: with it killed, its trial workers (and their evaluation workers)
    once went on for seconds and wrote outcome files into the directory of a run nobody held."""
    out, log = tmp_path / "run", tmp_path / "evaluated.txt"
    proc = cli(
        *ARGS,
        "--jobs",
        "2",
        "--out",
        str(out),
        site=faulty_site,
        background=True,
        env={"GDABENCH_FAULTY_DELAY": "0.05", "GDABENCH_FAULTY_LOG": str(log)},
    )
    wait_for(lambda: len(list(out.glob("outcomes/*/*"))) >= 4, proc, "outcomes written by the workers")
    proc.kill()
    proc.wait(timeout=30)
    before, evaluated = snapshot(out), log.read_text()
    time.sleep(2.5)  # the old watcher threads noticed within a second, and an evaluation then still finished
    assert snapshot(out) == before
    assert log.read_text() == evaluated  # and nothing was evaluated any more


def test_wall_time_adds_up_the_first_run_and_every_resume(tmp_path, faulty_site, reference):
    """run.json once had no wall time but its timestamps, which either count only the last resume or the
    pauses between the parts; it keeps each part's time and their sum (a part killed with kill -9 records none)."""
    out = tmp_path / "run"
    for stop in (signal.SIGTERM, signal.SIGKILL):  # a first run stopped, a resume killed, a resume that completes
        args = ["compare", "--resume", str(out), "-q", "--no-report"] if out.exists() else [*ARGS, "--out", str(out)]
        proc = cli(*args, site=faulty_site, env=SLOW, background=True)
        before = len(list(out.glob("pending/*/gen-*.parquet")))
        wait_for(lambda n=before: len(list(out.glob("pending/*/gen-*.parquet"))) > n, proc, "a new generation")
        proc.send_signal(stop)
        proc.communicate(timeout=60)
        time.sleep(1.5)  # a pause between two parts is no part of the run's time
    started = time.monotonic()
    assert cli("compare", "--resume", str(out), "-q", "--no-report", site=faulty_site).returncode == 0
    last = time.monotonic() - started
    assert_whole(out, reference)
    meta = RunDirectory.open(out).meta
    first, killed, resumed = meta["wall_seconds_by_part"]
    assert len(meta["resumed"]) == 2 and killed is None and 0 < first and 0 < resumed < last
    assert meta["wall_seconds"] == pytest.approx(first + resumed, abs=0.002)
    assert meta["wall_seconds"] > resumed  # not just the last part


def test_trials_that_propose_the_same_body_score_it_once(tmp_path, faulty_site, reference):
    """ga and random share generation 0 under a seed (Evolution Gym's sampler): the run trains it once."""
    out, log = tmp_path / "run", tmp_path / "evaluated.txt"
    result = cli(*ARGS, "--jobs", "1", "--out", str(out), site=faulty_site, env={"GDABENCH_FAULTY_LOG": str(log)})
    assert result.returncode == 0, result.stderr
    assert_whole(out, reference)  # the replayed rows are the computed ones: the table is the same
    rows = table(out)
    first = rows[(rows["generation"] == 0) & (rows["seed"] == 0)]
    assert set(first[first["designer"] == "ga"]["body"]) == set(first[first["designer"] == "random"]["body"])
    evaluated = log.read_text().splitlines()
    assert (
        len(evaluated)
        == len(set(evaluated))
        == rows[rows["status"] == "ok"]["body_hash"].groupby(rows["seed"]).nunique().sum()
    )


def test_ctrl_c_pressed_again_and_again_gives_one_line(tmp_path, faulty_site):
    out = tmp_path / "run"
    proc = cli(*ARGS, "--out", str(out), site=faulty_site, env=SLOW, background=True)
    wait_for(lambda: started(out), proc, "a first generation")
    for _ in range(4):
        proc.send_signal(signal.SIGINT)
        time.sleep(0.003)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and said(err)[0].startswith("error: interrupted"), err
    assert RunDirectory.open(out).meta["status"] == "interrupted"


def spawned_children(pid: int) -> list[str]:
    """Worker processes multiprocessing spawned from ``pid`` (its resource tracker is not one)."""
    path = Path(f"/proc/{pid}/task/{pid}/children")
    spawned = []
    for child in path.read_text().split() if path.exists() else []:
        with contextlib.suppress(OSError):  # it may have ended meanwhile
            if "spawn_main" in Path(f"/proc/{child}/cmdline").read_text(errors="replace"):
                spawned.append(child)
    return spawned


@pytest.mark.skipif(
    not Path(f"/proc/{os.getpid()}/task/{os.getpid()}/children").exists(), reason="needs /proc/PID/task/TID/children"
)
def test_ctrl_c_in_a_terminal_while_workers_start_gives_one_line(tmp_path, faulty_site):
    """A terminal's Ctrl-C goes to the whole process group, workers still importing included."""
    env = dict(
        os.environ,
        COLUMNS="200",
        PYTHONPATH=os.pathsep.join(filter(None, [str(faulty_site), os.environ.get("PYTHONPATH")])),
        **SLOW,
    )
    for attempt, pause in enumerate(
        (0.0, 0.25, 0.5, 0.75, 1.0, 1.5)
    ):  # moments of the workers' set-up (imports, unpickling)
        command = [
            sys.executable,
            "-m",
            "gdabench",
            *ARGS,
            "--jobs",
            "2",
            "--workers",
            "2",
            "--out",
            str(tmp_path / f"run{attempt}"),
        ]
        proc = subprocess.Popen(
            command,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
            start_new_session=True,
            preexec_fn=default_sigint,
        )
        wait_for(lambda proc=proc: spawned_children(proc.pid), proc, "a worker process")
        time.sleep(pause)
        while (
            proc.poll() is None
        ):  # again until it ends: one press may land while a worker is being started (ignored then)
            os.killpg(proc.pid, signal.SIGINT)
            try:
                proc.wait(0.5)
            except subprocess.TimeoutExpired:
                pass
        err = proc.stderr.read()
        lines = said(err)
        assert (
            proc.returncode == 130
            and "Traceback" not in err
            and len(lines) == 1
            and lines[0].startswith("error: interrupted")
        ), err


# -- a full disk --------------------------------------------------------------------------------------
@pytest.fixture
def small_disk(tmp_path):
    mount = tmp_path / "disk"
    mount.mkdir()
    made = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=600k", "tmpfs", str(mount)], capture_output=True)
    if made.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here ({made.stderr.decode().strip() or 'not permitted'})")
    yield mount
    subprocess.run(["umount", "-l", str(mount)], capture_output=True)


def test_a_full_disk_fails_the_run_in_one_line_and_keeps_what_was_written(small_disk, faulty_site):
    out = small_disk / "run"
    result = cli(
        "compare",
        "-d",
        "ga,random",
        "--env",
        "faulty",
        "--budget",
        "5000",
        "--seeds",
        "0..3",
        "-q",
        "--no-report",
        "--jobs",
        "1",
        "--out",
        str(out),
        site=faulty_site,
    )
    assert result.returncode == 1, result.stderr
    lines = error_lines(result)
    assert len(lines) == 1 and lines[0].startswith(f"error: no space left on the device of {out}"), result.stderr
    run = RunDirectory.open(out)
    assert run.meta["status"] == "failed" and "no space left" in run.meta["error"]
    assert len(run.load_evaluations()) > 0 and not list(out.rglob("*.tmp"))


def fill(disk: Path) -> None:
    """Leave no free byte on ``disk``."""
    subprocess.run(["dd", "if=/dev/zero", f"of={disk / 'filler'}", "bs=4k"], capture_output=True)


def test_a_full_disk_is_one_line_and_exit_1_for_every_command(small_disk, faulty_site):
    run = small_disk / "run"
    assert (
        cli(
            "compare", "-d", "random", "--budget", "50", "-q", "--no-report", "--out", str(run), site=faulty_site
        ).returncode
        == 0
    )
    fill(small_disk)
    for args, where in [
        (["report", str(run)], run / "report"),
        (["export", str(run)], run / "export" / "ioh"),
        (["export", str(run), "-f", "csv"], run / "export" / "evaluations.csv"),
        (["compare", "-d", "random", "--budget", "50", "-q", "--out", str(small_disk / "new")], small_disk / "new"),
    ]:
        result = cli(*args, site=faulty_site)
        lines = error_lines(result)
        assert result.returncode == 1 and len(lines) == 1, (args, result.stderr)
        assert lines[0].startswith(f"error: no space left on the device of {where}"), result.stderr
        assert not where.exists()
    assert (
        not (small_disk / "new").exists()
        and not list(small_disk.rglob("*.tmp"))
        and not list(small_disk.rglob("*gdabench-*"))
    )


# -- reports and exports ------------------------------------------------------------------------------
@pytest.mark.parametrize("command, made", [(["report"], "report"), (["export"], "export/ioh")])
def test_a_killed_report_or_export_leaves_nothing_half_written(command, made, tmp_path, faulty_site):
    out = tmp_path / "run"
    assert (
        cli(
            "compare", "-d", "random", "--budget", "50", "-q", "--no-report", "--out", str(out), site=faulty_site
        ).returncode
        == 0
    )
    dead = cli(*command, str(out), site=faulty_site, env={"GDABENCH_FAULT": "output-staged"})
    assert dead.returncode == -signal.SIGKILL, dead.stderr
    assert not (out / made).exists()  # nothing, rather than a part
    assert list(out.rglob("*gdabench-*"))  # what the kill left (the next writer clears it)
    (out / "export").mkdir(exist_ok=True)
    (out / "export" / ".evaluations.csv.k1ll3d.tmp").write_text("half a table")  # as a killed CSV export leaves
    for again in (command, ["export", "-f", "csv"]):
        assert cli(*again, str(out), site=faulty_site).returncode == 0
    assert (out / made).is_dir() and not list(out.rglob("*gdabench-*")) and not list(out.rglob("*.tmp"))
    assert (out / "report" / "report.html").exists() or command == ["export"]
    assert locks_left(out, out) == []  # the lock file the kill left is gone too


def locks_left(where: Path, run: Path) -> list[str]:
    """Lock files under ``where`` other than the run's own (held while a run writes it)."""
    return sorted(str(p.relative_to(where)) for p in where.rglob("*.lock") if p != run / ".lock")


def test_report_and_export_leave_no_lock_files(tmp_path):
    """They once left an empty ``.<name>.lock`` beside each output, even after success."""
    out = tmp_path / "run"
    assert (
        CliRunner().invoke(app, ["compare", "-d", "random", "--budget", "50", "-q", "--out", str(out)]).exit_code == 0
    )
    for command in (["export"], ["export", "-f", "csv"], ["report", "--out", str(tmp_path / "elsewhere")]):
        assert CliRunner().invoke(app, [*command, str(out)]).exit_code == 0
    assert (out / "report" / "report.html").exists() and (out / "export" / "evaluations.csv").exists()
    assert locks_left(tmp_path, out) == []


# -- input errors: one line, exit 2, nothing made ----------------------------------------------------
BAD_INPUT = [
    (
        ["-d", "ga[survivors=abc]"],
        "designer 'ga[survivors=abc]': parameter 'survivors' must be an integer or null, got 'abc'",
    ),
    (["-d", "ga[survivors=[5]]"], "parameter 'survivors' must be an integer or null, got [5]"),
    (["-d", "ga[survivors=2.5]"], "parameter 'survivors' must be an integer or null, got 2.5"),
    (["-d", "ga[survivors=true]"], "parameter 'survivors' must be an integer or null, got True"),
    (["-d", "ga[attempts=1.5]"], "parameter 'attempts' must be an integer, got 1.5"),
    (["-d", "ga[max_tries=0]"], "ga: max_tries must be at least 1, got 0"),
    (["-d", "ga,"], "malformed list 'ga,': an empty item"),
    (["-d", "ga,random", "--env", "simple,,nk"], "malformed list 'simple,,nk': an empty item"),
    (["-d", "ga[mutation_rate=high]"], "parameter 'mutation_rate' must be a number, got 'high'"),
    (["-d", "cppn[config=5]"], "cppn: cannot read config file '5'"),
    (["-d", "ga", "--seeds", "99999999999999999999"], "seed must be an integer from 0 to 4294967295"),
    (["-d", "ga", "--seeds", "0..100000000000"], "at most 10000 are allowed"),
    (
        ["-d", "ga", "--population", "1000000000", "--budget", "1000000000"],
        "population must be an integer from 1 to 10,000",
    ),
    (["-d", "cppn", "--population", "1000000000"], "population must be an integer from 1 to 10,000"),
    (["-d", "ga", "--budget", "100000000000"], "budget must be an integer from 1 to 10,000,000"),
    (["-d", "ga", "--shape", "100x100"], "shape must be two sides from 1 to 64 voxels"),
    (
        ["-d", "ga", "--env", "walker", "--controller", "open-loop[trials=-1]"],
        "open-loop: trials must be a positive integer, got -1",
    ),
    (["-d", "ga", "--jobs", "0"], "jobs must be a positive integer"),
]


@pytest.mark.parametrize("args, fragment", BAD_INPUT, ids=[" ".join(a) for a, _ in BAD_INPUT])
def test_bad_input_is_one_line_exit_2_and_makes_nothing(tmp_path, args, fragment):
    out = tmp_path / "run"
    result = CliRunner().invoke(app, ["compare", *args, "--out", str(out), "-q"], env={"COLUMNS": "300"})
    assert result.exit_code == 2, result.stderr
    lines = said(result.stderr)
    assert len(lines) == 1 and lines[0].startswith("error: ") and fragment in lines[0], result.stderr
    assert not out.exists()


def test_evaluate_and_compare_agree_on_bad_input():
    for args in (["--seed", "-1"], ["--env", "walker", "--controller", "open-loop[trials=-1]"]):
        result = CliRunner().invoke(app, ["evaluate", "44444/44444/44444/44444/44444", *args], env={"COLUMNS": "300"})
        lines = said(result.stderr)
        assert result.exit_code == 2 and len(lines) == 1 and lines[0].startswith("error: "), result.stderr


def test_output_paths_that_cannot_be_a_run_directory(tmp_path):
    a_file = tmp_path / "file"
    a_file.write_text("x")
    cases = {
        a_file: "exists and is not a directory",
        a_file / "run": "which is not a directory",
        Path("/proc/gdabench-run"): "cannot create",
    }
    for out, fragment in cases.items():
        result = CliRunner().invoke(app, ["compare", "-d", "random", "--out", str(out), "-q"], env={"COLUMNS": "300"})
        lines = said(result.stderr)
        assert result.exit_code == 2 and len(lines) == 1 and fragment in lines[0], (out, result.stderr)


def test_a_label_too_long_for_a_file_name_runs_reports_and_exports(tmp_path):
    long = "ga[mutation_rate=0." + "1" * 260 + "]"
    out = tmp_path / "run"
    for args in (["compare", "-d", f"{long},random", "--budget", "50", "-q", "--out", str(out)], ["export", str(out)]):
        result = CliRunner().invoke(app, args, env={"COLUMNS": "300"})
        assert result.exit_code == 0, result.stderr
    assert set(RunDirectory.open(out).load_evaluations()["designer"]) == {long, "random"}


def damaged(tmp_path: Path, damage) -> Path:
    """A complete run, then ``damage(run_dir)``."""
    out = tmp_path / "run"
    assert (
        CliRunner()
        .invoke(app, ["compare", "-d", "random", "--budget", "50", "-q", "--no-report", "--out", str(out)])
        .exit_code
        == 0
    )
    damage(out)
    return out


def budget_abc(out: Path) -> None:
    meta = RunDirectory.open(out).meta
    RunDirectory(out).write_meta({**meta, "config": {**meta["config"], "budget": "abc"}})


@pytest.mark.parametrize(
    "damage, command, code, fragment",
    [
        (
            budget_abc,
            ["compare", "--resume"],
            2,
            "run.json: config: budget must be an integer from 1 to 10,000,000, got 'abc'",
        ),
        (
            budget_abc,
            ["report"],
            0,
            "run.json has no readable configuration; budget and seeds are taken from the table",
        ),
        (
            lambda out: (out / "evaluations.parquet").unlink(),
            ["compare", "--no-report", "--resume"],
            2,
            "is complete but its table",
        ),
        (lambda out: (out / "run.json").write_bytes(b'{"a": "\xff"}'), ["compare", "--config"], 2, "is not UTF-8 text"),
    ],
)
def test_a_damaged_run_is_one_line_not_an_internal_error(tmp_path, damage, command, code, fragment):
    out = damaged(tmp_path, damage)
    result = CliRunner().invoke(
        app, [*command, str(out / "run.json" if "--config" in command else out)], env={"COLUMNS": "300"}
    )
    lines = said(result.stderr)
    assert result.exit_code == code and fragment in lines[0] and len(lines) == 1, result.stderr
    assert "internal error" not in result.stderr


@pytest.mark.parametrize(
    "content, fragment", [("[1, 2]", "is not a JSON object"), ('{"format": "gdabench-run/1"}', "has no 'config' table")]
)
def test_a_damaged_run_json_is_one_line(tmp_path, content, fragment):
    (tmp_path / "run.json").write_text(content)
    for command in (["compare", "--resume", str(tmp_path)], ["report", str(tmp_path)]):
        result = CliRunner().invoke(app, command, env={"COLUMNS": "300"})
        assert result.exit_code == 2 and fragment in result.stderr and result.stderr.count("\n") == 1, result.stderr


def test_an_error_is_the_first_line_on_stderr(tmp_path):
    """Not an empty line before it (a progress display that never started printed one)."""
    for args in (["compare", "-d", "nope", "--out", str(tmp_path / "run")], ["compare", "--resume", str(tmp_path)]):
        result = subprocess.run(
            [sys.executable, "-m", "gdabench", *args],
            capture_output=True,
            text=True,
            env=dict(os.environ, COLUMNS="300"),
        )
        assert result.returncode == 2 and result.stderr.startswith("error: ") and result.stderr.count("\n") == 1, (
            result.stderr
        )


def test_usage_errors_are_one_line_too():
    for args in (["compare", "--budget", "abc"], ["compare", "--nope"], ["frobnicate"]):
        result = subprocess.run(
            [sys.executable, "-m", "gdabench", *args],
            capture_output=True,
            text=True,
            env=dict(os.environ, COLUMNS="300"),
        )
        lines = said(result.stderr)
        assert result.returncode == 2 and len(lines) == 1 and lines[0].startswith("error: "), result.stderr
