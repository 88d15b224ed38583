"""The ``gdabench`` command line.

Errors caused by input are printed as one line (``error: ...``) with exit code 2, before any
run directory is made; a run that failed while running exits 1 (its directory is kept and can
be resumed); Ctrl-C exits 130 and SIGTERM 143, the run marked ``interrupted``.  Set
``GDABENCH_DEBUG=1`` to see tracebacks.
"""

from __future__ import annotations

import atexit
import inspect
import os
import signal
import sys
import threading
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Annotated, Any, Callable, Literal, NoReturn, Optional, get_type_hints

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from .errors import ConfigError, GdabenchError, RunFailure, Terminated
from .experiment.build import DEFAULTS, OPTIONS, RunSetup, build_run, significance_warnings
from .experiment.config import PluginChoice, format_seeds
from .loggers import make_logger
from .plugins import KINDS, registry
from .report.diversity import NEAR_COPY, SURVIVORS
from .report.tables import summary_cells
from .results import RunDirectory, is_file, load_reevaluations
from .running.progress import ProgressDisplay
from .running.runner import execute
from .stats.summary import failure_counts, nothing_measured, summarize, thresholds

try:  # typer >= 0.2x carries its own copy of click
    from typer._click import exceptions as click_errors
except ImportError:  # pragma: no cover - older typer uses click itself
    from click import exceptions as click_errors  # type: ignore[no-redef]

app = typer.Typer(
    help="Benchmark harness for robot-morphology designers (GA, CPPN-NEAT, generational diffusion).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # help texts show name[key=value] literally
)
console = Console()
err_console = Console(stderr=True)

KIND_ALIASES = {
    "designers": "designer",
    "envs": "environment",
    "environments": "environment",
    "controllers": "controller",
    "suites": "suite",
}


def _fail(message: str, code: int) -> typer.Exit:
    err_console.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)
    return typer.Exit(code)


class _Guard:
    """Turn errors into one line and an exit code; keep the traceback behind GDABENCH_DEBUG."""

    def __init__(self, run_dir: Path | None = None):
        self.run_dir = run_dir

    def __enter__(self) -> _Guard:
        return self

    def __exit__(self, exc_type, exc, tb) -> Literal[False]:
        if exc is None or isinstance(exc, (typer.Exit, typer.Abort, SystemExit)):
            return False
        if os.environ.get("GDABENCH_DEBUG"):
            return False
        hint = ""
        if self.run_dir is not None and is_file(self.run_dir / "run.json"):
            hint = f" (results so far are in {self.run_dir}; continue with: gdabench compare --resume {self.run_dir})"
        if isinstance(exc, KeyboardInterrupt):
            raise _fail(
                f"{'terminated' if isinstance(exc, Terminated) else 'interrupted'}{hint}",
                143 if isinstance(exc, Terminated) else 130,
            )
        if isinstance(exc, RunFailure):
            raise _fail(f"{exc}{hint}", 1)
        if isinstance(exc, GdabenchError):
            raise _fail(str(exc), 2)
        raise _fail(f"internal error: {type(exc).__name__}: {exc}{hint} (set GDABENCH_DEBUG=1 for the traceback)", 1)


# -- list, info ---------------------------------------------------------------------------------
def _kinds(kind: str | None, suites: bool = False) -> tuple[str, ...]:
    known = (*KINDS, "suite") if suites else KINDS
    if kind is None:
        return known
    if KIND_ALIASES.get(kind, kind) not in known:
        raise ConfigError(
            f"unknown kind {kind!r}; choose designers, envs, controllers" + (" or suites" if suites else "")
        )
    return (KIND_ALIASES.get(kind, kind),)


@app.command("list")
def list_plugins(
    kind: Annotated[Optional[str], typer.Argument(help="designers, envs, controllers or suites (default: all)")] = None,
) -> None:
    """Show every installed designer, environment, controller and suite, and the package it comes from."""
    with _Guard():
        reg = registry()
        for k in _kinds(kind, suites=True):
            table = Table(title=f"{k}s", title_justify="left", show_edge=False)
            table.add_column("name", style="bold")
            table.add_column("description")
            table.add_column("package")
            for item in reg.items(k):  # type: ignore[arg-type]
                spec = item.spec
                description = spec.description + (
                    f" ({', '.join(spec.envs)}{f'; controller {spec.controller}' if spec.controller else ''})"
                    if k == "suite"
                    else ""
                )
                table.add_row(
                    escape(item.name), escape(description), escape(f"{item.distribution} {item.version}".strip())
                )
            console.print(table)


