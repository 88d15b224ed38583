"""What the documentation promises and the site build cannot check.

The README's quick start is CI's test command and the main job; its table is the committed reference
run's; its designer sketch and the plugin guide's example (docs/examples/gdabench-checkerboard) work.
Broken links, anchors and API references are the job of ``mkdocs build --strict`` in .ci/run.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from test_plugins import gdabench_cli, pip_install

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
MAIN_JOB = "gdabench compare --designers ga,cppn,gda --env simple"
EXAMPLE = ROOT / "docs" / "examples" / "gdabench-checkerboard"


def bash_blocks(text: str) -> list[str]:
    return [block.strip() for block in re.findall(r"```bash\n(.*?)```", text, re.S)]


def test_quick_start_is_the_main_job_and_cis_test_command():
    main_job, tests = bash_blocks(README.split("## Quick start", 1)[1])[:2]
    setup = "python3 -m venv .venv && . .venv/bin/activate && pip install torch==2.13.0 && pip install -e ."
    assert main_job == f"{setup} && {MAIN_JOB}"
    ci_lines = (ROOT / ".ci" / "run").read_text().splitlines()
    assert tests in ci_lines, "README's test command and .ci/run's must be identical"


def test_readme_table_is_the_reference_runs():
    summary = (ROOT / "results" / "reference" / "simple" / "report" / "summary.md").read_text()
    table = re.search(r"## Summary per designer\n\n((?:\|.*\n)+)", summary).group(1)
    assert table in README, "regenerated reference run: copy its table (report/summary.md) into the README"
    assert "results/reference/simple/report/best_so_far.png" in README


WALKER_RUN = ROOT / "results" / "reference" / "walker"
WALKER_THESIS_RUN = ROOT / "results" / "reference" / "walker-thesis"


def docs_hooks():
    pytest.importorskip("mkdocs")
    spec = importlib.util.spec_from_file_location("gdabench_docs", ROOT / "docs" / "hooks" / "gdabench_docs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_walker_reference_page_shows_the_committed_runs_own_figures():
    """The page's tables are generated from the committed report: the report must be that of the committed rows
    (a part of the run committed without its report made again fails here), and the run walker.toml's."""
    import pandas as pd

    from gdabench.experiment.build import build_run
    from gdabench.results import RunDirectory
    from gdabench.stats.core import generation_rewards

    page = (ROOT / "docs" / "benchmarks" / "reference-walker.md").read_text()
    assert "<!-- gdabench:thesis-walker -->" in page and "<!-- gdabench:reference-summary walker -->" in page
    run = RunDirectory.open(WALKER_RUN)
    experiment = build_run({"config": ROOT / "experiments" / "walker.toml"}).experiment
    config = run.meta["config"]
    assert [d["name"] for d in config["designers"]] == [d.name for d in experiment.designers]
    assert config["controller"]["label"] == experiment.controller.label
    assert (config["population"], config["budget"], config["seeds"]) == (
        experiment.population,
        experiment.budget,
        list(experiment.seeds),
    )

    rows = generation_rewards(run.load_evaluations())
    committed = pd.read_csv(WALKER_RUN / "report" / "generations.csv")
    pd.testing.assert_frame_equal(committed, rows, check_dtype=False)

    hooks = docs_hooks()
    table = hooks.thesis_walker(ROOT).splitlines()[2:]
    assert len(table) == len(rows.groupby(["designer", "generation"]))
    for (designer, generation), group in rows.groupby(["designer", "generation"]):
        line = next(r for r in table if r.startswith(f"| {designer} | {generation} | {len(group)} | "))
        assert f"| {group['max'].median():.2f} [{group['max'].min():.2f}, {group['max'].max():.2f}] |" in line
        thesis = hooks.thesis_walker_best(ROOT).get(designer, {}).get(generation)
        assert line.endswith(f"| {thesis:.2f} |" if thesis is not None else "|  |")
    assert [r for r in table if r.startswith("| gda | 0 |")][0].endswith("| 6.22 |")  # the thesis's GDA, generation 0
    # the author's published runs (SPEC.md): GDA 6.22, 7.88, 9.55, 8.90, 8.28; GA 8.89 ... 9.53 by 4; CPPN-NEAT 9.56
    author = {d: {g: round(v, 2) for g, v in gens.items()} for d, gens in hooks.thesis_walker_best(ROOT).items()}
    assert [author["gda"][g] for g in range(5)] == [6.22, 7.88, 9.55, 8.90, 8.28]
    assert (author["ga"][0], author["ga"][4], author["cppn"][0]) == (8.89, 9.53, 9.56)
    assert hooks.reference_summary(ROOT, "walker") in (WALKER_RUN / "report" / "summary.md").read_text()


