"""Every script under benchmarks/ still starts, and every figure reproducer that can still makes its figure.

The figures in docs/benchmarks/ cite these scripts as the commands that reproduce them, so a script
broken by a refactor (a removed helper it imports, a renamed option or column) would leave a figure nobody
can reproduce. Starting with ``--help`` catches the first; only running it catches the others, so each
script of ``figures/`` and ``compare/`` is run at tiny sizes here (:data:`SMOKE`), run by another test
(:data:`ELSEWHERE`), or says why it cannot be (:data:`HELP_ONLY`: Evolution Gym, a GPU, or a cost out of
proportion). Smoke runs work in the test's own folder and write only there.
"""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"
SCRIPTS = sorted(p for p in BENCHMARKS.glob("*/*.py") if "__main__" in p.read_text())
REFERENCE = ROOT / "results" / "reference" / "simple"
OUTPUT = ROOT / "docs" / "benchmarks" / "output"


def _name(path: Path) -> str:
    return f"{path.parent.name}/{path.name}"


#: figure reproducers run here at tiny sizes: their arguments ({tmp}: the test's folder, also the working
#: directory; {root}: the repository) and a line their output must hold
SMOKE: dict[str, tuple[str, str]] = {
    "figures/random_sampler.py": ("--bodies 2 --shapes 5x5", "| 5x5 |"),
    "figures/gda_quality_table.py": ("{root}/results/reference/simple", "| `gda` | 10 |"),
    "figures/report_speed.py": ("{tmp}/run -n 1", "median"),  # a copy of the committed run: it writes the report
    "figures/thesis_budget.py": (  # the page's table from the committed rows, read twice as two parts' files
        "table --rows {root}/docs/benchmarks/output/thesis-budget.csv,{root}/docs/benchmarks/output/thesis-budget.csv"
        " --markdown {tmp}/table.md",
        "spearman_author",
    ),
    "figures/voxel_gpu.py": (  # --dry-run: the CPU engine in the GPU's place
        "--dry-run --agree 2 --batches 4 --cpu-batches 4 --distinct 4 --seconds 0.05 --repeats 1 --shapes 8x8"
        " --shape-batch 4 --block-sweep 32 --out {tmp}/gpu.json",
        "agreement",
    ),
    "figures/codesign_gpu.py": (  # a CPU arm (the learner on the CPU); it stops at its timesteps, far before 10 min
        "--arms cpu:evogym2 --bodies 2 --timesteps 256 --minutes 10 --out {tmp}/cg.json",
        '"finished": true',
    ),
    "compare/voxel_speed.py": (  # without Evolution Gym: the engine's half of the table
        "--shapes 5x5 --batches 1,4 --bodies 4 --seconds 0.05 --repeats 1",
        "| 5x5 | 4 |",
    ),
    "compare/walker_stability.py": ("--bodies 3 --steps 50 --engine voxel", "undetected problems: 0"),
    "compare/before_after.py": (  # this tree on both sides, the engine job alone (the main job is gda's minutes)
        "--before {root} --jobs engine --rounds 1 --engine-steps 5",
        "after/before",
    ),
}

#: figure reproducers that another test runs at tiny sizes
ELSEWHERE = {
    "figures/bench_scale.py": "tests/benchmarks/test_bench_scale.py",
    "figures/landscape_table.py": "tests/test_landscape_table.py",
    "figures/scaling_table.py": "tests/test_scaling_table.py",
    "compare/ppo_clip_loss.py": "tests/test_torchrl.py (the check of the numbers; timing is its other part)",
    "compare/task_parity.py": "tests/test_task_benchmarks.py (the voxel engine standing in for Evolution Gym)",
    "compare/task_fidelity.py": "tests/test_task_benchmarks.py (the voxel engine standing in for Evolution Gym)",
    "compare/task_stability.py": "tests/test_task_benchmarks.py (the voxel engine standing in for Evolution Gym)",
    "compare/walker_fidelity.py": "plugins/gdabench-evogym/tests/test_evogym.py (in the plugin's venv)",
}

