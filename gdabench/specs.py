"""Specs: what a plugin hook returns to describe one designer, environment or controller.

A spec names its factory by import string (``"package.module:Class"``) so that listing plugins
never imports their heavy dependencies (torch, pymunk, ...); the factory is imported only
when a run actually builds the object.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Mapping

import pluggy

from .errors import PluginError

#: the plugin entry-point group and pluggy project; ``hookimpl`` marks a plugin's hook functions and ``hookspec``
#: the contract's (:mod:`gdabench.hookspecs`); both live here, below the contract, so built-in plugins can mark
#: their hooks without importing the registry's floor
PROJECT_NAME = "gdabench"
hookspec = pluggy.HookspecMarker(PROJECT_NAME)
hookimpl = pluggy.HookimplMarker(PROJECT_NAME)


def _load(factory: str | Callable[..., Any], kind: str, name: str) -> Callable[..., Any]:
    if not isinstance(factory, str):
        return factory
    module_name, _, attr = factory.partition(":")
    try:
        obj: Any = importlib.import_module(module_name)
        for part in attr.split("."):
            obj = getattr(obj, part)
    except Exception as exc:  # any import failure is the plugin's, reported in one line
        raise PluginError(f"{kind} {name!r}: cannot load {factory!r}: {type(exc).__name__}: {exc}") from exc
    return obj


@dataclass(frozen=True)
class Factory:
    """A picklable recipe for an environment or controller: factory plus keyword arguments."""

    factory: str | Callable[..., Any]
    params: tuple[tuple[str, Any], ...] = ()

    @classmethod
    def of(cls, factory: str | Callable[..., Any], params: Mapping[str, Any]) -> Factory:
        return cls(factory, tuple(sorted(params.items())))

    def key(self) -> str:
        return repr((self.factory, self.params))

    def build(self, **harness: Any) -> Any:
        """Call the factory with its parameters (and what the harness adds, e.g. a designer's seed)."""
        return _load(self.factory, "factory", "factory")(**harness, **dict(self.params))


@dataclass(frozen=True)
class Spec:
    """``settings`` (optional): a light callable, by import string, that takes the factory's parameters and
    raises :class:`~gdabench.errors.ConfigError` for bad ones (e.g. a frozen settings dataclass); the harness
    calls it before importing the factory, so a typo is refused before torch loads."""

    name: str
    factory: str | Callable[..., Any]
    description: str
    defaults: Mapping[str, Any] = field(default_factory=dict)
    settings: str | Callable[..., Any] | None = None

    kind: ClassVar[str] = "plugin"

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name or any(c in self.name for c in " ,[]="):
            raise PluginError(
                f"invalid {self.kind} name {self.name!r}: use a non-empty name without spaces, commas, brackets or '='"
            )
        if isinstance(self.factory, str) and ":" not in self.factory:
            raise PluginError(
                f"{self.kind} {self.name!r}: factory {self.factory!r} must look like 'package.module:attribute'"
            )

    def load(self) -> Callable[..., Any]:
        """Import and return the factory."""
        return _load(self.factory, self.kind, self.name)

    def load_settings(self) -> Callable[..., Any] | None:
        """Import and return the settings checker, if the spec names one."""
        return None if self.settings is None else _load(self.settings, self.kind, self.name)

    def recipe(self, params: Mapping[str, Any]) -> Factory:
        """A picklable recipe: the factory with the spec's defaults overridden by ``params``."""
        return Factory.of(self.factory, {**self.defaults, **params})

    def create(self, **params: Any) -> Any:
        """Build the object (defaults overridden by ``params``)."""
        return self.recipe(params).build()


@dataclass(frozen=True)
class DesignerSpec(Spec):
    """A designer: ``factory(shape=, population=, budget=, seed=, **params)`` returns a Designer."""

    kind: ClassVar[str] = "designer"


@dataclass(frozen=True)
class EnvironmentSpec(Spec):
    """An environment: ``factory(shape=, **params)`` returns an Environment.

    ``requires_controller`` tells the harness (without importing anything) that bodies can
    only be scored together with a controller, e.g. a physics task.
    """

    requires_controller: bool = False
    kind: ClassVar[str] = "environment"


@dataclass(frozen=True)
class ControllerSpec(Spec):
    """A controller: ``factory(**params)`` returns a Controller."""

    kind: ClassVar[str] = "controller"


@dataclass(frozen=True)
class SuiteSpec:
    """A named set of environments to run every designer on (``--suite NAME``), with the controller
    they need, if any; each entry is written as on the command line (``"nk[k=4]"``)."""

    name: str
    envs: tuple[str, ...]
    description: str
    controller: str | None = None

    def __post_init__(self) -> None:
        if not self.name or any(c in self.name for c in " ,[]="):
            raise PluginError(
                f"invalid suite name {self.name!r}: use a non-empty name without spaces, commas, brackets or '='"
            )
        if not self.envs:
            raise PluginError(f"suite {self.name!r} names no environment")
        object.__setattr__(self, "envs", tuple(self.envs))
