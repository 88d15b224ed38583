"""Plugin manager: built-in plugins plus every installed ``gdabench`` entry point.

Built-ins are registered through the same hooks as third-party packages.  Every spec is
recorded with the plugin and distribution it came from, so ``gdabench list`` and ``run.json``
can say where each designer, environment and controller lives.

Set ``GDABENCH_DISABLE_PLUGINS=name1,name2`` (entry-point names) to skip broken plugins.
"""

from __future__ import annotations

import difflib
import importlib
import os
from dataclasses import dataclass
from importlib import metadata
from typing import Any, Generic, Iterator, Literal, TypeVar, overload

import pluggy

from . import hookspecs
from .errors import PluginError, UnknownPluginError
from .specs import ControllerSpec, DesignerSpec, EnvironmentSpec, Spec, SuiteSpec

Kind = Literal["designer", "environment", "controller", "suite"]
#: the kinds of plugin objects (suites are named sets of environments, listed with them)
KINDS: tuple[Kind, ...] = ("designer", "environment", "controller")

#: built-in plugin modules, registered under the ``gdabench`` distribution
BUILTIN_PLUGINS = ("gdabench.designers", "gdabench.envs", "gdabench.controllers")

_HOOKS: dict[Kind, tuple[str, type[Any]]] = {
    "designer": ("gdabench_designers", DesignerSpec),
    "environment": ("gdabench_environments", EnvironmentSpec),
    "controller": ("gdabench_controllers", ControllerSpec),
    "suite": ("gdabench_suites", SuiteSpec),
}


S = TypeVar("S", Spec, SuiteSpec, Any)


@dataclass(frozen=True)
class Registered(Generic[S]):
    """A spec together with where it came from."""

    spec: S
    plugin: str
    distribution: str
    version: str

    @property
    def name(self) -> str:
        return self.spec.name


def _own_version() -> str:
    try:
        return metadata.version("gdabench")
    except metadata.PackageNotFoundError:
        return "unknown"