@app.command()
def info(
    name: Annotated[str, typer.Argument(help="A designer, environment or controller name (see gdabench list).")],
    kind: Annotated[
        Optional[str], typer.Option(help="designers, envs or controllers, where a name is used by several kinds.")
    ] = None,
) -> None:
    """Show a plugin's parameters: type, default and what each one does."""
    from .params import describe

    with _Guard():
        reg = registry()
        found = [(k, reg.get(k, name)) for k in _kinds(kind) if name in reg.names(k)]  # type: ignore[arg-type]
        if not found and kind:
            reg.get(_kinds(kind)[0], name)  # raises the not-found error, with suggestions
        if not found:
            raise _unknown_plugin(reg, name)
        for k, item in found:
            console.print(
                escape(f"{k} {item.name} ({item.distribution} {item.version}): {item.spec.description}".strip()),
                highlight=False,
            )
            table = Table(show_edge=False)
            for column in ("parameter", "type", "default", "description"):
                table.add_column(column)
            rows = describe(item.spec)
            for row in rows:
                table.add_row(*map(escape, row))
            console.print(table if rows else "no parameters")


def _unknown_plugin(reg: Any, name: str) -> ConfigError:
    """No designer, environment or controller is called ``name``: say so, with the closest name of any kind."""
    import difflib

    known = sorted({n for k in KINDS for n in reg.names(k)})
    close = difflib.get_close_matches(name, known, n=1)
    hint = f" Did you mean {close[0]!r}?" if close else ""
    return ConfigError(f"no designer, environment or controller is called {name!r} (see: gdabench list).{hint}")


# -- run / compare --------------------------------------------------------------------------------
def _option(*names: str, help: str) -> Any:
    return typer.Option(*names, help=help)


@dataclass
class RunOptions:
    """The options ``compare`` and ``run`` share (typer reads them from :data:`RUN_OPTIONS`).

    ``explicit`` names the options given on the command line: they override an experiment file
    (``--config``), which overrides the defaults (see :func:`~gdabench.experiment.build.build_run`).
    """

    config: Optional[Path] = None
    env: str = DEFAULTS["env"]
    suite: Optional[str] = None
    controller: Optional[str] = None
    budget: int = DEFAULTS["budget"]
    population: int = DEFAULTS["population"]
    seeds: Optional[str] = None
    repetitions: Optional[int] = None
    shape: str = "x".join(map(str, DEFAULTS["shape"]))
    out: Optional[Path] = None
    designer_param: Optional[list[str]] = None
    env_param: Optional[list[str]] = None
    controller_param: Optional[list[str]] = None
    jobs: Optional[int] = DEFAULTS["jobs"]
    workers: int = DEFAULTS["workers"]
    batch: Optional[int] = DEFAULTS["batch"]
    executor: str = DEFAULTS["executor"]
    ray_address: Optional[str] = DEFAULTS["ray_address"]
    timeout: Optional[float] = DEFAULTS["timeout"]
    cache: Optional[Path] = DEFAULTS["cache"]
    resume: Optional[Path] = None
    stop_at_optimum: bool = DEFAULTS["stop_at_optimum"]
    reevaluate: Optional[str] = None
    log: Optional[list[str]] = None
    quiet: bool = False
    no_report: bool = False
    explicit: frozenset[str] = frozenset()  # filled in by with_run_options

    def given(self, designers: str) -> dict[str, Any]:
        """What the user gave, for :func:`~gdabench.experiment.build.build_run` to fill in the rest."""
        given = {name: getattr(self, name) for name in self.explicit & OPTIONS}
        return {**given, "designers": designers} if designers else given


