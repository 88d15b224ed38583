"""Building a run from what the user gave: the one place an option becomes part of an experiment.

The command line, :func:`gdabench.compare` and ``--resume`` all go through :func:`build_run`,
so an option means the same wherever it is given.  Each option is taken as given, else from the
experiment file (``config``), else from :data:`DEFAULTS`; a resumed run keeps the experiment
its directory records, to which only seeds can be added.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, fields, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping, Sequence

from ..body import DEFAULT_SHAPE, parse_shape
from ..errors import ConfigError, RunDirectoryError
from ..execution.options import Execution
from ..plugins import Registry, registry
from ..results import RunDirectory
from ..stats.power import ALPHA, minimum_seeds, seeds_needed
from .config import (
    DEFAULT_BUDGET,
    DEFAULT_ENV,
    DEFAULT_POPULATION,
    DEFAULT_SEEDS,
    Experiment,
    PluginChoice,
    Primary,
    Reevaluation,
    format_seeds,
    parse_params,
    parse_seeds,
)
from .file import EXECUTION_KEYS, ExperimentFile, load
from .plan import Plan

#: each option's value where neither the user nor the experiment file gives one
DEFAULTS: Mapping[str, Any] = MappingProxyType({
    "env": DEFAULT_ENV,
    "shape": DEFAULT_SHAPE,
    "population": DEFAULT_POPULATION,
    "budget": DEFAULT_BUDGET,
    "seeds": DEFAULT_SEEDS,
    "stop_at_optimum": False,
    **{f.name: f.default for f in fields(Execution)},
})  # fmt: skip

#: the options :func:`build_run` reads
OPTIONS = frozenset({"config", "resume", "designers", "suite", "controller", "repetitions", "out", "designer_param",
                     "env_param", "controller_param", "reevaluate", "primary", *DEFAULTS})  # fmt: skip

#: options that define the experiment, which a resumed run takes from its directory
RESUME_FIXED = frozenset({"config", "env", "suite", "controller", "budget", "population", "shape", "out",
                          "designer_param", "env_param", "controller_param", "stop_at_optimum", "reevaluate",
                          "primary"})  # fmt: skip

Choices = str | PluginChoice | Sequence[str | PluginChoice]


@dataclass(frozen=True)
class RunSetup:
    """What to run, how, and into which directory: resolved once, before anything runs, and passed down."""

    experiment: Experiment
    execution: Execution
    out: Path
    #: the experiment resolved through the registry; None only for a complete run resumed unchanged
    plan: Plan | None
    #: the run directory a resume continues (opened and checked here, once); None for a new run
    resumed: RunDirectory | None = None
    #: the seeds a resume adds to the run's own
    added_seeds: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        """A controller whose bodies learn together (``modular-ppo``) needs each generation in one call."""
        choice = self.experiment.controller
        if self.plan is None or self.plan.controller is None or choice is None:
            return
        from ..execution.evaluation import instance

        if not getattr(instance(self.plan.controller), "learns_across_bodies", False):
            return
        batch, population = self.execution.batch, self.experiment.population
        if self.execution.workers > 1 or (batch is not None and batch < population):
            raise ConfigError(
                f"controller {choice.label!r} learns a generation's bodies together: use "
                f"--workers 1 and no --batch below the population ({population})"
            )


def build_run(given: Mapping[str, Any], *, reg: Registry | None = None) -> RunSetup:
    """The run ``given`` asks for: option name -> value, only the options the user gave.

    Values are as on the command line (``"ga,gda[epochs=50]"``, ``"0..9"``, ``"5x5"``) or as
    Python has them (choices, seed lists, shape pairs).  ``given["resume"]`` names a run
    directory to continue.  Errors are :class:`~gdabench.errors.ConfigError` lines naming the option.
    """
    unknown = sorted(set(given) - OPTIONS)
    if unknown:
        raise TypeError(f"build_run() got unknown options: {', '.join(unknown)}")
    file = load(given["config"]) if given.get("config") is not None else ExperimentFile(None)
    execution = _execution(given, file)
    if given.get("resume") is not None:
        run = RunDirectory.open(given["resume"])
        stored = stored_experiment(run)
        return _resume(run, Path(given["resume"]), stored, _resumed(stored, given), execution, reg)
    experiment = _experiment(given, file, reg)
    out = Path(given.get("out") or file.out or default_out_dir(experiment))
    return RunSetup(experiment, execution, out, Plan.resolve(experiment, reg))


def setup_run(
    experiment: Experiment | None,
    out: str | Path | None = None,
    *,
    resume: bool = False,
    execution: Execution | None = None,
    reg: Registry | None = None,
) -> RunSetup:
    """The setup of running ``experiment`` into ``out``, for a caller that holds an :class:`Experiment`.

    A resume takes the experiment from the directory; ``experiment`` may only add seeds to it.
    """
    execution = execution or Execution()
    if resume:
        if out is None:
            raise RunDirectoryError("resume needs the run directory")
        run = RunDirectory.open(out)
        stored = stored_experiment(run)
        return _resume(run, Path(out), stored, with_added_seeds(stored, experiment), execution, reg)
    if experiment is None:
        raise ConfigError("compare() needs an experiment unless it resumes a run")
    out = Path(out) if out is not None else default_out_dir(experiment)
    return RunSetup(experiment, execution, out, Plan.resolve(experiment, reg))


def _resume(
    run: RunDirectory, out: Path, stored: Experiment, experiment: Experiment, execution: Execution,
    reg: Registry | None,
) -> RunSetup:
    """The setup that continues ``run`` with ``experiment`` (``stored`` with any seeds added): its plan checked
    against the versions the run recorded, its timeout the run's unless one is given."""
    meta = run.meta
    added = experiment.seeds[len(stored.seeds):]
    if meta.get("status") == "complete" and not added:
        if not run.evaluations_path.exists():
            raise RunDirectoryError(
                f"run {run.path} is complete but its table {run.evaluations_path} is missing; restore it"
            )
        return RunSetup(experiment, execution, out, None, run)
    if execution.timeout is None and (meta.get("execution") or {}).get("timeout"):
        execution = Execution(**{**execution.to_json(), "timeout": meta["execution"]["timeout"]})
    plan = Plan.resolve(experiment, reg)
    plan.check_versions(run.path, meta, "resuming")
    return RunSetup(experiment, execution, out, plan, run, tuple(added))


