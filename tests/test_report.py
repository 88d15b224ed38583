"""`gdabench report`: every plot and table from a small real run, numbers checked against pandas."""

from __future__ import annotations

import base64
import io
import json
import math
import shutil
from html.parser import HTMLParser
from itertools import combinations
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.container import BarContainer, ErrorbarContainer
from PIL import Image
from typer.testing import CliRunner

from gdabench import Body, Environment, EnvironmentSpec, Experiment, PluginChoice, RunDirectoryError, hookimpl
from gdabench.cli import app
from gdabench.errors import ConfigError
from gdabench.execution import Execution
from gdabench.plugins import Registry
from gdabench.report import plots
from gdabench.report.bodies import COLOURS, body_image
from gdabench.report.build import write_report
from gdabench.report.diversity import body_matrix, categorize, diversity
from gdabench.running.events import RunListener
from gdabench.running.runner import compare
from gdabench.seeding import evaluation_seed
from gdabench.stats.core import (
    best_so_far_curve,
    censored_median,
    generation_rewards,
    median_interval,
    order_statistic_ranks,
)

DESIGNERS = ("ga", "random")
SEEDS = (0, 1)
BUDGET = 100
COUNTED = ["ok", "error", "timeout"]


def _experiment(designers=DESIGNERS, env="simple", seeds=SEEDS, budget=BUDGET) -> Experiment:
    return Experiment(
        designers=tuple(PluginChoice(d, {}, d) for d in designers),
        envs=PluginChoice(env, {}, env),
        budget=budget,
        seeds=tuple(seeds),
    )


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    """`compare --designers ga,random --env simple --budget 100 --seeds 0,1`, without a report."""
    return compare(_experiment(), tmp_path_factory.mktemp("runs") / "small").path


@pytest.fixture(scope="module")
def report(run_dir):
    return write_report(run_dir)


@pytest.fixture(scope="module")
def table(run_dir) -> pd.DataFrame:
    return pd.read_parquet(run_dir / "evaluations.parquet")


@pytest.fixture(scope="module")
def one_generation(tmp_path_factory) -> pd.DataFrame:
    """The evaluations of `compare --designers ga,random --env simple --budget 25 --seeds 0,1`: one generation."""
    return compare(_experiment(budget=25), tmp_path_factory.mktemp("runs") / "one").load_evaluations()


# -- what is written ------------------------------------------------------------------------------
def test_every_plot_and_table_is_written(report, run_dir):
    out = run_dir / "report"
    assert report.out == out
    expected_pngs = ["best_so_far.png", "rewards_per_generation.png", "best_bodies.png", "diversity.png", "novelty.png"]
    expected_pngs += [f"bodies_per_generation_{d}.png" for d in DESIGNERS] + ["ecdf_simple.png"]
    for name in expected_pngs:
        image = Image.open(out / name)
        assert image.format == "PNG" and image.width > 300 and image.height > 150, name
        # a plot is not a blank canvas: it has many distinct colours
        assert len(np.unique(np.asarray(image.convert("RGB")).reshape(-1, 3)[::13], axis=0)) > 5, name
    assert sorted(f.filename for f in report.figures) == sorted(expected_pngs)  # simple has nothing to animate
    for name in ["summary.csv", "runs.csv", "generations.csv", "best_so_far.csv", "diversity.csv"]:
        assert len(pd.read_csv(out / name)) > 0, name
    markdown = (out / "summary.md").read_text()
    for name in expected_pngs:
        assert f"]({name})" in markdown
    for row in report.rows:
        assert "| " + " | ".join(row) + " |" in markdown


def test_report_is_reproducible(report, run_dir, tmp_path):
    again = write_report(run_dir, tmp_path / "again")
    assert again.rows == report.rows
    for fig in report.figures:
        assert (tmp_path / "again" / fig.filename).read_bytes() == fig.data, fig.filename
    assert (tmp_path / "again" / "report.html").read_text() == (run_dir / "report" / "report.html").read_text()


# -- numbers against a direct pandas computation -------------------------------------------------
def _runs(table: pd.DataFrame):
    return table.groupby(["designer", "seed"])