class Registry:
    """Everything the installed plugins provide, looked up by kind and name."""

    def __init__(self, *, entry_points: bool = True, extra_plugins: dict[str, Any] | None = None):
        self.pm = pluggy.PluginManager(hookspecs.PROJECT_NAME)
        self.pm.add_hookspecs(hookspecs)
        self._origin: dict[str, tuple[str, str]] = {}  # plugin name -> (distribution, version)
        for module_name in BUILTIN_PLUGINS:
            self._register(importlib.import_module(module_name), module_name, "gdabench", _own_version())
        for name, plugin in (extra_plugins or {}).items():
            self._register(plugin, name, "<in-process>", "")
        if entry_points:
            self._load_entry_points()
        self._check_hooks()
        self._items: dict[Kind, dict[str, Registered[Any]]] = {kind: self._collect(kind) for kind in _HOOKS}

    # -- loading -----------------------------------------------------------------------------
    def _register(self, plugin: Any, name: str, dist: str, version: str) -> None:
        try:
            self.pm.register(plugin, name=name)
        except Exception as exc:  # pluggy validation errors become one line
            raise PluginError(
                f"plugin {name!r} from package {dist} does not follow the gdabench contract: {exc}"
            ) from exc
        self._origin[name] = (dist, version)

    def _check_hooks(self) -> None:
        """Refuse hook functions pluggy would silently ignore: misspelt hook names and missing markers."""
        hooks = sorted(name for name in dir(hookspecs) if name.startswith(f"{hookspecs.PROJECT_NAME}_"))
        for name, plugin in self.pm.list_name_plugin():
            dist = self._origin.get(name, ("unknown package", ""))[0]
            for attr in dir(plugin):
                if not attr.startswith(f"{hookspecs.PROJECT_NAME}_") or not callable(getattr(plugin, attr, None)):
                    continue
                marked = self.pm.parse_hookimpl_opts(plugin, attr) is not None
                if attr not in hooks:
                    raise PluginError(
                        f"plugin {name!r} from package {dist}: {attr}() is not a gdabench hook (hooks: "
                        f"{', '.join(hooks)})"
                    )
                if not marked:
                    raise PluginError(
                        f"plugin {name!r} from package {dist}: {attr}() lacks the @gdabench.hookimpl marker, so it "
                        f"would never be called"
                    )

    def _load_entry_points(self) -> None:
        disabled = {n.strip() for n in os.environ.get("GDABENCH_DISABLE_PLUGINS", "").split(",") if n.strip()}
        for ep in sorted(metadata.entry_points(group=hookspecs.PROJECT_NAME), key=lambda e: e.name):
            if ep.name in disabled or self.pm.has_plugin(ep.name):
                continue
            dist = ep.dist.name if ep.dist is not None else "unknown package"
            version = ep.dist.version if ep.dist is not None else ""
            try:
                plugin = ep.load()
            except Exception as exc:
                raise PluginError(
                    f"plugin {ep.name!r} from package {dist} failed to import: {type(exc).__name__}: {exc} "
                    f"(fix or uninstall it, or set GDABENCH_DISABLE_PLUGINS={ep.name})"
                ) from exc
            self._register(plugin, ep.name, dist, version)

    def _collect(self, kind: Kind) -> dict[str, Registered[Any]]:
        hook_name, spec_type = _HOOKS[kind]
        found: dict[str, Registered[Any]] = {}
        for impl in getattr(self.pm.hook, hook_name).get_hookimpls():
            dist, version = self._origin.get(impl.plugin_name, ("unknown package", ""))
            try:
                specs = list(impl.function() or [])
            except Exception as exc:
                raise PluginError(
                    f"plugin {impl.plugin_name!r} from package {dist}: {hook_name}() raised {type(exc).__name__}: {exc}"
                ) from exc
            for spec in specs:
                if not isinstance(spec, spec_type):
                    raise PluginError(
                        f"plugin {impl.plugin_name!r} from package {dist}: {hook_name}() returned "
                        f"{type(spec).__name__}, expected {spec_type.__name__}"
                    )
                if spec.name in found:
                    other = found[spec.name]
                    raise PluginError(
                        f"{kind} name {spec.name!r} is provided twice: by plugin {other.plugin!r} "
                        f"(package {other.distribution}) and by plugin {impl.plugin_name!r} (package {dist})"
                    )
                found[spec.name] = Registered(spec, impl.plugin_name, dist, version)
        return dict(sorted(found.items()))

    # -- lookup ------------------------------------------------------------------------------
    def names(self, kind: Kind) -> list[str]:
        return list(self._items[kind])

    def items(self, kind: Kind) -> Iterator[Registered[Any]]:
        return iter(self._items[kind].values())

    @overload
    def get(self, kind: Literal["suite"], name: str) -> Registered[SuiteSpec]: ...
    @overload
    def get(self, kind: Literal["designer", "environment", "controller"], name: str) -> Registered[Spec]: ...
    @overload
    def get(self, kind: str, name: str) -> Registered[Any]: ...
    def get(self, kind: Any, name: str) -> Registered[Any]:
        try:
            return self._items[kind][name]
        except KeyError:
            known = self.names(kind)
            close = difflib.get_close_matches(name, known, n=1)
            hint = f" Did you mean {close[0]!r}?" if close else ""
            raise UnknownPluginError(
                f"unknown {kind} {name!r}; known {kind}s: {', '.join(known) or '(none)'}.{hint}"
            ) from None

    def distributions(self) -> dict[str, str]:
        """Distribution name -> version of every registered plugin (for run.json)."""
        return dict(sorted(self._origin.values()))


_default: Registry | None = None


def registry() -> Registry:
    """The process-wide registry (built on first use)."""
    global _default
    if _default is None:
        _default = Registry()
    return _default


def reset_registry() -> None:
    """Forget the cached registry, e.g. after installing a plugin in the same process."""
    global _default
    _default = None