def stored_experiment(run: RunDirectory) -> Experiment:
    """The experiment a run directory records: what resuming it continues."""
    return Experiment.from_json(run.meta["config"], f"{run.path / 'run.json'}: config")


def with_added_seeds(stored: Experiment, given: Experiment | None) -> Experiment:
    """``stored`` with the seeds ``given`` adds after its own, so finished trials keep their rows.

    A resume cannot change anything else, nor drop a seed: the table would mix two experiments.
    """
    if given is None or given == stored:
        return stored
    changed = [
        f.name for f in fields(Experiment) if f.name != "seeds" and getattr(given, f.name) != getattr(stored, f.name)
    ]
    if changed:
        raise ConfigError(
            f"a resumed run keeps its experiment ({', '.join(changed)} would change); only seeds can be added"
        )
    dropped = [s for s in stored.seeds if s not in given.seeds]
    if dropped:
        raise ConfigError(
            f"the run has seeds {format_seeds(stored.seeds)}; resuming can add seeds but not drop "
            f"{format_seeds(dropped)}"
        )
    return replace(stored, seeds=stored.seeds + tuple(s for s in given.seeds if s not in stored.seeds))


def default_out_dir(experiment: Experiment, root: str | Path = "results") -> Path:
    """``results/<time>-<envs>-<designers>``: where a run goes unless told."""
    envs = "+".join(e.name.replace("/", "_") for e in experiment.envs)
    names = "-".join(d.name for d in experiment.designers)
    return Path(root) / f"{time.strftime('%Y%m%d-%H%M%S')}-{envs}-{names}"