def test_best_reward_and_wall_time_match_pandas(report, table, run_dir):
    summary = pd.read_csv(run_dir / "report" / "summary.csv").set_index("designer")
    best = table[table["status"] == "ok"].groupby(["designer", "seed"])["reward"].max()
    wall = table.groupby(["designer", "seed"])["elapsed_seconds"].max()
    for designer in DESIGNERS:
        assert summary.loc[designer, "best_median"] == pytest.approx(best[designer].median())
        low, high = summary.loc[designer, "best_ci_low"], summary.loc[designer, "best_ci_high"]
        assert best[designer].min() <= low <= best[designer].median() <= high <= best[designer].max()
        assert summary.loc[designer, "wall_seconds_median"] == pytest.approx(wall[designer].median())
        assert summary.loc[designer, "seeds"] == len(SEEDS)
    cells = {row[0]: row for row in report.rows}
    assert cells["ga"][3].startswith(f"{best['ga'].median():.4g}")


def test_area_under_best_so_far_matches_the_tables_own_column(table, run_dir, report):
    """Mean best-so-far (area / evaluations) from the report vs the runner's best_so_far column."""
    runs = pd.read_csv(run_dir / "report" / "runs.csv").set_index(["designer", "seed"])
    for (designer, seed), g in _runs(table):
        counted = g[g["status"].isin(COUNTED)]
        assert runs.loc[(designer, seed), "mean_best_so_far"] == pytest.approx(counted["best_so_far"].mean())
        assert runs.loc[(designer, seed), "evaluations"] == len(counted) == BUDGET


