"""Common ground of the analytic landscapes (``two-peaks``, ``target``, ``nk``).

They score a body with a formula, so they are cheap enough to compare designers over many
seeds, and each knows its optimum.  They refuse invalid bodies themselves instead of trusting
the harness to filter them: a landscape used outside the runner (a notebook, another tool)
must never hand an invalid body a score that looks like a valid one.
"""

from __future__ import annotations

import abc
from pathlib import Path
from typing import Any

import numpy as np

from ..body import Body
from ..environment import Controller, Environment
from ..errors import ConfigError, InvalidBodyError


class Landscape(Environment):
    """An environment whose reward is a function of the voxel codes alone."""

    #: name used in error messages
    name: str = "landscape"

    def evaluate(
        self, body: Body, *, seed: int, controller: Controller | None = None, workdir: Path | None = None
    ) -> float:
        reason = self.invalid_reason(body)
        if reason is not None:
            raise InvalidBodyError(f"{self.name}: cannot score body {body.text}: {reason}")
        return self.score(np.asarray(body.voxels))

    @abc.abstractmethod
    def score(self, voxels: np.ndarray) -> float:
        """Reward of a valid (H, W) grid of codes (validity is checked by :meth:`evaluate`)."""

    def _int_param(self, key: str, value: Any, low: int, high: int | None = None) -> int:
        """An integer parameter within ``[low, high]``, or a one-line :class:`ConfigError`."""
        ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
        if not ok or value < low or (high is not None and value > high):
            bounds = f"between {low} and {high}" if high is not None else f"at least {low}"
            raise ConfigError(f"{self.name}: {key} must be an integer {bounds}, got {value!r}")
        return int(value)

    def _shape_text(self) -> str:
        return f"{self.shape[0]}x{self.shape[1]}"
