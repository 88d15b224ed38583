"""Errors a user can act on.

Every problem caused by input (a name, a parameter, a body, a plugin) is raised as a
:class:`GdabenchError` whose message is one readable line; the CLI prints that line and exits
non-zero instead of showing a traceback.
"""

from __future__ import annotations


class GdabenchError(Exception):
    """Base class: the message is meant for the user, as one line."""


class ConfigError(GdabenchError, ValueError):
    """A run was configured with values that cannot work (budget, population, parameters)."""


class MalformedBodyError(GdabenchError, ValueError):
    """A body (array or text) is not a voxel grid of codes 0-4."""


class InvalidBodyError(GdabenchError, ValueError):
    """A well-formed body that breaks the validity rule was handed to something that scores bodies."""


class UnknownPluginError(ConfigError):
    """No designer, environment or controller is registered under the requested name."""


class PluginError(GdabenchError):
    """A plugin failed to import, broke its contract, or collided with another plugin."""


class RunFailure(GdabenchError):
    """A run started and failed while running; its directory keeps what was written and can be resumed."""


class DesignerError(RunFailure):
    """A designer raised or misbehaved during a run; the run directory stays resumable."""


class RunDirectoryError(GdabenchError):
    """A results directory is missing, unreadable, or not a gdabench run."""


class RunLockedError(RunDirectoryError):
    """Another process is writing the run directory (a run or a resume holds its lock)."""


class TrialError(RunFailure):
    """Trials (a designer on an environment with a seed) failed; the other trials of the run went on."""


class Terminated(KeyboardInterrupt):
    """The process was asked to stop (SIGTERM): handled as Ctrl-C is, with its own exit code."""


def one_line(exc: BaseException) -> str:
    """``Type: first line of the message``: how a failure is recorded in a row or reported."""
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}".rstrip(": ")