def _choices(value: Choices) -> tuple[PluginChoice, ...]:
    """Plugin choices from text (``"ga,gda[epochs=50]"``), a choice, or a sequence of either."""
    items = [value] if isinstance(value, (str, PluginChoice)) else list(value)
    out: list[PluginChoice] = []
    for item in items:
        out += PluginChoice.parse_list(item) if isinstance(item, str) else [item]
    return tuple(out)


def _pick(name: str, given: Mapping[str, Any], from_file: Any) -> Any:
    """An option's value: as given, else from the file, else the default."""
    if name in given:
        return given[name]
    return DEFAULTS[name] if from_file is None else from_file


def _execution(given: Mapping[str, Any], file: ExperimentFile) -> Execution:
    defaults = {name: DEFAULTS[name] for name in EXECUTION_KEYS}
    return Execution(**{**defaults, **file.execution, **{n: given[n] for n in EXECUTION_KEYS if n in given}})


def _given_seeds(given: Mapping[str, Any]) -> tuple[int, ...] | None:
    """The seeds ``seeds`` or ``repetitions`` name; None where neither is given."""
    if not {"seeds", "repetitions"} & set(given):
        return None
    seeds = given.get("seeds")
    text = seeds if seeds is None or isinstance(seeds, str) else list(seeds)
    return tuple(parse_seeds(text, given.get("repetitions")))


def _experiment(given: Mapping[str, Any], file: ExperimentFile, reg: Registry | None) -> Experiment:
    suite_name = given["suite"] if "suite" in given else file.suite
    suite = (reg or registry()).get("suite", suite_name).spec if suite_name else None
    if "env" in given:
        envs = _choices(given["env"])
    elif suite is not None and ("suite" in given or file.envs is None):
        envs = tuple(PluginChoice.parse(e) for e in suite.envs)
    else:
        envs = file.envs or _choices(DEFAULTS["env"])
    env_params = parse_params(given.get("env_param"), "environment parameter")
    designers = _choices(given["designers"]) if given.get("designers") else file.designers or ()
    seeds = _given_seeds(given)
    controller = _controller(given, file, suite.controller if suite is not None else None)
    primary = Primary.from_json(given["primary"]) if given.get("primary") is not None else file.primary
    return Experiment(
        designers=_with_designer_params(designers, given.get("designer_param")),
        envs=tuple(e.with_params(env_params) for e in envs),
        controller=controller,
        shape=parse_shape(_pick("shape", given, file.shape)),
        population=_pick("population", given, file.population),
        budget=_pick("budget", given, file.budget),
        seeds=seeds if seeds is not None else file.seeds or _primary_seeds(primary) or DEFAULTS["seeds"],
        stop_at_optimum=_pick("stop_at_optimum", given, file.stop_at_optimum),
        reevaluate=_reevaluate(given, file, controller),
        primary=primary,
    )


def _reevaluate(given: Mapping[str, Any], file: ExperimentFile, controller: PluginChoice | None) -> Reevaluation | None:
    """Re-evaluation as given, else the file's, else on (the default top and seeds) where a controller learns
    each body: its reward then depends on the training seed, and a trial's best is the best of noisy numbers."""
    if given.get("reevaluate") is not None:
        return Reevaluation.parse(given["reevaluate"], "--reevaluate")
    if isinstance(file.reevaluate, Reevaluation):
        return file.reevaluate
    if file.reevaluate is False:
        return None
    return Reevaluation() if controller is not None else None


def _primary_seeds(primary: Primary | None) -> tuple[int, ...] | None:
    """Seeds 0..n-1, n from the power analysis for the primary comparison's smallest effect of interest."""
    if primary is None:
        return None
    needed = seeds_needed(primary.effect, alpha=primary.alpha, target_power=primary.power)
    if needed is None:
        raise ConfigError(f"primary: no number of seeds up to 1000 detects A12 = {primary.effect} {primary.power:.0%} "
                          "of the time; give seeds, or a larger effect")  # fmt: skip
    return tuple(range(needed))