def test_the_thesis_budget_table_is_the_committed_rows_against_the_authors():
    """The thesis-budget page's table comes from docs/benchmarks/output/thesis-budget.csv: each budget's Spearman
    with the author's rewards, recomputed here, and the author's rewards are those of the committed bodies CSV."""
    import pandas as pd
    from scipy.stats import spearmanr

    hooks = docs_hooks()
    assert "<!-- gdabench:thesis-budget -->" in (ROOT / "docs" / "benchmarks" / "thesis-budget.md").read_text()
    rows = pd.read_csv(ROOT / hooks.THESIS_BUDGET)
    author = pd.read_csv(ROOT / hooks.THESIS_BODIES, comment="#").drop_duplicates("body").set_index("body")["reward"]
    assert (rows["author"] == rows["body"].map(author)).all() and rows["body"].nunique() >= 24
    table = hooks.thesis_budget(ROOT).splitlines()
    for (budget, seed), g in rows.groupby(["budget", "seed"]):
        line = next(r for r in table if r.startswith(f"| {budget:,} | {seed} | {len(g)} | "))
        assert line.split(" | ")[3] == f"{spearmanr(g['reward'], g['author']).statistic:.2f}"


def test_the_controllers_page_shows_the_committed_comparison_and_codesign_runs():
    """The controller comparison's tables come from its committed outputs: each way's median, Spearman with 4x
    and paired p recomputed here from every body's rewards, and each designer's best per seed from the co-design
    runs' evaluations (a row edited by hand, or an output that the page's numbers do not rest on, fails)."""
    import statistics

    import pandas as pd
    from scipy.stats import spearmanr, wilcoxon

    hooks = docs_hooks()
    page = (ROOT / "docs" / "benchmarks" / "controllers.md").read_text()
    assert "<!-- gdabench:controllers-compare -->" in page and "<!-- gdabench:controllers-codesign -->" in page
    table = hooks.controllers_compare(ROOT).splitlines()
    rows = [r for name in hooks.CONTROLLERS_COMPARE for r in json.loads((ROOT / name).read_text())]
    assert {r["task"] for r in rows if r["budget"] == 12500} >= {"Walker-v0", "Carrier-v0", "Climber-v0"}
    for row in rows:
        rewards = row["rewards"]
        start = next(i for i, line in enumerate(table) if line.startswith(f"| {row['task']}, T = {row['budget']:,} |"))
        for line, way in zip(table[start:], ("scratch", "parent", "modular")):
            cells = [c.strip() for c in line.split("|")[1:-1]]
            assert cells[1] == f"`{way}`" and cells[2] == f"{statistics.median(rewards[way]):.3f}"
            assert cells[6] == f"{spearmanr(rewards[way], rewards['scratch4x']).statistic:.2f}"
            if way != "scratch":
                assert cells[5] == f"{wilcoxon(rewards[way], rewards['scratch']).pvalue:.2g}"
    generations = hooks.controllers_generations(ROOT).splitlines()
    unpinned = [r for name in hooks.CONTROLLERS_UNPINNED for r in json.loads((ROOT / name).read_text())]
    assert "<!-- gdabench:controllers-generations -->" in page and len(unpinned) >= 5
    for column, measured in enumerate((rows, unpinned)):  # the pinned generation, then the unpinned one
        for row in measured:
            line = next(x for x in generations if x.startswith(f"| {row['task']}, {row['budget']:,} |"))
            for cell, way in zip(line.split("|")[2:-1], ("parent", "modular")):
                better = sum(a > b for a, b in zip(row["rewards"][way], row["rewards"]["scratch"]))
                said = cell.strip().split("), ")[column]
                assert said.startswith(f"{better} / {row['children']} (p {row[f'{way}_wilcoxon_p']:.2g}"), (way, line)
    speeds = [[c.strip() for c in line.split("|")[1:-1]] for line in hooks.controllers_speed(ROOT).splitlines()[2:]]
    assert "<!-- gdabench:controllers-speed -->" in page and len(speeds) == len(rows)
    for row, cells in zip(rows, speeds):
        base = row["scratch_steps_per_s"]
        assert cells[:3] == [row["task"], f"{row['budget']:,}", f"{base:,.0f}"]
        assert cells[3].endswith(f"({row['parent_steps_per_s'] / base:.2f}x)")
        assert cells[5].startswith(f"{row['scratch4x_steps_per_s']:,.0f} (")
    progress = [[c.strip() for c in line.split("|")[1:-1]] for line in hooks.controllers_record(ROOT).splitlines()[2:]]
    assert "<!-- gdabench:controllers-record -->" in page
    for row in rows:  # a row is read from a record that has every child of every way
        cells = next(c for c in progress if c[:2] == [row["task"], f"{row['budget']:,}"])
        assert cells[3:] == [f"{row['children']} / {row['children']}"] * 4 + ["(its row)"] * 2, cells
    assert len(progress) == 3 * len({row["task"] for row in rows})  # every task at 12,500, 50,000 and 200,000
    runs = pd.read_csv(ROOT / hooks.CONTROLLERS_CODESIGN)
    assert set(runs["controller"]) == {"ppo", "ppo[init=parent]", "modular-ppo"} and set(runs["seed"]) == {0, 1, 2}
    codesign = [[c.strip() for c in line.split("|")[1:-1]] for line in hooks.controllers_codesign(ROOT).splitlines()]
    for (controller, designer), g in runs.groupby(["controller", "designer"]):
        best = g.groupby("seed")["reward"].max()
        row = next(r for r in codesign if r[0] == f"`{controller}`")
        cell = row[codesign[0].index(f"{designer}, best per seed")]
        assert cell == f"{', '.join(f'{v:.2f}' for v in best)} (median {best.median():.2f})"