#: typer's view of RunOptions: option names and help, in the order --help lists them
RUN_OPTIONS: dict[str, Any] = {
    "config": _option(
        "--config", help="An experiment file (TOML, or a run's run.json to repeat it); options given here override it."
    ),
    "env": _option(
        "--env", "-e", help="Environment(s), each name or name[key=value,...]; several run as a suite: simple,nk[k=4]."
    ),
    "suite": _option("--suite", help="A named suite of environments (gdabench list suites), instead of --env."),
    "controller": _option(
        "--controller", "-c", help="Controller for physics environments, e.g. ppo or open-loop[period=30]."
    ),
    "budget": _option("--budget", help="Evaluations per trial (unique valid bodies)."),
    "population": _option("--population", help="Bodies per generation."),
    "seeds": _option("--seeds", help=f"Seeds: 0,1,2 or 0..9 (default: {format_seeds(DEFAULTS['seeds'])})."),
    "repetitions": _option("--repetitions", "-r", help="Number of seeds: 0..N-1 (instead of --seeds)."),
    "shape": _option("--shape", help="Body shape HxW."),
    "out": _option("--out", "-o", help="Run directory (default: results/<time>-<env>-<designers>)."),
    "designer_param": _option(
        "--designer-param", "-D", help="Designer parameter KEY=VALUE (all designers) or NAME.KEY=VALUE."
    ),
    "env_param": _option("--env-param", "-E", help="Environment parameter KEY=VALUE."),
    "controller_param": _option("--controller-param", "-C", help="Controller parameter KEY=VALUE."),
    "jobs": _option(
        "--jobs", "-j", help="Trials (designer x seed) at once (default: as many as the CPUs allow --workers each)."
    ),
    "workers": _option(
        "--workers", help="Evaluation processes per trial (default 1: evaluate in the trial's own process)."
    ),
    "batch": _option(
        "--batch",
        help="Bodies evaluated in one call, at most (default: the controller's; ppo learns a generation in lockstep).",
    ),
    "executor": _option("--executor", help="local (processes on this machine) or ray (actors on a Ray cluster)."),
    "ray_address": _option(
        "--ray-address", help="Ray cluster to join: auto or HOST:PORT (default: start a local one)."
    ),
    "timeout": _option(
        "--timeout", help="Seconds an evaluation may take before it is stopped and recorded as 'timeout'."
    ),
    "cache": _option(
        "--cache", help="Directory of an evaluation cache shared across runs (deterministic environments)."
    ),
    "resume": _option(
        "--resume",
        help="Continue the run in this directory (its experiment is taken from it; execution options may change, "
             "--seeds may add seeds).",
    ),
    "stop_at_optimum": _option("--stop-at-optimum", help="End each trial once it reaches the environment's optimum."),
    "reevaluate": _option(
        "--reevaluate",
        help="TOPxSEEDS: retrain each trial's TOP best bodies under SEEDS more training seeds and score it by the best "
             "mean, or off (default: 3x5 with a controller, off without).",
    ),
    "log": _option(
        "--log", help="Log each generation's figures to a tracker: tensorboard (writes RUN_DIR/tensorboard)."
    ),
    "quiet": _option("--quiet", "-q", help="No progress display."),
    "no_report": _option("--no-report", help="Only print the summary table; do not write the report (plots, HTML)."),
}


def _typed(ctx: typer.Context, names: list[str]) -> frozenset[str]:
    """The options among ``names`` the user typed (an option left at its default is not one of them)."""
    return frozenset(
        n for n in names if getattr(ctx.get_parameter_source(n), "name", "DEFAULT") not in ("DEFAULT", "DEFAULT_MAP")
    )


def with_run_options(command: Callable[..., None]) -> Callable[..., None]:
    """Give ``command(..., options: RunOptions)`` the shared options as typer parameters."""
    own = [p for p in inspect.signature(command, eval_str=True).parameters.values() if p.name != "options"]
    types = get_type_hints(RunOptions)
    names = [f.name for f in fields(RunOptions) if f.name in RUN_OPTIONS]
    shared = [
        inspect.Parameter(
            n,
            inspect.Parameter.KEYWORD_ONLY,
            default=RunOptions.__dataclass_fields__[n].default,
            annotation=Annotated[types[n], RUN_OPTIONS[n]],
        )
        for n in names
    ]
    context = inspect.Parameter("ctx", inspect.Parameter.KEYWORD_ONLY, annotation=typer.Context)

    def wrapper(ctx: typer.Context, **kwargs: Any) -> None:
        options = RunOptions(**{n: kwargs.pop(n) for n in names}, explicit=_typed(ctx, names))
        command(**kwargs, options=options)

    wrapper.__name__, wrapper.__doc__ = command.__name__, command.__doc__
    wrapper.__signature__ = inspect.Signature([*own, context, *shared])  # type: ignore[attr-defined]
    return wrapper