def _controller(given: Mapping[str, Any], file: ExperimentFile, suite_controller: str | None) -> PluginChoice | None:
    """The controller as given, else the file's, else the suite's; with ``controller_param`` added."""
    value = given.get("controller") or file.controller
    controller = PluginChoice.parse(value) if isinstance(value, str) else value
    if controller is None and suite_controller:
        controller = PluginChoice.parse(suite_controller)
    extra = given.get("controller_param")
    if extra:
        if controller is None:
            raise ConfigError("--controller-param given without --controller")
        controller = controller.with_params(parse_params(extra, "controller parameter"))
    return controller


def _with_designer_params(designers: Sequence[PluginChoice], items: Sequence[str] | None) -> tuple[PluginChoice, ...]:
    """Each designer with the ``KEY=VALUE`` parameters for all designers and ``NAME.KEY=VALUE`` for it."""
    if not designers:
        raise ConfigError("give --designers, e.g. --designers ga,cppn,gda (or designers in --config)")
    shared: dict[str, Any] = {}
    targeted: dict[str, dict[str, Any]] = {}
    for item in items or ():
        key = item.partition("=")[0]
        if "." in key:
            target, _, rest = item.partition(".")
            if not any(target in (d.name, d.label) for d in designers):
                raise ConfigError(f"--designer-param {item!r} names designer {target!r}, which is not in this run")
            targeted.setdefault(target, {}).update(parse_params([rest], "designer parameter"))
        else:
            shared.update(parse_params([item], "designer parameter"))
    return tuple(d.with_params({**shared, **targeted.get(d.name, {}), **targeted.get(d.label, {})}) for d in designers)


def _resumed(stored: Experiment, given: Mapping[str, Any]) -> Experiment:
    """The resumed run's experiment: ``stored``, with the seeds ``given`` adds."""
    fixed = sorted(RESUME_FIXED & set(given))
    if given.get("designers") and _choices(given["designers"]) != stored.designers:
        fixed.insert(0, "designers")
    if fixed:
        named = ", ".join(f"--{name.replace('_', '-')}" for name in fixed)
        raise ConfigError(
            f"--resume takes the experiment from the run; {named} cannot change it (--seeds can add seeds)"
        )
    seeds = _given_seeds(given)
    return stored if seeds is None else with_added_seeds(stored, replace(stored, seeds=seeds))


def significance_warnings(experiment: Experiment, alpha: float | None = None) -> list[str]:
    """What an experiment's seeds cannot show, said before it runs: a primary comparison with fewer seeds than
    any significant result needs (or than its power analysis asks for), or, without one, pairs of designers
    that no outcome could make significant after Holm's correction (at ``alpha``, by default 0.05)."""
    alpha = ALPHA if alpha is None else alpha
    n, designers = len(experiment.seeds), len(experiment.designers)
    out = []
    primary = experiment.primary
    if primary is not None:
        fewest = minimum_seeds(primary.alpha)
        needed = seeds_needed(primary.effect, alpha=primary.alpha, target_power=primary.power)
        name = f"the primary comparison ({primary.a} against {primary.b})"
        if n < fewest:
            out.append(
                f"{name} cannot be significant with {n} seeds: the exact signed-rank test's smallest two-sided p "
                f"is 2/2^{n} = {2 / 2**n:.3g}, above {primary.alpha:g}; at least {fewest} seeds whose two runs differ "
                f"are needed, and about {needed} to detect A12 = {primary.effect:g} {primary.power:.0%} of the time"
            )
        elif needed is None or n < needed:
            out.append(
                f"{name} has {n} seeds; about {needed or 'more than 1000'} detect its smallest effect of interest "
                f"(A12 = {primary.effect:g}) {primary.power:.0%} of the time at {primary.alpha:g}"
            )
    pairs = designers * (designers - 1) // 2 - (primary is not None)
    if pairs >= 1:
        fewest = minimum_seeds(alpha / pairs)
        if n < fewest:
            which = "no other pair of designers (exploratory)" if primary is not None else "no pair of designers"
            out.append(
                f"{which} can differ significantly with {n} seeds: after Holm's correction over {pairs} pair(s) at "
                f"{alpha:g} the exact signed-rank test needs at least {fewest} seeds"
                + ("" if primary is not None else f" ({minimum_seeds(alpha)} for one primary comparison)")
            )
    return out