def test_the_walker_pages_reevaluation_is_the_runs():
    """Raw against re-evaluated best on the walker page, from the committed re-evaluations (once committed)."""
    from gdabench.results import load_reevaluations as load, read_parquet
    from gdabench.stats.reevaluated import trial_scores

    hooks = docs_hooks()
    again = load(WALKER_RUN)
    if again.empty:
        assert "not committed yet" in hooks.walker_reevaluated(ROOT)
        return
    trials = trial_scores(read_parquet(WALKER_RUN / "evaluations.parquet"), again)
    table = hooks.walker_reevaluated(ROOT).splitlines()
    for designer, g in trials.groupby("designer"):
        line = next(r for r in table if r.startswith(f"| {designer} | {len(g)} | "))
        assert f"| {g['raw_best'].median():.2f} | {g['reevaluated_best'].median():.2f} |" in line


def test_the_walker_pages_measures_are_the_runs():
    """Evaluations to a reward and mean best-so-far on the walker page, from the committed rows."""
    hooks = docs_hooks()
    from gdabench.results import read_parquet
    from gdabench.stats.summary import per_run

    rows = read_parquet(WALKER_RUN / "evaluations.parquet")
    table = hooks.walker_measures(ROOT).splitlines()
    reached = per_run(rows, 5.0).groupby("designer")["evals_to_threshold"]
    for designer, to_five in reached:
        line = next(r for r in table if r.startswith(f"| {designer} | 5 | "))
        assert f"| {int(to_five.notna().sum())}/5, " in line
    assert "93.8%" in table[2]  # five seeds: the range, with its own coverage