def _execute(designers: str, options: RunOptions) -> None:
    guard = _Guard(options.resume or options.out)
    with guard:
        setup = build_run(options.given(designers))
        guard.run_dir = setup.out
        for line in significance_warnings(setup.experiment):
            err_console.print(f"[yellow]warning:[/] {escape(line)}", highlight=False, soft_wrap=True)
        done = setup.resumed.evaluations_made() if setup.resumed is not None else {}
        reg = registry()
        for name in dict.fromkeys(options.log or []):
            reg.pm.register(make_logger(name), name=f"gdabench-log-{name}")
        with ProgressDisplay(setup.experiment, done, console=err_console, quiet=options.quiet) as display:
            run = execute(setup, listener=display, command=["gdabench", *sys.argv[1:]], reg=reg)
        for env, reason in _uncached(setup):
            err_console.print(
                f"[yellow]note:[/] {escape(reason)}; the evaluation cache was not used for {escape(env)}",
                highlight=False,
            )
    if not options.no_report:
        with _Guard():
            try:
                _write_report(run.path)
            except GdabenchError as exc:
                raise _fail(
                    f"the run is complete in {run.path}, but its report failed: {exc} (retry with: gdabench report "
                    f"{run.path})",
                    1,
                ) from None
    else:
        _print_summary(run)
    _report_failures(run)


def _uncached(setup: RunSetup) -> list[tuple[str, str]]:
    if setup.execution.cache is None or setup.plan is None:
        return []
    return sorted(setup.plan.uncacheable.items())


def _report_failures(run: RunDirectory) -> None:
    """Say which evaluations went wrong; exit 1 if a trial's every evaluation failed."""
    counts = failure_counts(run.load_evaluations())
    for row in counts.itertuples():
        err_console.print(
            escape(f"note: {row.designer} on {row.env}: {row.line}"), style="yellow", highlight=False, soft_wrap=True
        )
    line = nothing_measured(counts)
    if line is not None:
        raise _fail(line, 1)


def _print_table(title: str, headers: list[str], rows: list[list[str]]) -> None:
    table = Table(title=escape(title), title_justify="left", show_edge=False)
    for i, c in enumerate(headers):
        table.add_column(escape(c), justify="left" if i < 2 else "right")
    for cells in rows:
        table.add_row(*map(escape, cells))  # labels such as ga[survivors=5] are not rich markup
    console.print(table)


def _print_summary(run: RunDirectory) -> None:
    summary = summarize(run.load_evaluations(), thresholds(run.meta), reevaluations=load_reevaluations(run.path))
    _print_table(f"summary ({run.path})", *summary_cells(summary, compact=True))


def _write_report(run_dir: Path, out: Path | None = None, **options: Any) -> None:
    """Write the report of a run and print its table, notes and where it went."""
    from .report.build import write_report  # matplotlib is imported only when a report is made

    report = write_report(run_dir, out, **options)
    _print_table(f"summary ({report.run_path})", *summary_cells(report.summary, compact=True))
    for note in report.notes:
        err_console.print(f"[yellow]note:[/] {escape(note)}", highlight=False, soft_wrap=True)
    console.print(
        escape(f"report: {report.out / 'report.html'} (summary: {report.out / 'summary.md'})"),
        highlight=False,
        soft_wrap=True,
    )


@app.command()
@with_run_options
def compare(
    designers: Annotated[
        str,
        typer.Option("--designers", "-d", help="Comma-separated designers, e.g. ga,cppn,gda or ga[survivors=5],gda."),
    ] = "",
    *,
    options: RunOptions,
) -> None:
    """Run several designers side by side under the same budget and seeds."""
    _execute(designers, options)


@app.command()
@with_run_options
def run(
    designer: Annotated[str, typer.Argument(help="Designer, optionally with parameters: name[key=value,...].")],
    *,
    options: RunOptions,
) -> None:
    """Run one designer (compare with a single designer)."""
    if len(PluginChoice.parse_list(designer)) > 1:
        raise _fail(f"run takes one designer, got {designer!r}; use compare for several", 2)
    _execute(designer, options)


