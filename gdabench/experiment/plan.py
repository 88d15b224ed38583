"""Resolving an experiment once: plugin names to specs, parameters to typed values, trials to recipes.

Everything after resolution works from the :class:`Plan`: trial specs are picklable (factories
named by import string, parameters converted), so they travel to worker processes and Ray
actors unchanged, and :meth:`Plan.scorers` builds an environment and controller exactly as
trials build them, for ``evaluate``, ``replay`` and the report.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping, cast

from ..environment import Controller, Environment
from ..errors import ConfigError, PluginError
from ..execution.cache import recipe_identity
from ..execution.evaluation import adopt, instance
from ..names import file_name
from ..params import check_params
from ..plugins import Registry, registry
from ..results import RunDirectory
from ..spawning import from_script
from ..specs import Factory
from .config import Experiment, PluginChoice
from .trial_spec import DesignerRecipe, EnvRecipe, TrialSpec, build_plugin

#: keyword arguments the harness itself passes to designer and environment factories
HARNESS_DESIGNER_ARGS = ("shape", "population", "budget", "seed")
HARNESS_ENV_ARGS = ("shape",)


def _json(params: Mapping[str, Any]) -> str:
    return json.dumps(dict(params), sort_keys=True, default=str)


class Plan:
    """An experiment resolved against the installed plugins: recipes, trial specs, built scorers."""

    def __init__(
        self,
        experiment: Experiment,
        envs: list[EnvRecipe],
        controller: Factory | None,
        controller_package: tuple[str, str] | None,
        designers: list[DesignerRecipe],
    ):
        self.experiment = experiment
        self.envs = envs
        self.controller = controller
        self.designers = designers
        #: why an environment's evaluations cannot be cached, by label
        self.uncacheable: dict[str, str] = {}
        self._contexts = {env.label: self._cache_context(env, controller_package) for env in envs}
        self.trials = self._trials()

    @classmethod
    def resolve(cls, experiment: Experiment, reg: Registry | None = None, *, designers: bool = True) -> Plan:
        """Check everything about ``experiment`` that can be checked without running it.

        ``designers=False`` resolves only the environments and the controller (enough to score,
        replay or animate bodies of a run; the plan then has no trials).
        """
        reg = reg or registry()
        experiment.check()
        exp = experiment
        cls._check_settings(reg, exp, designers)  # cheap checks first, before any heavy import
        envs = [cls._env(reg, choice, exp) for choice in exp.envs]  # first: they say whether a controller belongs
        controller, controller_package = None, None
        if exp.controller is not None:
            item = reg.get("controller", exp.controller.name)
            controller_package = (item.distribution, item.version)
            params = check_params(
                "controller", exp.controller.label, item.spec.load(), {**item.spec.defaults, **exp.controller.params}
            )
            controller = Factory.of(item.spec.factory, params)
            # built here to check it, and kept as this process's object for the recipe (reused by trials here)
            obj = adopt(controller, build_plugin("controller", exp.controller.label, controller))
            if not isinstance(obj, Controller):
                raise PluginError(
                    f"controller {exp.controller.label!r}: factory returned {type(obj).__name__}, not a "
                    f"gdabench.Controller"
                )
        recipes = []
        for choice in exp.designers if designers else ():
            item = reg.get("designer", choice.name)
            params = check_params(
                "designer",
                choice.label,
                item.spec.load(),
                {**item.spec.defaults, **choice.params},
                HARNESS_DESIGNER_ARGS,
            )
            recipe = DesignerRecipe(choice.label, choice.name, Factory.of(item.spec.factory, params))
            recipe.build(
                exp.shape, exp.population, exp.budget, exp.seeds[0]
            )  # constructor checks, before any run starts
            recipes.append(recipe)
        return cls(exp, envs, controller, controller_package, recipes)

    @staticmethod
    def _check_settings(reg: Registry, exp: Experiment, designers: bool) -> None:
        """Refuse bad parameters of the plugins whose specs name a light ``settings`` checker (seconds
        before their factories would import torch and fail on the same parameter)."""
        chosen = [("controller", exp.controller)] if exp.controller is not None else []
        chosen += [("designer", choice) for choice in exp.designers] if designers else []
        chosen += [("environment", choice) for choice in exp.envs]
        for kind, choice in chosen:
            spec = reg.get(kind, choice.name).spec
            settings = spec.load_settings()
            if settings is not None:
                settings(**check_params(kind, choice.label, settings, {**spec.defaults, **choice.params}))

    @staticmethod
    def _env(reg: Registry, choice: PluginChoice, exp: Experiment) -> EnvRecipe:
        item = reg.get("environment", choice.name)
        spec = item.spec
        params = check_params(
            "environment", choice.label, spec.load(), {**spec.defaults, **choice.params}, HARNESS_ENV_ARGS
        )
        needs_controller = bool(getattr(spec, "requires_controller", False))
        if needs_controller and exp.controller is None:
            known = ", ".join(reg.names("controller")) or "(none installed)"
            raise ConfigError(f"environment {choice.name!r} needs a controller: add --controller NAME (known: {known})")
        if exp.controller is not None and not needs_controller:
            raise ConfigError(f"environment {choice.name!r} scores bodies directly and takes no controller")
        factory = Factory.of(spec.factory, {"shape": tuple(exp.shape), **params})
        env = adopt(factory, build_plugin("environment", choice.label, factory))
        if not isinstance(env, Environment):
            raise PluginError(
                f"environment {choice.label!r}: factory returned {type(env).__name__}, not a gdabench.Environment"
            )
        return EnvRecipe(
            choice.label,
            choice.name,
            factory,
            env.version,
            env.optimum,
            bool(env.deterministic),
            (item.distribution, item.version),
        )

    def _trials(self) -> list[TrialSpec]:
        exp = self.experiment
        several_envs = len(self.envs) > 1
        trials: list[TrialSpec] = []
        names: dict[str, str] = {}
        for repetition, seed in enumerate(exp.seeds):
            for env in self.envs:
                for designer in self.designers:
                    label = f"{env.label}-{designer.label}" if several_envs else designer.label
                    name = self.trial_name(env.label, designer.label, seed)
                    clash = names.get(name.lower())
                    if clash is not None and clash != label:
                        raise ConfigError(
                            f"labels {clash!r} and {label!r} map to the same file name {name!r}; rename one"
                        )
                    names[name.lower()] = label
                    constants = {
                        "designer": designer.label,
                        "designer_name": designer.name,
                        "env": env.label,
                        "env_version": env.version or "",
                        "controller": exp.controller.label if exp.controller else "",
                        "designer_params": _json(designer.params),
                        "env_params": _json({k: v for k, v in env.factory.params if k != "shape"}),
                        "controller_params": _json(dict(self.controller.params)) if self.controller else "{}",
                        "shape": f"{exp.shape[0]}x{exp.shape[1]}",
                        "population": exp.population,
                        "budget": exp.budget,
                        "seed": seed,
                        "repetition": repetition,
                    }
                    title = f"{label} seed {seed}"
                    trials.append(
                        TrialSpec(
                            len(trials),
                            name,
                            designer,
                            env,
                            self.controller,
                            seed,
                            repetition,
                            cast("tuple[int, int]", tuple(exp.shape)),
                            exp.population,
                            exp.budget,
                            exp.stop_at_optimum,
                            title,
                            constants,
                            self._contexts[env.label],
                        )
                    )
        return trials

    @property
    def from_script(self) -> bool:
        """Whether a plugin of this plan is defined in the user's script (``__main__``): workers must import it."""
        factories = (
            [d.factory for d in self.designers]
            + [e.factory for e in self.envs]
            + [self.controller] * bool(self.controller)
        )
        return any(from_script(f.factory) for f in factories if f is not None)

    def trial_name(self, env: str, designer: str, seed: int) -> str:
        """The file-system name of a trial (its checkpoint, pending rows and artifacts)."""
        label = f"{env}-{designer}" if len(self.experiment.envs) > 1 else designer
        return f"{file_name(label)}-seed{seed}"

    def workdir(self, run_path: Path, env: str, designer: str, seed: int, body_hash: str) -> Path:
        """Where the trial's evaluation of a body kept its files (e.g. a trained policy)."""
        return RunDirectory(run_path).artifacts(self.trial_name(env, designer, seed)) / body_hash

    def _cache_context(self, env: EnvRecipe, controller_package: tuple[str, str] | None) -> dict[str, Any] | None:
        if not env.deterministic:
            self.uncacheable[env.label] = f"environment {env.label!r} is not deterministic"
            return None
        try:
            return {
                "env": env.name,
                "env_recipe": recipe_identity(env.factory, env.package),
                "controller": self.experiment.controller.name if self.experiment.controller else None,
                "controller_recipe": recipe_identity(self.controller, controller_package),
            }
        except TypeError as exc:
            self.uncacheable[env.label] = f"a parameter of {env.label!r} or its controller is not a plain value ({exc})"
            return None

    def check_versions(self, run_path: Path, meta: Mapping[str, Any], doing: str) -> None:
        """A run's rows may not mix dynamics: every environment must still build the version the run recorded
        (``doing``: what would mix them, e.g. "resuming")."""
        recorded = meta.get("envs") or {}
        for env in self.envs:
            was = (recorded.get(env.label) or {}).get("version")
            if was is not None and was != env.version:
                raise ConfigError(
                    f"{run_path}: its rows were scored by {was}, but '{env.label}' now builds {env.version}; "
                    f"{doing} would mix the two in one table (start a new run)"
                )

    def scorers(self, env_label: str | None = None) -> tuple[Environment, Controller | None]:
        """The environment (the first, or the one labelled ``env_label``) and controller, as trials build them."""
        env = self.envs[0] if env_label is None else next((e for e in self.envs if e.label == env_label), None)
        if env is None:
            raise ConfigError(
                f"no environment {env_label!r} in this experiment; environments: "
                f"{', '.join(e.label for e in self.envs)}"
            )
        controller = instance(self.controller) if self.controller is not None else None
        return instance(env.factory), controller