def test_the_walker_page_describes_each_designers_best_bodies_by_their_materials():
    """The thesis's figure 5.2 claims (noise, a block of horizontal actuators, patches) are checked on the
    committed run's best body of every seed: the table's figures are those bodies', counted afresh here."""
    import numpy as np

    from gdabench.results import read_parquet

    hooks = docs_hooks()
    assert hooks.body_character("44444/44444")["same-material neighbours"] == 1.0
    checker = hooks.body_character("12120/21210/00000")
    assert checker["same-material neighbours"] == 0.0 and checker["voxels"] == 8.0 and checker["rigid"] == 0.5
    assert "<!-- gdabench:walker-bodies -->" in (ROOT / "docs" / "benchmarks" / "reference-walker.md").read_text()

    rows = read_parquet(WALKER_RUN / "evaluations.parquet", columns=["designer", "seed", "body", "reward"])
    table = hooks.walker_bodies(ROOT).splitlines()
    assert table[0] == (
        "| designer | seeds | voxels | rigid | soft | horizontal actuator | vertical actuator "
        "| same-material neighbours |"
    )
    for designer, trials in rows.groupby("designer"):
        bests = [
            np.array([list(map(int, line)) for line in trial.sort_values("reward").body.iloc[-1].split("/")])
            for _, trial in trials.groupby("seed")
        ]
        horizontal = np.mean([(v == 3).sum() / (v > 0).sum() for v in bests])
        same = []
        for v in bests:
            pairs = [
                (v[i, j], v[i + di, j + dj])
                for i in range(v.shape[0])
                for j in range(v.shape[1])
                for di, dj in ((0, 1), (1, 0))
                if i + di < v.shape[0] and j + dj < v.shape[1]
            ]
            filled = [(a, b) for a, b in pairs if a and b]
            same.append(sum(a == b for a, b in filled) / len(filled))
        line = next(r for r in table if r.startswith(f"| {designer} | {len(bests)} | "))
        cells = line.strip("|").split("|")
        assert float(cells[5]) == pytest.approx(horizontal, abs=0.005), designer
        assert float(cells[7]) == pytest.approx(np.mean(same), abs=0.005), designer


def test_the_thesis_statements_are_checked_seed_by_seed():
    """Two made-up seeds, seed 0 built to bear every statement of the thesis out and seed 1 to contradict it."""
    import pandas as pd

    hooks = docs_hooks()
    runs = {  # (designer, seed): per generation, the two bodies' rewards (worst, best)
        ("gda", 0): ([0, 1, 2, 3, 4], [5, 6, 7, 6.5, 6]),
        ("gda", 1): ([4, 3, 2, 1, 0], [7, 6, 5, 6, 7]),
        ("ga", 0): ([0, 1, 2, 3, 4], [1, 2, 3, 4, 5]),
        ("ga", 1): ([4, 3, 2, 1, 0], [5, 6, 7, 8, 9]),
        ("cppn", 0): ([0, 0, 0, 0, 0], [9, 8, 7, 6, 5]),
        ("cppn", 1): ([0, 1, 2, 3, 4], [1, 2, 3, 4, 10]),
    }
    rows = []
    for (designer, seed), (worst, best) in runs.items():
        rewards = [r for pair in zip(worst, best) for r in pair]
        rows += [
            {
                "env": "walker",
                "designer": designer,
                "seed": seed,
                "generation": i // 2,
                "status": "ok",
                "reward": float(r),
                "n_evals": i + 1,
            }
            for i, r in enumerate(rewards)
        ]
    claims = hooks.thesis_claims(pd.DataFrame(rows))
    assert [c["holds"] for c in claims] == [[0], [0], [0], [0], [], [0], [0], []]
    assert all(c["seeds"] == 2 for c in claims)
    assert claims[0]["figures"] == "0: 5.00 to 7.00; 1: 7.00 to 5.00"
    assert claims[-1]["figures"] == "0: cppn; 1: cppn"  # the same winner on both seeds: no variance shown
    assert "<!-- gdabench:walker-claims -->" in (ROOT / "docs" / "benchmarks" / "reference-walker.md").read_text()
    table = hooks.walker_claims(ROOT).splitlines()
    assert len(table) == 2 + len(claims) and all(" seeds | " in line for line in table[2:])