@app.command()
def evaluate(
    body: Annotated[
        str, typer.Argument(help="Body in text form, rows separated by '/', e.g. 44444/44444/44444/44444/44444.")
    ],
    env: Annotated[str, RUN_OPTIONS["env"]] = DEFAULTS["env"],
    controller: Annotated[Optional[str], RUN_OPTIONS["controller"]] = None,
    env_param: Annotated[Optional[list[str]], RUN_OPTIONS["env_param"]] = None,
    controller_param: Annotated[Optional[list[str]], RUN_OPTIONS["controller_param"]] = None,
    seed: Annotated[int, typer.Option(help="Run seed (the evaluation seed is derived from it and the body).")] = 0,
) -> None:
    """Score one body, exactly as a run with this seed would."""
    with _Guard():
        from . import seeding
        from .body import Body
        from .execution.evaluation import evaluate as evaluate_task
        from .experiment.config import check_seed
        from .experiment.plan import Plan
        from .statuses import OK
        from .strategy import EvalTask

        parsed = Body.from_text(body)
        check_seed(seed)
        experiment = build_run({"designers": "random", "env": env, "controller": controller, "env_param": env_param,
                                "controller_param": controller_param, "shape": parsed.shape, "population": 1,
                                "budget": 1}).experiment  # fmt: skip
        plan = Plan.resolve(experiment, registry(), designers=False)
        scorer, _ = plan.scorers()
        reason = scorer.invalid_reason(parsed)
        if reason is not None:
            raise ConfigError(f"body {parsed.text} is invalid for {env!r}: {reason}")
        task = EvalTask(parsed, seeding.evaluation_seed(seed, parsed.hash), plan.envs[0].factory, plan.controller)
        outcome = evaluate_task(task)
        if outcome.status != OK:
            raise _fail(f"evaluation failed: {outcome.message}", 1)
        console.print(f"{outcome.reward:.6g}")


@app.command()
def report(
    run_dir: Annotated[Path, typer.Argument(help="A run directory written by compare or run.")],
    out: Annotated[
        Optional[Path], typer.Option("--out", "-o", help="Where to write the report (default: RUN_DIR/report).")
    ] = None,
    threshold: Annotated[
        Optional[float],
        typer.Option(
            help="Reward whose first reach is counted in evaluations (default: the environment's optimum, if known)."
        ),
    ] = None,
    survivors: Annotated[
        int, typer.Option(help="Diversity: survivors = this many best bodies evaluated before a generation.")
    ] = SURVIVORS,
    near_copy: Annotated[
        int, typer.Option(help="Diversity: a proposal at most this many voxels from a survivor is a near-copy.")
    ] = NEAR_COPY,
    animations: Annotated[
        bool,
        typer.Option(
            "--animations/--no-animations", help="Animate the best bodies, if the environment can render them."
        ),
    ] = True,
    primary: Annotated[
        Optional[str],
        typer.Option(
            help="A,B: test designer A against B alone (for a run whose experiment names no primary comparison; "
                 "the report says it was named after the run)."
        ),
    ] = None,
) -> None:
    """Write plots, tables and a self-contained HTML report of a run directory (also mid-run)."""
    with _Guard():
        from .experiment.config import Primary

        chosen = Primary.from_json(primary, "--primary") if primary is not None else None
        _write_report(
            run_dir, out, threshold=threshold, survivors=survivors, near_copy=near_copy, animations=animations,
            primary=chosen,
        )  # fmt: skip


@app.command()
def replay(
    run_dir: Annotated[Path, typer.Argument(help="A run directory written by compare or run.")],
    body: Annotated[
        Optional[str], typer.Option("--body", help="Hash (or unique prefix) of the body to replay (default: the best).")
    ] = None,
    designer: Annotated[Optional[str], typer.Option("--designer", help="Only consider this designer's bodies.")] = None,
    gif: Annotated[
        Optional[Path], typer.Option("--gif", help="Write an animation of the body acting to this GIF file.")
    ] = None,
) -> None:
    """Replay a body of a run as it was scored (ppo replays the policy it saved, no retraining)."""
    with _Guard():
        from .replay import replay_run

        done = replay_run(run_dir, body_hash=body, designer=designer, gif=gif)
        console.print(
            f"{done.designer} seed {done.seed} body {done.body.text} ({done.body.hash}): reward {done.reward:.6g}",
            highlight=False,
        )
        if done.gif is not None:
            console.print(f"animation: {done.gif}", highlight=False)


