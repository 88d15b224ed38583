"""gdabench: a plugin-based benchmark harness for robot-morphology design.

The public API lives here; the modules behind it are implementation details.
"""

from __future__ import annotations

from typing import Any

from . import cpu as _cpu  # noqa: F401 - first: pins torch's kernels before anything imports torch (gdabench.cpu)
from .body import DEFAULT_SHAPE, EMPTY, H_ACT, RIGID, SOFT, V_ACT, Body, as_body, is_valid, mutate, random_body
from .designer import Designer, nearest_first, ranking_rewards, top_k
from .environment import Controller, Environment, Evaluation
from .envs import (
    voxel as _voxel,  # noqa: F401 - registers gdabench/Walker-v2 with Gymnasium (Numba loads on make)
    walker as _walker,  # noqa: F401 - registers gdabench/Walker-v1 with Gymnasium (pymunk loads on make)
)
from .errors import (
    ConfigError,
    DesignerError,
    GdabenchError,
    MalformedBodyError,
    PluginError,
    RunDirectoryError,
    UnknownPluginError,
)
from .experiment.config import Experiment, PluginChoice
from .plugins import registry
from .sdk import report_progress
from .seeding import designer_seed
from .specs import ControllerSpec, DesignerSpec, EnvironmentSpec, hookimpl

__version__ = "0.1.0"


_LAZY = {
    "compare": "api",
    "open_run": "api",
    "Run": "api",
    "RunDirectory": "results",
    "RunListener": "running.events",
    # the event hooks' payloads (gdabench.hookspecs): public types
    "GenerationReport": "hookspecs",
    "TrialSpec": "experiment.trial_spec",
}


def __getattr__(name: str) -> Any:
    """Import the pandas-based parts on first use, so worker processes start quickly."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'gdabench' has no attribute {name!r}")


def make_designer(name: str, *, seed: int = 0, **kwargs: Any) -> Designer:
    """Build a registered designer outside the harness (seeded exactly as in a run)."""
    return registry().get("designer", name).spec.create(seed=designer_seed(seed), **kwargs)


def make_env(name: str, **kwargs: Any) -> Environment:
    """Build a registered environment, e.g. ``make_env("simple", shape=(5, 5))``."""
    return registry().get("environment", name).spec.create(**kwargs)


def make_controller(name: str, **kwargs: Any) -> Controller:
    """Build a registered controller."""
    return registry().get("controller", name).spec.create(**kwargs)


__all__ = [
    "Body",
    "ConfigError",
    "Controller",
    "ControllerSpec",
    "DEFAULT_SHAPE",
    "Designer",
    "DesignerError",
    "DesignerSpec",
    "EMPTY",
    "Environment",
    "EnvironmentSpec",
    "Evaluation",
    "Experiment",
    "GdabenchError",
    "H_ACT",
    "MalformedBodyError",
    "PluginChoice",
    "PluginError",
    "RIGID",
    "Run",
    "RunDirectory",
    "RunListener",
    "RunDirectoryError",
    "SOFT",
    "UnknownPluginError",
    "V_ACT",
    "as_body",
    "compare",
    "hookimpl",
    "is_valid",
    "make_controller",
    "make_designer",
    "make_env",
    "mutate",
    "nearest_first",
    "open_run",
    "random_body",
    "ranking_rewards",
    "registry",
    "report_progress",
    "top_k",
]