def test_the_thesis_variants_are_set_beside_their_designers_seed_by_seed():
    """A variant (``ga[survivors=5]``) takes its designer's place in the thesis's statements and sits beside it
    per seed; a trial still running is left out, and each pair's medians are over the seeds both have run."""
    import pandas as pd

    hooks = docs_hooks()

    def trial(label: str, seed: int, rewards: list[float], budget: int = 3) -> list[dict]:
        return [
            {
                "designer": label,
                "designer_name": label.split("[")[0],
                "seed": seed,
                "generation": i,
                "status": "ok",
                "reward": r,
                "n_evals": i + 1,
                "budget": budget,
            }
            for i, r in enumerate(rewards)
        ]

    main = pd.DataFrame(
        trial("ga", 0, [1, 2, 3])
        + trial("ga", 1, [1, 1, 5])
        + trial("gda", 0, [2, 2, 2])
        + trial("gda", 1, [4, 4, 4])
        + trial("cppn", 0, [9, 9, 9])
    )
    variants = pd.DataFrame(
        trial("ga[survivors=5]", 0, [3, 4, 6])
        + trial("ga[survivors=5]", 1, [0, 7, 1])
        + trial("gda[published_reencoding=true]", 0, [1, 8, 1])
        + trial("gda[published_reencoding=true]", 1, [9, 9])
    )  # seed 1 still running
    done = hooks.finished(variants)
    assert sorted(set(zip(done["designer"], done["seed"]))) == [
        ("ga[survivors=5]", 0),
        ("ga[survivors=5]", 1),
        ("gda[published_reencoding=true]", 0),
    ]

    mixed = hooks.with_variants(main, done)
    assert sorted(set(mixed["designer"])) == ["cppn", "ga", "gda"]
    assert mixed.loc[mixed["designer"] == "ga", "reward"].max() == 7  # the variant's, not the walker run's 5
    assert (mixed.loc[mixed["designer"] == "gda", "seed"] == 0).all()  # walker's gda is replaced on every seed

    table = hooks.variants_table(main, done).splitlines()
    assert table[0] == "| seed | ga | ga[survivors=5] | gda | gda[published_reencoding=true] |"
    assert table[2:] == [
        "| 0 | 3.00 | 6.00 | 2.00 | 8.00 |",
        "| 1 | 5.00 | 7.00 | 4.00 |  |",
        "| median | 4.00 | 6.50 | 2.00 | 8.00 |",
    ]


def test_the_committed_run_of_the_thesis_variants_is_walker_thesis_toml_beside_the_walker_run():
    """The run of the thesis's variants is experiments/walker-thesis.toml's, at the walker run's controller,
    population and budget, and the page shows the best reward of each of its finished trials."""
    from gdabench.experiment.build import build_run
    from gdabench.results import RunDirectory

    hooks = docs_hooks()
    page = (ROOT / "docs" / "benchmarks" / "reference-walker.md").read_text()
    assert "<!-- gdabench:walker-variants walker-thesis -->" in page
    assert "<!-- gdabench:walker-claims walker-thesis -->" in page
    run = RunDirectory.open(WALKER_THESIS_RUN)
    config, walker = run.meta["config"], RunDirectory.open(WALKER_RUN).meta["config"]
    experiment = build_run({"config": ROOT / "experiments" / "walker-thesis.toml"}).experiment
    assert [d["label"] for d in config["designers"]] == [d.label for d in experiment.designers]
    assert config["seeds"] == list(experiment.seeds)
    assert [config[k] for k in ("controller", "population", "budget")] == [
        walker[k] for k in ("controller", "population", "budget")
    ]

    finished = hooks.finished(run.load_evaluations())
    assert len(finished), "no finished trial committed"
    table = hooks.walker_variants(ROOT, "walker-thesis").splitlines()
    for (label, seed), trial in finished.groupby(["designer", "seed"]):
        line = next(r for r in table if r.startswith(f"| {seed} | ")).strip("|").split("|")
        column = table[0].strip("|").split("|").index(f" {label} ")
        assert float(line[column]) == pytest.approx(trial["reward"].max(), abs=0.005), (label, seed)


