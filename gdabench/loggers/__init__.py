"""Built-in logger plugins: each generation's figures sent to an experiment tracker (``--log NAME``).

A logger is a plugin like any other: an object whose ``@gdabench.hookimpl`` methods implement the
event hooks of :mod:`gdabench.hookspecs`; ``--log`` registers it for the run.
"""

from __future__ import annotations

from typing import Any

from ..errors import ConfigError

LOGGERS = {"tensorboard": "gdabench.loggers.tensorboard:TensorBoardLogger"}


def make_logger(name: str) -> Any:
    """The logger plugin ``name`` (one line naming the extra to install when its library is missing)."""
    if name not in LOGGERS:
        raise ConfigError(f"unknown logger {name!r}; known loggers: {', '.join(LOGGERS)}")
    module, _, attr = LOGGERS[name].partition(":")
    import importlib

    return getattr(importlib.import_module(module), attr)()