def test_evaluations_to_threshold_are_censored(run_dir, table, tmp_path):
    """A threshold some runs reach and others do not: reached runs give their first n_evals, the others inf."""
    best = table[table["status"] == "ok"].groupby(["designer", "seed"])["reward"].max()
    threshold = float(best.sort_values().iloc[len(best) // 2])  # reached by about half of the runs
    report = write_report(run_dir, tmp_path, threshold=threshold)
    summary = pd.read_csv(tmp_path / "summary.csv").set_index("designer")
    runs = pd.read_csv(tmp_path / "runs.csv").set_index(["designer", "seed"])
    for (designer, seed), g in _runs(table):
        hit = g[(g["status"] == "ok") & (g["reward"] >= threshold)]["n_evals"]
        expected = float(hit.min()) if len(hit) else math.nan
        got = runs.loc[(designer, seed), "evals_to_threshold"]
        assert (math.isnan(got) and math.isnan(expected)) or got == expected
    for designer in DESIGNERS:
        per_seed = [runs.loc[(designer, s), "evals_to_threshold"] for s in SEEDS]
        times = [math.inf if math.isnan(v) else v for v in per_seed]
        assert summary.loc[designer, "evals_to_threshold_median"] == np.median(times)
        assert summary.loc[designer, "seeds_reached"] == sum(not math.isnan(v) for v in per_seed)
    assert summary["seeds_reached"].sum() >= 1 and (summary["seeds_reached"] < len(SEEDS)).any()
    cells = [row[5] for row in report.rows]
    assert any("not reached" in c for c in cells)
    assert f"seeds reaching {threshold:.4g}" in report.headers


def test_default_threshold_is_the_environment_optimum(report, run_dir):
    summary = pd.read_csv(run_dir / "report" / "summary.csv")
    assert (summary["threshold"] == 100.0).all()  # simple 5x5: 25 vertical actuators
    assert "seeds reaching 100" in report.headers


def test_reward_per_generation_matches_pandas(table, run_dir, report):
    gens = pd.read_csv(run_dir / "report" / "generations.csv").set_index(["designer", "seed", "generation"])
    ok = table[table["status"] == "ok"]
    direct = ok.groupby(["designer", "seed", "generation"])["reward"].agg(["min", "mean", "max", "count"])
    assert len(gens) == len(direct)
    for key, row in direct.iterrows():
        assert gens.loc[key, "min"] == row["min"] and gens.loc[key, "max"] == row["max"]
        assert gens.loc[key, "mean"] == pytest.approx(row["mean"])
        assert gens.loc[key, "evaluated"] == row["count"]


def test_best_so_far_curve_matches_pandas(table, run_dir, report):
    curve = pd.read_csv(run_dir / "report" / "best_so_far.csv").set_index(["designer", "evaluations"])
    for designer in DESIGNERS:
        for n in (1, 7, 25, 60, BUDGET):
            values = []
            for seed in SEEDS:
                g = table[(table["designer"] == designer) & (table["seed"] == seed) & table["status"].isin(COUNTED)]
                values.append(g[g["n_evals"] <= n]["best_so_far"].iloc[-1])
            row = curve.loc[(designer, n)]
            assert row["median"] == pytest.approx(np.median(values))
            assert min(values) <= row["ci_low"] <= row["median"] <= row["ci_high"] <= max(values)
            assert row["runs"] == len(SEEDS) and row["ci_level"] == order_statistic_ranks(len(SEEDS))[1]


def test_diversity_matches_a_brute_force_count(table, run_dir, report):
    div = pd.read_csv(run_dir / "report" / "diversity.csv").set_index(["designer", "seed", "generation"])
    for (designer, seed, generation), g in table.groupby(["designer", "seed", "generation"]):
        row = div.loc[(designer, seed, generation)]
        assert row["proposals"] == len(g)
        assert row["unique"] == g["body_hash"].nunique()
        texts = [t.replace("/", "") for t in g["body"]]
        pairs = [sum(a != b for a, b in zip(x, y)) for x, y in combinations(texts, 2)]
        assert row["mean_pairwise_hamming"] == pytest.approx(np.mean(pairs))
        same_trial = (table["designer"] == designer) & (table["seed"] == seed)
        earlier = table[same_trial & (table["generation"] < generation) & (table["status"] == "ok")]
        if generation == 0:
            assert math.isnan(row["nearest_survivor_mean"])
            continue
        survivors = [
            t.replace("/", "") for t in earlier.sort_values("reward", ascending=False, kind="stable")["body"].head(5)
        ]
        nearest = [min(sum(a != b for a, b in zip(x, s)) for s in survivors) for x in texts]
        assert row["nearest_survivor_mean"] == pytest.approx(np.mean(nearest))
        shares = row[["share_copy", "share_near_copy", "share_new_materials", "share_novel_shape"]]
        assert shares.sum() == pytest.approx(1.0)
        assert row["share_copy"] + row["share_near_copy"] == pytest.approx(np.mean([d <= 3 for d in nearest]))


def test_diversity_categories():
    survivor = body_matrix(["44444/44444/44444/00000/00000"])
    proposals = body_matrix(
        [
            "44444/44444/44444/00000/00000",  # copy
            "44443/44444/44444/00000/00000",  # near-copy (1 voxel)
            "33333/33333/44444/00000/00000",  # same shape, other materials (10 voxels)
            "40000/40000/40000/40000/40000",  # novel shape
        ]
    )
    distance, category = categorize(proposals, survivor, near_copy=3)
    assert distance.tolist() == [0, 1, 10, 14]
    assert category.tolist() == [0, 1, 2, 3]


# -- the HTML file ---------------------------------------------------------------------------------
class _Refs(HTMLParser):
    def __init__(self):
        super().__init__()
        self.refs: list[tuple[str, str, str]] = []
        self.tags: list[str] = []
        self.cells = 0

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.cells += tag == "td"
        for name, value in attrs:
            if name in ("src", "href", "srcset", "data", "poster", "action"):
                self.refs.append((tag, name, value or ""))


def test_html_is_self_contained(report, run_dir):
    text = (run_dir / "report" / "report.html").read_text()
    parser = _Refs()
    parser.feed(text)
    parser.close()
    assert parser.tags[0] == "html" and "body" in parser.tags and "table" in parser.tags
    images = [r for r in parser.refs if r[0] == "img"]
    assert len(images) == len(report.figures)
    assert all(value.startswith("data:image/png;base64,") for _, _, value in images)
    assert [r for r in parser.refs if r[0] != "img"] == []  # no links, scripts, stylesheets
    assert "url(" not in text and "@import" not in text and "<link" not in text and "<script" not in text
    for _, _, value in images:  # every embedded image decodes
        assert Image.open(io.BytesIO(base64.b64decode(value.split(",", 1)[1]))).format == "PNG"
    for row in report.rows:
        for cell in row:
            assert f"<td>{cell}</td>" in text


# -- body images -------------------------------------------------------------------------------------
def test_body_image_uses_evolution_gym_colours():
    body = Body.from_text("01234/44444/44444/44444/44444")
    image = body_image(body, scale=10)
    assert image.shape == (50, 50, 4)
    for code in range(5):
        assert tuple(image[5, code * 10 + 5]) == COLOURS[code]
    assert image[5, 5, 3] == 0  # empty is transparent
    assert COLOURS[1][:3] < (60, 60, 60)  # rigid black
    r, g, b, _ = COLOURS[3]
    assert r > 200 and 100 < g < 180 and b < 100  # horizontal actuator orange
    r, g, b, _ = COLOURS[4]
    assert b > 180 and r < 130  # vertical actuator blue


# -- statistics ------------------------------------------------------------------------------------
def test_median_intervals_and_censoring():
    assert censored_median([10.0, math.nan, math.nan]) == math.inf
    assert censored_median([10.0, 20.0, math.nan]) == 20.0
    five = median_interval([4.0, 1.0, 100.0, 3.0, 2.0])  # 5 seeds: the range, which covers 93.75%
    assert (five.median, five.low, five.high, five.level) == (3.0, 1.0, 100.0, 0.9375)
    censored_runs = median_interval([5.0, math.inf, math.inf])
    assert censored_runs.low == 5.0 and censored_runs.high == math.inf
    one = median_interval([7.0])
    assert (one.low, one.high, one.level) == (7.0, 7.0, 0.0)


def test_best_so_far_curve_skips_failures_and_stops_where_the_run_stopped():
    run = pd.DataFrame(
        {
            "status": ["error", "ok", "invalid", "ok", "error", "ok"],
            "reward": [math.nan, 5.0, math.nan, 3.0, math.nan, 9.0],
            "n_evals": [1, 2, 2, 3, 4, 5],
        }
    )
    curve = best_so_far_curve(run, 7)
    assert np.isnan(curve[0]) and curve[1:5].tolist() == [5.0, 5.0, 5.0, 9.0] and np.isnan(curve[5:]).all()


# -- bad input -------------------------------------------------------------------------------------
def _copy(run_dir: Path, tmp_path: Path) -> Path:
    dest = tmp_path / "copy"
    shutil.copytree(run_dir, dest, ignore=shutil.ignore_patterns("report"))
    return dest


def _cli_error(args: list[str]) -> str:
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), result.output
    return lines[0]


def test_not_a_run(tmp_path):
    assert "not a directory" in _cli_error(["report", str(tmp_path / "missing")])
    assert "not a gdabench run" in _cli_error(["report", str(tmp_path)])


def test_corrupt_or_missing_files(run_dir, tmp_path):
    bad = _copy(run_dir, tmp_path)
    (bad / "evaluations.parquet").write_bytes(b"not parquet at all")
    assert "cannot read" in _cli_error(["report", str(bad)])
    (bad / "evaluations.parquet").unlink()
    assert "has no evaluations yet" in _cli_error(["report", str(bad)])
    pd.DataFrame({"designer": ["ga"], "seed": [0], "reward": [1.0]}).to_parquet(bad / "evaluations.parquet")
    assert "lacks the column(s) env, controller, generation" in _cli_error(["report", str(bad)])
    pd.DataFrame({"designer": ["ga"], "reward": [1.0]}).to_parquet(bad / "evaluations.parquet")
    assert "lacks the column(s) env, controller, seed" in _cli_error(["report", str(bad)])
    (bad / "run.json").write_text("{ truncated")
    assert "cannot read" in _cli_error(["report", str(bad)])
    assert not (bad / "report").exists()


def test_run_in_progress_is_reported_as_far_as_it_got(run_dir, table, tmp_path):
    partial = _copy(run_dir, tmp_path)
    keep = ~((table["designer"] == "random") & (table["seed"] == 1) & (table["generation"] >= 2))
    table[keep].to_parquet(partial / "evaluations.parquet")
    meta = json.loads((partial / "run.json").read_text())
    (partial / "run.json").write_text(json.dumps({**meta, "status": "running"}))
    result = CliRunner().invoke(app, ["report", str(partial)])
    assert result.exit_code == 0, result.output
    assert "status is 'running'" in result.output and "random seed 1: 50 of 100 evaluations" in result.output
    html = (partial / "report" / "report.html").read_text()
    assert "still in progress" in html and "random seed 1: 50 of 100 evaluations" in html
    curve = pd.read_csv(partial / "report" / "best_so_far.csv").set_index(["designer", "evaluations"])
    assert curve.loc[("random", 50), "runs"] == 2 and curve.loc[("random", 51), "runs"] == 1


def test_report_of_a_run_while_it_runs_and_after_it_failed(tmp_path):
    """Rows of unfinished (designer, seed) runs are reported too, with notes saying what is missing."""
    peeked = {}

    class PeekThenFail(RunListener):
        def generation(self, spec, result):
            where = (spec.designer.label, spec.seed, result.generation)
            if where == ("random", 0, 1):
                peeked["report"] = write_report(
                    tmp_path / "run", tmp_path / "mid"
                )  # ga seed 0 done, random seed 0 half-way
            if where == ("ga", 1, 2):
                raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        compare(_experiment(), tmp_path / "run", execution=Execution(jobs=1), listener=PeekThenFail())
    mid = peeked["report"]
    assert any("status is 'running'" in n for n in mid.notes)
    assert "random seed 0: 50 of 100 evaluations" in mid.notes
    assert "ga seed 1: not started" in mid.notes and "random seed 1: not started" in mid.notes
    assert [row[2] for row in mid.rows] == ["1", "1"]  # one seed per designer so far

    result = CliRunner().invoke(app, ["report", str(tmp_path / "run")])
    assert result.exit_code == 0, result.output
    assert "status is 'interrupted'" in result.output and "random seed 1: not started" in result.output
    runs = pd.read_csv(tmp_path / "run" / "report" / "runs.csv").set_index(["designer", "seed"])
    assert runs.loc[("ga", 1), "evaluations"] < BUDGET and runs.loc[("random", 0), "evaluations"] == BUDGET
    curve = pd.read_csv(tmp_path / "run" / "report" / "best_so_far.csv").set_index(["designer", "evaluations"])
    last = runs.loc[("ga", 1), "evaluations"]
    assert curve.loc[("ga", last), "runs"] == 2 and curve.loc[("ga", last + 1), "runs"] == 1


def test_bad_options(run_dir, tmp_path):
    with pytest.raises(ConfigError, match="survivors"):
        write_report(run_dir, tmp_path, survivors=0)
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(ConfigError, match="file exists and is not a directory"):
        write_report(run_dir, blocker / "sub")
    with pytest.raises(RunDirectoryError):
        write_report(tmp_path)


# -- the CLI ---------------------------------------------------------------------------------------
def test_compare_writes_the_report_unless_disabled(tmp_path):
    common = ["compare", "--designers", "random", "--env", "simple", "--budget", "25", "--quiet"]
    result = CliRunner().invoke(app, [*common, "--out", str(tmp_path / "a")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "a" / "report" / "report.html").is_file() and "report:" in result.output
    result = CliRunner().invoke(app, [*common, "--out", str(tmp_path / "b"), "--no-report"])
    assert result.exit_code == 0, result.output
    assert not (tmp_path / "b" / "report").exists() and "random" in result.output


# -- animations (GIF) through an in-process physics-like environment --------------------------------
class Stage(Environment):
    """A toy 'physics' environment: the body slides right one pixel per frame."""

    calls: list[dict] = []
    fail = False

    def evaluate(self, body, *, seed, controller=None, workdir=None):
        return float(np.count_nonzero(np.asarray(body.voxels)))

    def render_frames(self, body, *, seed, controller=None, workdir=None):
        Stage.calls.append({"body": body.text, "seed": seed, "workdir": workdir})
        if Stage.fail:
            raise RuntimeError("renderer exploded")
        sprite = body_image(body, scale=4)[..., :3]
        frames = []
        for t in range(30):
            frame = np.full((40, 80, 3), 255, dtype=np.uint8)
            frame[10:30, t : t + 20] = sprite
            frames.append(frame)
        return frames


class Broken(Environment):
    def evaluate(self, body, *, seed, controller=None, workdir=None):
        raise RuntimeError("simulator crashed")


class StagePlugin:
    @staticmethod
    @hookimpl
    def gdabench_environments():
        return [
            EnvironmentSpec(name="stage", factory=Stage, description="toy env with frames"),
            EnvironmentSpec(name="broken", factory=Broken, description="every evaluation fails"),
        ]


@pytest.fixture(scope="module")
def stage_run(tmp_path_factory):
    reg = Registry(entry_points=False, extra_plugins={"stage": StagePlugin})
    run = compare(
        _experiment(designers=("random",), env="stage", seeds=(3,), budget=25),
        tmp_path_factory.mktemp("stage") / "run",
        reg=reg,
    )
    return run.path, reg


def test_animation_of_the_best_body(stage_run, tmp_path):
    path, reg = stage_run
    Stage.calls.clear()
    report = write_report(path, tmp_path, reg=reg)
    gifs = [f for f in report.figures if f.mime == "image/gif"]
    assert [f.filename for f in gifs] == ["animation_random.gif"]
    gif = Image.open(tmp_path / "animation_random.gif")
    assert gif.format == "GIF" and gif.n_frames == 30 and gif.size == (80, 40)
    best = pd.read_parquet(path / "evaluations.parquet").sort_values("reward", ascending=False, kind="stable").iloc[0]
    (call,) = Stage.calls
    assert call["body"] == best["body"]
    assert call["seed"] == evaluation_seed(3, best["body_hash"])  # replayed as it was evaluated
    assert call["workdir"] == path / "artifacts" / "random-seed3" / best["body_hash"]
    assert 'src="data:image/gif;base64,' in (tmp_path / "report.html").read_text()
    assert "threshold" in dict(report.facts) and "pass --threshold" in dict(report.facts)["threshold"]


def test_broken_renderer_costs_only_the_animation(stage_run, tmp_path):
    path, reg = stage_run
    Stage.fail = True
    try:
        report = write_report(path, tmp_path, reg=reg)
    finally:
        Stage.fail = False
    assert not [f for f in report.figures if f.mime == "image/gif"]
    assert any("renderer exploded" in n for n in report.notes)
    assert (tmp_path / "report.html").is_file()


def test_no_animations_option_and_missing_plugin(stage_run, tmp_path):
    path, reg = stage_run
    Stage.calls.clear()
    write_report(path, tmp_path / "a", reg=reg, animations=False)
    assert Stage.calls == []
    report = write_report(path, tmp_path / "b", reg=Registry(entry_points=False))  # plugin not installed
    assert any("cannot rebuild the environment" in n and "stage" in n for n in report.notes)


def test_run_where_every_evaluation_failed(tmp_path):
    reg = Registry(entry_points=False, extra_plugins={"stage": StagePlugin})
    run = compare(_experiment(designers=("random",), env="broken", seeds=(0,), budget=25), tmp_path / "run", reg=reg)
    report = write_report(run.path, reg=reg, threshold=10)
    (row,) = report.rows
    assert row[3] == "-" and row[4] == "0/1" and row[5] == "not reached"
    assert (run.path / "report" / "report.html").is_file() and (run.path / "report" / "best_bodies.png").is_file()


def test_a_run_of_one_generation_draws_whole_generations_and_says_what_is_missing(tmp_path):
    from gdabench.report import plots
    from gdabench.report.diversity import diversity
    from gdabench.stats.core import generation_rewards

    exp = Experiment(designers=(PluginChoice("ga"), PluginChoice("random")), envs=PluginChoice("simple"), budget=25)
    frame = compare(exp, tmp_path / "run").load_evaluations()
    div = diversity(frame, 5, 2)
    figures = [
        plots.generation_rewards_figure(generation_rewards(frame), ["ga", "random"]),
        plots.diversity_figure(div, ["ga", "random"]),
        plots.novelty_figure(div, ["ga", "random"], 2),
    ]
    axes = [ax for fig in figures for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 7 and all(ax.get_xlim() == (-1, 1) for ax in axes)  # generation 0 between whole generations
    empty = [ax for ax in axes if [t.get_text() for t in ax.texts] == ["needs a previous generation"]]
    assert len(empty) == 3  # nearest survivor, and each designer's novelty panel


def _errorbars(ax) -> list[ErrorbarContainer]:
    return [c for c in ax.containers if isinstance(c, ErrorbarContainer)]


def _whole_generation_ticks(ax) -> bool:
    low, high = ax.get_xlim()
    ticks = [t for t in ax.get_xticks() if low <= t <= high]
    return len(ticks) >= 2 and all(t == round(t) for t in ticks)


def test_one_generation_is_drawn_as_points_with_error_bars(one_generation):
    """A line and a band through one x draw nothing: one generation is a point per statistic with its spread."""
    assert one_generation["generation"].nunique() == 1
    rewards = plots.generation_rewards_figure(generation_rewards(one_generation), list(DESIGNERS))
    axes = [ax for ax in rewards.axes if ax.get_visible()]
    assert len(axes) == len(DESIGNERS)
    for ax in axes:
        assert len(_errorbars(ax)) == 3 and all(c.has_yerr for c in _errorbars(ax))  # max, mean, min over 2 seeds
        assert ax.get_xlim() == (-1, 1) and _whole_generation_ticks(ax)
    assert "error bars = inter-quartile range" in rewards.get_suptitle()

    unique, pairwise, nearest = plots.diversity_figure(diversity(one_generation, 5, 2), list(DESIGNERS)).axes
    for ax in (unique, pairwise):
        assert len(_errorbars(ax)) == len(DESIGNERS) and ax.get_xlim() == (-1, 1) and _whole_generation_ticks(ax)
    assert not nearest.containers and [t.get_text() for t in nearest.texts] == ["needs a previous generation"]


def test_a_lone_generation_beside_longer_runs_is_drawn_not_left_empty(table):
    """random stopped after two generations, ga ran on: random's only nearest-survivor generation is a point, its
    novelty a bar, on whole-generation ticks; ga's curves stay lines."""
    short = table[(table["designer"] == "ga") | (table["generation"] <= 1)]
    div = diversity(short, 5, 2)
    nearest = plots.diversity_figure(div, list(DESIGNERS)).axes[2]
    (lone,) = _errorbars(nearest)
    assert lone.get_label() == "random" and [line.get_label() for line in nearest.lines][0] == "ga"
    assert _whole_generation_ticks(nearest)
    ga, random = plots.novelty_figure(div, list(DESIGNERS), 2).axes[:2]
    bars = [c for c in random.containers if isinstance(c, BarContainer)]
    assert [b.get_label() for b in bars] == ["copy", "near-copy", "new materials", "novel shape"]
    assert sum(b.patches[0].get_height() for b in bars) == pytest.approx(1.0) and _whole_generation_ticks(random)
    assert ga.collections and not ga.containers  # the stack plot across generations, as before


def test_the_run_facts_give_its_wall_time_over_the_first_run_and_its_resumes(run_dir, report, tmp_path):
    meta = json.loads((run_dir / "run.json").read_text())
    assert meta["wall_seconds_by_part"] == [meta["wall_seconds"]] and meta["wall_seconds"] > 0
    assert dict(report.facts)["wall time"] == f"{meta['wall_seconds']:.1f} s"
    copy = tmp_path / "run"
    shutil.copytree(run_dir, copy)
    resumed = [{"at": meta["finished"], "executor": "local"}] * 2  # as if stopped twice, the second time by kill -9
    (copy / "run.json").write_text(
        json.dumps({**meta, "resumed": resumed, "wall_seconds": 5.5, "wall_seconds_by_part": [2.0, None, 3.5]})
    )
    facts = dict(write_report(copy, tmp_path / "report").facts)
    assert (
        facts["wall time"]
        == "5.5 s over the first run and 2 resumes"
        " (1 of the 3 parts recorded no time: killed with kill -9, or still going)"
    )
