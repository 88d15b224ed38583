"""The ``gdabench`` command line.

Errors caused by input are printed as one line (``error: ...``) with a non-zero exit code:
2 for a bad command (unknown name, bad value), 1 when a run failed while running (its
directory is kept and can be resumed), 130 when interrupted.  Set ``GDABENCH_DEBUG=1`` to see
tracebacks.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Annotated, Any, Optional

import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

from .body import parse_shape
from .config import Experiment, PluginChoice, parse_params, parse_seeds, split_top_level
from .errors import ConfigError, DesignerError, GdabenchError
from .plugins import KINDS, registry
from .results import RunDirectory
from .report.diversity import NEAR_COPY, SURVIVORS
from .report.tables import summary_cells
from .runner import GenerationReport, compare as run_compare, default_out_dir
from .summary import summarize

app = typer.Typer(
    help="Benchmark harness for robot-morphology designers (GA, CPPN-NEAT, generational diffusion).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = Console()
err_console = Console(stderr=True)

KIND_ALIASES = {"designers": "designer", "envs": "environment", "environments": "environment", "controllers": "controller"}


def _fail(message: str, code: int) -> typer.Exit:
    err_console.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)
    return typer.Exit(code)


class _Guard:
    """Turn errors into one line and an exit code; keep the traceback behind GDABENCH_DEBUG."""

    def __init__(self, run_dir: Path | None = None):
        self.run_dir = run_dir

    def __enter__(self) -> _Guard:
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc is None or isinstance(exc, (typer.Exit, typer.Abort, SystemExit)):
            return False
        if os.environ.get("GDABENCH_DEBUG"):
            return False
        hint = ""
        if self.run_dir is not None and (self.run_dir / "run.json").exists():
            hint = f" (results so far are in {self.run_dir}; continue with: gdabench compare --resume {self.run_dir})"
        if isinstance(exc, KeyboardInterrupt):
            raise _fail(f"interrupted{hint}", 130)
        if isinstance(exc, DesignerError):
            raise _fail(f"{exc}{hint}", 1)
        if isinstance(exc, GdabenchError):
            raise _fail(str(exc), 2)
        raise _fail(f"internal error: {type(exc).__name__}: {exc}{hint} (set GDABENCH_DEBUG=1 for the traceback)", 1)


# -- list -------------------------------------------------------------------------------------
@app.command("list")
def list_plugins(
    kind: Annotated[Optional[str], typer.Argument(help="designers, envs or controllers (default: all)")] = None,
) -> None:
    """Show every installed designer, environment and controller, and the package it comes from."""
    with _Guard():
        kinds = KINDS
        if kind is not None:
            if KIND_ALIASES.get(kind, kind) not in KINDS:
                raise ConfigError(f"unknown kind {kind!r}; choose designers, envs or controllers")
            kinds = (KIND_ALIASES.get(kind, kind),)  # type: ignore[assignment]
        reg = registry()
        for k in kinds:
            table = Table(title=f"{k}s", title_justify="left", show_edge=False)
            table.add_column("name", style="bold")
            table.add_column("description")
            table.add_column("package")
            for item in reg.items(k):
                table.add_row(escape(item.name), escape(item.spec.description), escape(f"{item.distribution} {item.version}".strip()))
            console.print(table)


# -- run / compare ----------------------------------------------------------------------------
Budget = Annotated[int, typer.Option(help="Evaluations per run (unique valid bodies).")]
Population = Annotated[int, typer.Option(help="Bodies per generation.")]
Seeds = Annotated[Optional[str], typer.Option(help="Seeds: 0,1,2 or 0..9 (default: 0).")]
Repetitions = Annotated[Optional[int], typer.Option("--repetitions", "-r", help="Number of seeds: 0..N-1 (instead of --seeds).")]
Shape = Annotated[str, typer.Option(help="Body shape HxW.")]
Env = Annotated[str, typer.Option("--env", "-e", help="Environment, optionally with parameters: name[key=value,...].")]
Controller = Annotated[Optional[str], typer.Option("--controller", "-c", help="Controller for physics environments.")]
Out = Annotated[Optional[Path], typer.Option("--out", "-o", help="Run directory (default: results/<time>-<env>-<designers>).")]
DesignerParam = Annotated[
    Optional[list[str]], typer.Option("--designer-param", "-D", help="Designer parameter KEY=VALUE (all designers) or NAME.KEY=VALUE.")
]
EnvParam = Annotated[Optional[list[str]], typer.Option("--env-param", "-E", help="Environment parameter KEY=VALUE.")]
ControllerParam = Annotated[Optional[list[str]], typer.Option("--controller-param", "-C", help="Controller parameter KEY=VALUE.")]
Workers = Annotated[
    Optional[int], typer.Option(help="Evaluations at once (default: 1 for serial, every CPU for process, every cluster CPU for ray).")
]
ExecutorOpt = Annotated[
    Optional[str], typer.Option("--executor", help="serial, process or ray (default: serial for 1 worker, process for more).")
]
RayAddress = Annotated[Optional[str], typer.Option(help="Ray cluster to join: auto (the one this machine is part of) or HOST:PORT (default: start a local one).")]
Timeout = Annotated[Optional[float], typer.Option(help="Seconds an evaluation may take before it is stopped and recorded as 'timeout'.")]
Cache = Annotated[Optional[Path], typer.Option(help="Directory of an evaluation cache shared across runs (deterministic environments).")]
Resume = Annotated[
    Optional[Path], typer.Option(help="Continue the run in this directory (its experiment is taken from it; execution options may change).")
]
Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")]
NoReport = Annotated[bool, typer.Option("--no-report", help="Only print the summary table; do not write the report (plots, HTML).")]
StopAtOptimum = Annotated[
    bool, typer.Option("--stop-at-optimum", help="End each run once it reaches the environment's optimum (saves the rest of its budget).")
]


def _designer_choices(designers: str, designer_params: list[str] | None) -> list[PluginChoice]:
    choices = [PluginChoice.parse(text) for text in split_top_level(designers)]
    if not choices:
        raise ConfigError("no designer given")
    shared: dict[str, Any] = {}
    targeted: dict[str, dict[str, Any]] = {}
    for item in designer_params or []:
        key = item.partition("=")[0]
        if "." in key:
            target, _, rest = item.partition(".")
            if not any(target in (c.name, c.label) for c in choices):
                raise ConfigError(f"--designer-param {item!r} names designer {target!r}, which is not in this run")
            targeted.setdefault(target, {}).update(parse_params([rest], "designer parameter"))
        else:
            shared.update(parse_params([item], "designer parameter"))
    return [c.with_params({**shared, **targeted.get(c.name, {}), **targeted.get(c.label, {})}) for c in choices]


def _execute(
    designers: str,
    *,
    env: str,
    controller: str | None,
    budget: int,
    population: int,
    seeds: str | None,
    repetitions: int | None,
    shape: str,
    out: Path | None,
    designer_param: list[str] | None,
    env_param: list[str] | None,
    controller_param: list[str] | None,
    workers: int | None,
    executor: str | None,
    ray_address: str | None,
    timeout: float | None,
    cache: Path | None,
    resume: Path | None,
    quiet: bool,
    no_report: bool = False,
    stop_at_optimum: bool = False,
) -> None:
    guard = _Guard(resume or out)
    with guard:
        if resume is not None:
            run = RunDirectory.open(resume)
            experiment = Experiment.from_json(run.meta["config"])
        else:
            env_choice = PluginChoice.parse(env).with_params(parse_params(env_param, "environment parameter"))
            ctrl_choice = None
            if controller:
                ctrl_choice = PluginChoice.parse(controller).with_params(parse_params(controller_param, "controller parameter"))
            elif controller_param:
                raise ConfigError("--controller-param given without --controller")
            experiment = Experiment(
                designers=tuple(_designer_choices(designers, designer_param)),
                env=env_choice,
                controller=ctrl_choice,
                shape=parse_shape(shape),
                population=population,
                budget=budget,
                seeds=tuple(parse_seeds(seeds, repetitions)),
                stop_at_optimum=stop_at_optimum,
            )
            experiment.validate()
        runs = len(experiment.designers) * len(experiment.seeds)
        progress = Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("evaluations"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            console=err_console,
            disable=quiet,
        )
        done: dict[tuple[str, int], int] = {}
        if resume is not None:
            frame = run.load_evaluations()
            if len(frame):
                done = {(k[0], int(k[1])): int(v) for k, v in frame.groupby(["designer", "seed"])["n_evals"].max().items()}
        task = progress.add_task("starting", total=runs * experiment.budget, completed=sum(done.values()))

        def on_generation(report: GenerationReport) -> None:
            if not progress.live.is_started:  # started late so that set-up errors print alone
                progress.start()
            done[(report.designer, report.seed)] = report.n_evals
            best = "-" if report.best != report.best else f"{report.best:.4g}"
            progress.update(
                task,
                completed=sum(done.values()),
                description=escape(f"{report.designer} seed {report.seed} gen {report.generation} best {best}"),
            )

        if out is None and resume is None:
            out = default_out_dir(experiment)
        guard.run_dir = resume or out
        try:
            run = run_compare(
                experiment,
                resume or out,
                resume=resume is not None,
                workers=workers,
                executor=executor,
                timeout=timeout,
                ray_address=ray_address,
                cache=cache,
                on_generation=on_generation,
                command=["gdabench", *sys.argv[1:]],
            )
        finally:
            progress.stop()
        execution = (run.meta.get("resumed") or [None])[-1] if resume is not None else run.meta.get("execution")
        if cache is not None and isinstance(execution, dict) and execution.get("cache") is None:
            err_console.print(f"[yellow]note:[/] environment {escape(repr(experiment.env.name))} is not deterministic; the evaluation cache was not used")
    if no_report:
        _print_summary(run)
        return
    with _Guard():
        try:
            _write_report(run.path)
        except GdabenchError as exc:
            raise _fail(f"the run is complete in {run.path}, but its report failed: {exc} (retry with: gdabench report {run.path})", 1) from None


def _print_table(title: str, headers: list[str], rows: list[list[str]]) -> None:
    table = Table(title=escape(title), title_justify="left", show_edge=False)
    for i, c in enumerate(headers):
        table.add_column(escape(c), justify="left" if i < 2 else "right")
    for cells in rows:
        table.add_row(*map(escape, cells))  # labels such as ga[survivors=5] are not rich markup
    console.print(table)


def _print_summary(run: RunDirectory) -> None:
    summary = summarize(run.load_evaluations(), run.meta.get("env_optimum"))
    _print_table(f"summary ({run.path})", *summary_cells(summary))


def _write_report(run_dir: Path, out: Path | None = None, **options: Any) -> None:
    """Write the report of a run and print its table, notes and where it went."""
    from .report.build import write_report  # matplotlib is imported only when a report is made

    report = write_report(run_dir, out, **options)
    _print_table(f"summary ({report.run_path})", report.headers, report.rows)
    for note in report.notes:
        err_console.print(f"[yellow]note:[/] {escape(note)}", highlight=False, soft_wrap=True)
    console.print(escape(f"report: {report.out / 'report.html'} (summary: {report.out / 'summary.md'})"), highlight=False, soft_wrap=True)


@app.command()
def compare(
    designers: Annotated[str, typer.Option("--designers", "-d", help="Comma-separated designers, e.g. ga,cppn,gda or ga[survivors=5].")] = "",
    env: Env = "simple",
    controller: Controller = None,
    budget: Budget = 1000,
    population: Population = 25,
    seeds: Seeds = None,
    repetitions: Repetitions = None,
    shape: Shape = "5x5",
    out: Out = None,
    designer_param: DesignerParam = None,
    env_param: EnvParam = None,
    controller_param: ControllerParam = None,
    workers: Workers = None,
    executor: ExecutorOpt = None,
    ray_address: RayAddress = None,
    timeout: Timeout = None,
    cache: Cache = None,
    resume: Resume = None,
    quiet: Quiet = False,
    no_report: NoReport = False,
    stop_at_optimum: StopAtOptimum = False,
) -> None:
    """Run several designers side by side under the same budget and seeds."""
    if not designers and resume is None:
        raise _fail("give --designers, e.g. --designers ga,cppn,gda", 2)
    _execute(**{k: v for k, v in locals().items()})


@app.command()
def run(
    designer: Annotated[str, typer.Argument(help="Designer, optionally with parameters: name[key=value,...].")],
    env: Env = "simple",
    controller: Controller = None,
    budget: Budget = 1000,
    population: Population = 25,
    seeds: Seeds = None,
    repetitions: Repetitions = None,
    shape: Shape = "5x5",
    out: Out = None,
    designer_param: DesignerParam = None,
    env_param: EnvParam = None,
    controller_param: ControllerParam = None,
    workers: Workers = None,
    executor: ExecutorOpt = None,
    ray_address: RayAddress = None,
    timeout: Timeout = None,
    cache: Cache = None,
    resume: Resume = None,
    quiet: Quiet = False,
    no_report: NoReport = False,
    stop_at_optimum: StopAtOptimum = False,
) -> None:
    """Run one designer."""
    _execute(designers=designer, **{k: v for k, v in locals().items() if k != "designer"})


@app.command()
def evaluate(
    body: Annotated[str, typer.Argument(help="Body in text form, rows separated by '/', e.g. 44444/44444/44444/44444/44444.")],
    env: Env = "simple",
    controller: Controller = None,
    env_param: EnvParam = None,
    controller_param: ControllerParam = None,
    seed: Annotated[int, typer.Option(help="Run seed (the evaluation seed is derived from it and the body).")] = 0,
) -> None:
    """Score one body, exactly as a run with this seed would."""
    with _Guard():
        from . import seeding
        from .body import Body
        from .evaluation import OK, EvalTask, evaluate as evaluate_task

        parsed = Body.from_text(body)
        reg = registry()
        env_choice = PluginChoice.parse(env).with_params(parse_params(env_param, "environment parameter"))
        ctrl_choice = PluginChoice.parse(controller).with_params(parse_params(controller_param, "controller parameter")) if controller else None
        Experiment((PluginChoice("random"),), env_choice, ctrl_choice, shape=parsed.shape, population=1, budget=1).validate(reg)
        env_recipe = reg.get("environment", env_choice.name).spec.recipe({"shape": parsed.shape, **env_choice.params})
        reason = env_recipe.build().invalid_reason(parsed)
        if reason is not None:
            raise ConfigError(f"body {parsed.text} is invalid for {env_choice.name!r}: {reason}")
        ctrl_recipe = None
        if ctrl_choice is not None:
            ctrl_recipe = reg.get("controller", ctrl_choice.name).spec.recipe(ctrl_choice.params)
        outcome = evaluate_task(EvalTask(parsed, seeding.evaluation_seed(seed, parsed.hash), env_recipe, ctrl_recipe))
        if outcome.status != OK:
            raise _fail(f"evaluation failed: {outcome.message}", 1)
        console.print(f"{outcome.reward:.6g}")


@app.command()
def report(
    run_dir: Annotated[Path, typer.Argument(help="A run directory written by compare or run.")],
    out: Annotated[Optional[Path], typer.Option("--out", "-o", help="Where to write the report (default: RUN_DIR/report).")] = None,
    threshold: Annotated[
        Optional[float], typer.Option(help="Reward whose first reach is counted in evaluations (default: the environment's optimum, if known).")
    ] = None,
    survivors: Annotated[int, typer.Option(help="Diversity: survivors = this many best bodies evaluated before a generation.")] = SURVIVORS,
    near_copy: Annotated[int, typer.Option(help="Diversity: a proposal at most this many voxels from a survivor is a near-copy.")] = NEAR_COPY,
    animations: Annotated[bool, typer.Option(help="Animate the best bodies, if the environment can render them.")] = True,
) -> None:
    """Write plots, tables and a self-contained HTML report of a run directory (also mid-run)."""
    with _Guard():
        _write_report(run_dir, out, threshold=threshold, survivors=survivors, near_copy=near_copy, animations=animations)


@app.command()
def replay(
    run_dir: Annotated[Path, typer.Argument(help="A run directory written by compare or run.")],
    body: Annotated[Optional[str], typer.Option("--body", help="Hash (or unique prefix) of the body to replay (default: the best).")] = None,
    designer: Annotated[Optional[str], typer.Option("--designer", help="Only consider this designer's bodies.")] = None,
    gif: Annotated[Optional[Path], typer.Option("--gif", help="Write an animation of the body acting to this GIF file.")] = None,
) -> None:
    """Replay a body of a run as it was scored (ppo replays the policy it saved, no retraining)."""
    with _Guard():
        from .replay import replay_run

        done = replay_run(run_dir, body_hash=body, designer=designer, gif=gif)
        console.print(f"{done.designer} seed {done.seed} body {done.body.text} ({done.body.hash}): reward {done.reward:.6g}", highlight=False)
        if done.gif is not None:
            console.print(f"animation: {done.gif}", highlight=False)


# -- export -----------------------------------------------------------------------------------
@app.command()
def export(
    run_dir: Annotated[Path, typer.Argument(help="A run directory written by compare or run.")],
    format: Annotated[str, typer.Option("--format", "-f", help="ioh (IOHprofiler data for IOHanalyzer) or csv (the table, for spreadsheets).")] = "ioh",
    out: Annotated[Optional[Path], typer.Option("--out", "-o", help="Where to write (default: RUN_DIR/export/ioh or RUN_DIR/export/evaluations.csv).")] = None,
) -> None:
    """Write a run's results in another tool's format."""
    with _Guard():
        from .report.export import export_run

        console.print(escape(f"{format}: {export_run(run_dir, format, out)}"), highlight=False, soft_wrap=True)


def main() -> None:
    app()


if __name__ == "__main__":
    main()