@app.command()
def reevaluate(
    run_dir: Annotated[Path, typer.Argument(help="A run directory written by compare or run.")],
    how: Annotated[
        Optional[str],
        typer.Option("--reevaluate", help="TOPxSEEDS (default: the run's own setting, else 3x5)."),
    ] = None,
    jobs: Annotated[Optional[int], RUN_OPTIONS["jobs"]] = None,
    workers: Annotated[int, RUN_OPTIONS["workers"]] = 1,
    batch: Annotated[Optional[int], RUN_OPTIONS["batch"]] = None,
) -> None:
    """Train each trial's best bodies again under further seeds (for a run made without it); resumable."""
    with _Guard():
        from .execution.options import Execution
        from .experiment.config import Reevaluation
        from .running.reevaluation import reevaluate_directory

        setting = Reevaluation.parse(how, "--reevaluate") if how is not None else None
        if how is not None and setting is None:
            raise ConfigError("--reevaluate off leaves nothing to do; give TOPxSEEDS such as 3x5")

        def note(title: str, done: int, total: int) -> None:
            err_console.print(escape(f"re-evaluated {title} ({done}/{total})"), highlight=False)

        table = reevaluate_directory(run_dir, setting, Execution(jobs=jobs, workers=workers, batch=batch), note)
        console.print(escape(f"{len(table)} re-evaluations in {run_dir / 'reevaluations.parquet'}; "
                             f"report: gdabench report {run_dir}"), highlight=False)  # fmt: skip


# -- export -----------------------------------------------------------------------------------
@app.command()
def export(
    run_dir: Annotated[Path, typer.Argument(help="A run directory written by compare or run.")],
    format: Annotated[
        str,
        typer.Option(
            "--format", "-f", help="ioh (IOHprofiler data for IOHanalyzer) or csv (the table, for spreadsheets)."
        ),
    ] = "ioh",
    out: Annotated[
        Optional[Path],
        typer.Option(
            "--out", "-o", help="Where to write (default: RUN_DIR/export/ioh or RUN_DIR/export/evaluations.csv)."
        ),
    ] = None,
) -> None:
    """Write a run's results in another tool's format."""
    with _Guard():
        from .report.export import export_run

        console.print(escape(f"{format}: {export_run(run_dir, format, out)}"), highlight=False, soft_wrap=True)


def _interrupt_once(signum: int, frame: Any) -> None:
    """The first Ctrl-C interrupts; more of them cannot cut short the clean-up and exit it starts."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    raise KeyboardInterrupt


def main() -> None:
    """The console script: usage errors become one ``error:`` line too (exit 2)."""
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _interrupt_once)
    command = typer.main.get_command(app)
    try:
        code = command.main(prog_name="gdabench", standalone_mode=False)
    except click_errors.NoArgsIsHelpError as exc:
        exc.show()
        code = 0
    except click_errors.UsageError as exc:
        hint = f" (see: {exc.ctx.command_path} --help)" if exc.ctx is not None else ""
        err_console.print(
            f"[bold red]error:[/] {escape(' '.join(exc.format_message().split()))}{escape(hint)}",
            highlight=False,
            soft_wrap=True,
        )
        code = 2
    except (click_errors.Abort if hasattr(click_errors, "Abort") else typer.Abort):  # noqa: B030 - click's Abort, wherever this version keeps it
        code = 130
    _exit(code if isinstance(code, int) else 0)


def _exit(code: int) -> NoReturn:
    """Exit with ``code`` once Python's own clean-up has run, skipping the native libraries' teardown.

    pyarrow's thread pools, torn down at interpreter exit, abort the process now and then ("terminate
    called without an active exception", apache/arrow#34314) after a run has finished and written
    everything.  So: the ``atexit`` functions (multiprocessing's joins and finalizers, logging), flushed
    streams, then ``os._exit``.  A thread that still works (none of ours) gets the ordinary exit instead.
    The cause measured, Arrow's threads releasing Python objects in a finalising interpreter, is gone from
    gdabench's own reads (:func:`gdabench.results.read_parquet`); this stays for what the command's other
    native libraries may leave behind.
    """
    if any(t.is_alive() and not t.daemon for t in threading.enumerate() if t is not threading.main_thread()):
        sys.exit(code)
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe or stream: nothing more can be said on it
            pass
    os._exit(code)


if __name__ == "__main__":
    main()
