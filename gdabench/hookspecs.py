"""The plugin contract of gdabench.

A plugin is any module (or object) with functions marked ``@gdabench.hookimpl`` whose names
match the hooks below.  Built-in plugins are registered through exactly these hooks; a
third-party package makes itself known by declaring an entry point::

    [project.entry-points.gdabench]
    my_plugin = "my_package.plugin"      # the module holding the hookimpls

Hooks return *specs* (:mod:`gdabench.specs`): a name, a factory given as an import string,
default parameters and a one-line description.  Keep the plugin module light: it is imported
whenever gdabench starts, so import heavy libraries only in the factory's module.
"""

from __future__ import annotations

from typing import Sequence

import pluggy

from .specs import ControllerSpec, DesignerSpec, EnvironmentSpec

PROJECT_NAME = "gdabench"

hookspec = pluggy.HookspecMarker(PROJECT_NAME)
hookimpl = pluggy.HookimplMarker(PROJECT_NAME)


@hookspec
def gdabench_designers() -> Sequence[DesignerSpec]:
    """Return the designers (morphology search algorithms) this plugin provides.

    The factory is called as ``factory(shape=(H, W), population=int, budget=int,
    seed=numpy.random.SeedSequence, **params)`` and must return a
    :class:`gdabench.Designer` (ask/tell).
    """


@hookspec
def gdabench_environments() -> Sequence[EnvironmentSpec]:
    """Return the environments (ways to score a body) this plugin provides.

    The factory is called as ``factory(shape=(H, W), **params)`` and must return a
    :class:`gdabench.Environment`.
    """


@hookspec
def gdabench_controllers() -> Sequence[ControllerSpec]:
    """Return the controllers (ways to make a body act in a physics environment).

    The factory is called as ``factory(**params)`` and must return a
    :class:`gdabench.Controller`.
    """