def test_the_walker_pages_transfer_check_is_of_the_committed_runs_best_bodies():
    """transfer.csv holds finished trials' best bodies with their reward on walker as committed; the page shows
    each of its rows, and ranks the designers by their mean in each simulator as a fresh count does."""
    import pandas as pd

    from gdabench.results import read_parquet

    transfer = pd.read_csv(WALKER_RUN / "transfer.csv", dtype={"body": str})
    rows = read_parquet(WALKER_RUN / "evaluations.parquet", columns=["designer", "seed", "body", "reward"])
    best = rows.loc[rows.groupby(["designer", "seed"])["reward"].idxmax()].set_index(["designer", "seed"])
    assert len(transfer) and not transfer.duplicated(["designer", "seed"]).any()
    for r in transfer.itertuples():
        assert best.loc[(r.designer, r.seed), "body"] == r.body
        assert best.loc[(r.designer, r.seed), "reward"] == pytest.approx(r.walker, abs=1e-9)

    page = docs_hooks().walker_transfer(ROOT).splitlines()
    for r in transfer.itertuples():
        assert f"| {r.designer} | {r.seed} | `{r.body}` | {r.walker:.2f} | {r.evogym:.2f} |" in page
    means = transfer.groupby("designer")[["walker", "evogym"]].mean()
    for column, rank_column in (("walker", 4), ("evogym", 5)):
        for designer, mean in means[column].items():  # ties share the better place
            cells = next(line for line in page if line.startswith(f"| {designer} | ")).strip("|").split("|")
            assert int(cells[rank_column]) == 1 + (means[column] > mean).sum(), (designer, column)


#: how the README and the tutorial name each column of the table a run prints in the terminal
TERMINAL_COLUMNS = {
    "designer": "one row per designer",
    "best": "best reward",
    "hit": "optimum",
    "evals to": "after how many evaluations",
    "seconds": "wall time",
}


def test_readme_and_tutorial_describe_the_terminal_summary_as_printed(tmp_path):
    """They once listed the mean best-so-far among its columns: only the report's table has that one."""
    from typer.testing import CliRunner

    from gdabench.cli import app

    result = CliRunner().invoke(
        app, ["compare", "-d", "ga,random", "--budget", "25", "--out", str(tmp_path / "run"), "-q", "--no-report"]
    )
    assert result.exit_code == 0, result.output
    header = next(line for line in result.output.splitlines() if "┃" in line)
    printed = [cell.strip() for cell in header.split("┃")]
    named = [next(key for key in TERMINAL_COLUMNS if cell.startswith(key)) for cell in printed]
    assert named == list(TERMINAL_COLUMNS), printed
    for page in (README, (ROOT / "docs" / "tutorial.md").read_text()):
        text = " ".join(page.split())
        said = re.search(r"prints a summary table, (one row per designer.*?)the report adds the mean best-so-far", text)
        assert said, (
            "a page no longer says what the terminal's summary table holds, and that the report adds the "
            "mean best-so-far"
        )
        assert all(phrase in said.group(1) for phrase in TERMINAL_COLUMNS.values()), said.group(1)
        assert "best-so-far" not in said.group(1), said.group(1)


def test_readme_designer_sketch_conforms(tmp_path, monkeypatch):
    code = re.search(r"```python\n(import gdabench\n\nclass (\w+)\(gdabench\.Designer\).*?)```", README, re.S)
    assert code, "the README's designer sketch is gone"
    (tmp_path / "readme_sketch.py").write_text(code.group(1))
    monkeypatch.syspath_prepend(str(tmp_path))
    from gdabench.testing import check_designer

    check_designer(getattr(__import__("readme_sketch"), code.group(2)))


@pytest.fixture(scope="module")
def example_site(tmp_path_factory) -> Path:
    return pip_install(EXAMPLE, tmp_path_factory.mktemp("site"))


def test_plugin_guide_example_passes_its_own_tests(example_site):
    env = dict(os.environ, PYTHONPATH=str(example_site))
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(EXAMPLE / "tests")],
        capture_output=True, text=True, env=env, cwd=EXAMPLE,
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr


