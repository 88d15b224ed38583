"""``target``: how much of a target body a design reproduces, voxel by voxel (0-100).

Unlike ``simple``, whose optimum is a uniform block that any near-constant generator (such as
a fresh CPPN) hits by chance, the default target mixes all five materials in a walker-like
shape, so it has to be found rather than stumbled upon::

    11111      rigid back
    13241      horizontal actuator, soft, vertical actuator
    14031      a hole in the middle
    20002      soft legs ...
    40004      ... ending in vertical actuators

For other shapes the default target is that body scaled by nearest neighbour (at 10x10, each of its
voxels becomes a 2x2 block).  ``target`` takes another body, as text (``'11111/13241/...'``) or as
the path of a file holding that text, for any shape.  ``class_credit`` (0 by default) gives that
fraction of a voxel's credit when it has the target's material class (empty / passive: rigid or soft
/ actuator) without the exact material, which smooths the landscape.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..body import H_ACT, N_VOXEL_TYPES, RIGID, SOFT, V_ACT, Body
from ..errors import ConfigError, GdabenchError
from .landscape import Landscape

DEFAULT_TARGET = Body.from_text("11111/13241/14031/20002/40004")

#: material class of each code: 0 empty, 1 passive (rigid, soft), 2 actuator
MATERIAL_CLASS = np.zeros(N_VOXEL_TYPES, dtype=np.int8)
MATERIAL_CLASS[[RIGID, SOFT]] = 1
MATERIAL_CLASS[[H_ACT, V_ACT]] = 2


def default_target(shape: tuple[int, int]) -> Body:
    """The default target for bodies of ``shape``: the 5x5 walker, scaled by nearest neighbour
    (each voxel of the 5x5 target becomes a block), so larger bodies face the same task."""
    h, w = shape
    rows = np.arange(h) * DEFAULT_TARGET.shape[0] // h
    cols = np.arange(w) * DEFAULT_TARGET.shape[1] // w
    return Body(np.asarray(DEFAULT_TARGET.voxels)[np.ix_(rows, cols)])


def parse_target(value: Any) -> Body:
    """A target given as body text or as the path of a file that holds body text."""
    if isinstance(value, Body):
        return value
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        value = str(value)  # a one-row target such as 3444 arrives parsed as a number
    if not isinstance(value, str):
        raise ConfigError(f"target: expected body text such as '{DEFAULT_TARGET.text}' or a file path, got {value!r}")
    path = Path(value).expanduser()
    if path.is_file():
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise ConfigError(f"target: cannot read {path}: {exc.strerror or exc}") from None
        except UnicodeDecodeError:
            raise ConfigError(f"target: {path} is not a body's text (not UTF-8)") from None
        origin = f"file {path}"
    else:
        text, origin = value, "text"
    try:
        return Body.from_text(text)
    except GdabenchError as exc:
        hint = "" if origin != "text" else " (nor is it an existing file)"
        raise ConfigError(f"target {origin}: {exc}{hint}") from None


class TargetBody(Landscape):
    """Reward = 100 * (exact matches + class_credit * class-only matches) / voxels.

    Parameters:
        target: the body to reproduce, as text (rows joined by '/') or a file holding it; default a walker (the 5x5
            one, scaled to the shape)
        class_credit: credit (0-1) for a voxel of the target's material class but not its exact material
    """

    name = "target"

    def __init__(
        self, *, shape: tuple[int, int] = DEFAULT_TARGET.shape, target: str | None = None, class_credit: float = 0.0
    ):
        super().__init__(shape=shape)
        body = default_target(self.shape) if target is None else parse_target(target)
        if body.shape != self.shape:
            raise ConfigError(
                f"target: target {body.text} is {body.shape[0]}x{body.shape[1]} but bodies are {self._shape_text()}; "
                f"give target=<body text or file> of shape {self._shape_text()}"
            )
        reason = body.invalid_reason()
        if reason is not None:
            raise ConfigError(f"target: {body.text} is not a valid body ({reason}), so no design could reach it")
        ok = (
            isinstance(class_credit, (int, float)) and not isinstance(class_credit, bool) and 0.0 <= class_credit <= 1.0
        )
        if not ok:
            raise ConfigError(f"target: class_credit must be a number between 0 and 1, got {class_credit!r}")
        self.target = body
        self.class_credit = float(class_credit)
        self._target = np.asarray(body.voxels)

    def score(self, voxels: np.ndarray) -> float:
        exact = voxels == self._target
        same_class = MATERIAL_CLASS[voxels] == MATERIAL_CLASS[self._target]
        credit = exact.sum() + self.class_credit * (same_class & ~exact).sum()
        return float(100.0 * credit / exact.size)

    @property
    def optimum(self) -> float:
        return 100.0