#: scripts started with --help only, and why
HELP_ONLY = {
    "figures/controllers_compare.py": "trains two generations of PPO four ways: minutes even at the smallest sizes",
    "figures/engine_threads_load.py": "keeps a busy process spinning on a core on purpose, the load it measures",
    "figures/gda_isa_cost.py": "gda compiled, twice (a minute of torch.compile before the first figure)",
    "figures/gda_step.py": "torch.compile of the default variant (about 30 s of CPU even at one epoch)",
    "figures/main_job.py": "the main job itself, with gda",
    "figures/ppo_schedules.py": "PPO training of one rollout under two schedules: about 35 s of CPU at the least",
    "compare/codesign_speed.py": "its arms need an older commit's worktree or Evolution Gym and stable-baselines3",
    "compare/evogym_record.py": "needs Evolution Gym (records its trajectories)",
    "compare/ppo_batch_of_one.py": "needs an older commit's worktree (--before)",
    "compare/ppo_vs_sb3.py": "needs stable-baselines3 (not a dependency)",
    "compare/task_speed.py": "needs Evolution Gym (times it)",
    "compare/walker_transfer.py": "needs Evolution Gym (trains the bodies in it)",
}


def test_the_scripts_are_found():
    found = {_name(p) for p in SCRIPTS}
    assert {"figures/main_job.py", "figures/gda_step.py", "compare/task_parity.py", "ops/reference_results.py"} <= found
    assert {p.parent.name for p in SCRIPTS} == {"figures", "compare", "research", "ops"}


def test_every_figure_reproducer_is_smoke_run_or_says_why_not():
    reproducers = {_name(p) for p in SCRIPTS if p.parent.name in ("figures", "compare")}
    listed = [*SMOKE, *ELSEWHERE, *HELP_ONLY]
    assert len(listed) == len(set(listed)), "a script in two lists"
    assert reproducers == set(listed)
    for name, where in ELSEWHERE.items():
        assert (ROOT / where.split()[0]).is_file() and Path(name).stem in (ROOT / where.split()[0]).read_text()


@pytest.mark.parametrize("script", SCRIPTS, ids=_name)
def test_a_benchmark_script_starts_and_shows_its_usage(script):
    done = subprocess.run(
        [sys.executable, str(script), "--help"], capture_output=True, text=True, cwd=ROOT, timeout=300
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "usage:" in done.stdout


#: modules that load torch when imported
TORCH = ("torch", "tensordict", "torchrl")


def _imports(script: Path, nested: bool) -> list[tuple[int, str]]:
    """(line, top-level module) of each import in ``script``: at module level, or with ``nested`` anywhere."""
    tree = ast.parse(script.read_text())
    found = []
    for node in ast.walk(tree) if nested else tree.body:
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name.split(".")[0]) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            found.append((node.lineno, node.module.split(".")[0]))
    return found


TORCH_SCRIPTS = [p for p in SCRIPTS if any(name in TORCH for _, name in _imports(p, nested=True))]


def test_the_scripts_that_use_torch_are_found():
    assert {"figures/gda_step.py", "figures/controllers_compare.py", "compare/ppo_clip_loss.py"} <= {
        _name(p) for p in TORCH_SCRIPTS
    }


@pytest.mark.parametrize("script", TORCH_SCRIPTS, ids=_name)
def test_a_benchmark_script_that_uses_torch_imports_gdabench_first(script):
    """gdabench pins torch's CPU kernels when it is imported before torch (gdabench.cpu): a script that loads
    torch first measures kernels (and rounding) that no gdabench run uses. Imported at module level, before
    any import of torch anywhere in the script, gdabench comes first whichever function runs."""
    first_torch = min(line for line, name in _imports(script, nested=True) if name in TORCH)
    ours = [line for line, name in _imports(script, nested=False) if name == "gdabench"]
    assert ours and min(ours) < first_torch, f"import gdabench at module level, before line {first_torch}"


@pytest.mark.parametrize("name", sorted(SMOKE))
def test_a_figure_reproducer_runs_at_tiny_sizes(name, tmp_path):
    args, expected = SMOKE[name]
    if name == "figures/report_speed.py":
        shutil.copytree(REFERENCE, tmp_path / "run")
    before = {p: p.stat().st_mtime_ns for p in OUTPUT.rglob("*")}
    done = subprocess.run(
        [sys.executable, str(BENCHMARKS / name), *(a.format(tmp=tmp_path, root=ROOT) for a in args.split())],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert expected in done.stdout + done.stderr
    assert {p: p.stat().st_mtime_ns for p in OUTPUT.rglob("*")} == before  # docs' outputs untouched