def test_plugin_guide_example_runs_in_compare(example_site, tmp_path):
    out = tmp_path / "run"
    run = gdabench_cli(
        "compare", "--designers", "hill-climber,random", "--env", "checkerboard", "--budget", "100",
        "--out", str(out), "-q", "--no-report", path=example_site,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert json.loads((out / "run.json").read_text())["versions"]["plugins"]["gdabench-checkerboard"] == "0.1.0"
    bad = gdabench_cli(
        "run", "hill-climber[rate=2]", "--env", "checkerboard", "--out", str(tmp_path / "bad"), path=example_site
    )
    assert bad.returncode == 2 and "hill-climber: rate must be in (0, 1]" in bad.stderr


def test_readme_python_example_runs_as_a_script_anywhere_and_prints_what_it_shows(tmp_path):
    """It once read a run by a path relative to the repository (a traceback elsewhere) and printed nothing."""
    code = re.search(
        r"```python\n(import gdabench\n\nrun = gdabench\.compare.*?)```\n\n```text\n(.*?)```", README, re.S
    )
    assert code, "the README's Python example (and the output it shows) is gone"
    (tmp_path / "example.py").write_text(code.group(1))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    result = subprocess.run([sys.executable, "example.py"], cwd=tmp_path, capture_output=True, text=True, env=env,
                            timeout=600)  # fmt: skip
    assert result.returncode == 0, result.stderr
    strip = lambda text: [line.rstrip() for line in text.splitlines() if not line.startswith("run directory:")]  # noqa: E731
    assert strip(result.stdout) == strip(code.group(2))


def test_every_output_a_page_links_to_is_committed_and_published():
    """mkdocs once left out docs/benchmarks/output/, so the pages' links to its JSON files were dead on the site."""
    import pathspec

    excluded = re.search(r"exclude_docs: \|\n((?:  .*\n)+)", (ROOT / "mkdocs.yml").read_text()).group(1).split()
    spec = pathspec.PathSpec.from_lines("gitwildmatch", excluded)
    docs = ROOT / "docs"
    for page in docs.rglob("*.md"):
        for target in re.findall(r"\]\((output/[^)#]+)\)", page.read_text()):
            path = (page.parent / target).resolve()
            assert path.is_file(), f"{page.relative_to(ROOT)} links to {target}, which is not committed"
            assert not spec.match_file("/" + str(path.relative_to(docs))), f"mkdocs leaves out {target}"


def test_the_evogym_task_page_shows_the_committed_task_outputs():
    """The page of Evolution Gym's tasks is generated from benchmarks/compare/task_*.py's committed outputs: a row per
    task whose parity steps, held-out Spearman and sign agreement, unstable bodies and speed ratio are recomputed here
    from the per-body and per-episode figures, and the tasks it says miss a goal are exactly those."""
    import pandas as pd
    from scipy.stats import fisher_exact, spearmanr

    from gdabench.envs.tasks import CATALOG

    hooks = docs_hooks()
    page = (ROOT / "docs" / "benchmarks" / "evogym-tasks.md").read_text()
    for name in ("summary", "misses", "parity", "control"):
        assert f"<!-- gdabench:evogym-task-{name} -->" in page
    out = ROOT / hooks.TASK_OUTPUT
    read = lambda name, key="tasks": {r["task"]: r for r in json.loads((out / name).read_text())[key]}  # noqa: E731
    parity, speed = read("task-parity.json"), read("task-speed.json", "rows")
    stability = read("task-stability.json") if (out / "task-stability.json").exists() else {}
    episodes = pd.read_csv(out / "task-fidelity.csv")
    rows = {cells[1].strip("` "): [c.strip(" *") for c in cells[2:-1]]
            for cells in (line.split("|") for line in hooks.evogym_task_summary(ROOT).splitlines()[2:])}
    assert list(rows) == list(CATALOG)
    low = {"Spearman": set(), "sign agreement": set(), "10x speed": set(), "unstable rate": set()}
    for task, (_, steps, rho_cell, sign_cell, unstable, _, _, ratio, *_) in rows.items():
        firsts = [b["first_over"]["1e-6"] for b in parity[task]["per_body"] if b["first_over"]["1e-6"] is not None]
        assert steps == (str(min(firsts) - 1) if firsts else "all")
        held = episodes[(episodes["task"] == task) & (episodes["part"] == "held-out")]
        rho = spearmanr(held["return_voxel"], held["return_evogym"]).statistic
        sign = (held["return_voxel"].map(lambda v: (v > 0) - (v < 0)) == held["return_evogym"].map(
            lambda v: (v > 0) - (v < 0))).mean()
        assert (rho_cell, sign_cell) == (f"{rho:.3f}", f"{100 * sign:.1f}%"), task
        if task in stability:
            s = stability[task]
            assert unstable.split(" (")[0] == f"{len(s['unstable_bodies_voxel'])} / {len(s['unstable_bodies_evogym'])}"
            one_only = set(s["unstable_bodies_voxel"]) ^ set(s["unstable_bodies_evogym"])
            nudged = {n["body"]: n for n in s.get("nudged", [])}
            for n in nudged.values():
                assert f"(nudged {n['runs']} times: {n['voxel']} / {n['evogym']})" in unstable
            if any(b not in nudged or fisher_exact([[nudged[b]["voxel"], nudged[b]["runs"] - nudged[b]["voxel"]],
                                                    [nudged[b]["evogym"], nudged[b]["runs"] - nudged[b]["evogym"]]]
                                                   ).pvalue < 0.05 for b in one_only):
                low["unstable rate"].add(task)
        else:
            assert unstable == "not run"
        if task in speed:
            assert ratio == f"{speed[task]['voxel'] / speed[task]['evogym']:.1f}x"
        else:  # Evolution Gym could not build the task's world in the speed run (Traverser-v0)
            assert ratio == "not run"
        for goal, missed in (("Spearman", rho < 0.95), ("sign agreement", sign < 0.95),
                             ("10x speed", task in speed and speed[task]["voxel"] < 10 * speed[task]["evogym"])):
            if missed:
                low[goal].add(task)
    said = {line.split(":")[0]: set(re.findall(r"`([^`]+)`", line.split("miss it")[1].split("; not measured")[0])
                                          if "miss it" in line else [])
            for line in hooks.evogym_task_misses(ROOT).splitlines() if line.startswith("* ")}
    assert said["* held-out Spearman >= 0.95"] == low["Spearman"]
    assert said["* held-out sign agreement >= 95%"] == low["sign agreement"]
    assert said["* at least 10x Evolution Gym's env steps/s"] == low["10x speed"]
    rate = next(line for line in hooks.evogym_task_misses(ROOT).splitlines() if "as many unstable bodies" in line)
    assert set(re.findall(r"`([^`]+)`", rate.split("miss it")[1]) if "miss it" in rate else []) == low["unstable rate"]


def test_the_evogym_task_page_shows_each_disagreements_nudged_runs():
    """The held-out episodes the simulators disagree on, each with its nudged runs' counts from the committed
    ``task-fidelity-nudged.json`` and Fisher's p recomputed from those counts."""
    from scipy.stats import fisher_exact

    hooks = docs_hooks()
    nudged = json.loads((ROOT / hooks.TASK_OUTPUT / "task-fidelity-nudged.json").read_text())["episodes"]
    misses = hooks.evogym_task_misses(ROOT).splitlines()
    table = [[c.strip(" `") for c in line.split("|")[1:-1]] for line in misses if line.startswith("| `")]
    assert {(r[0], r[1], r[2]) for r in table} == {(n["task"], n["body"], n["gait"]) for n in nudged}
    chance = 0
    for n in nudged:
        row = next(r for r in table if (r[0], r[1], r[2]) == (n["task"], n["body"], n["gait"]))
        p = {k: 1.0 if n["voxel"][k] == n["evogym"][k] else fisher_exact(
            [[n["voxel"][k], n["runs"] - n["voxel"][k]], [n["evogym"][k], n["runs"] - n["evogym"][k]]]).pvalue
            for k in ("positive", "ended_early", "unstable")}
        assert row[6] == (f"of {n['runs']}: {n['voxel']['positive']} / {n['evogym']['positive']} "
                          f"(p {p['positive']:.2g}), {n['voxel']['ended_early']} / {n['evogym']['ended_early']} "
                          f"(p {p['ended_early']:.2g}), {n['voxel']['unstable']} / {n['evogym']['unstable']} "
                          f"(p {p['unstable']:.2g})")
        chance += all(v >= 0.05 for v in p.values())
    assert f"in {chance} of them both simulators' runs end each way" in "\n".join(misses)
