"""Pictures of voxel bodies, coloured as Evolution Gym draws them.

Empty voxels are transparent (white on a page), rigid black, soft grey, horizontal actuators
orange and vertical actuators blue; the two actuator colours are the mid tones of Evolution
Gym's own orange and blue colour tables.  Row 0 of a body is its top row, as in Evolution Gym.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from ..body import EMPTY, H_ACT, RIGID, SOFT, V_ACT, VOXEL_NAMES, Body

#: RGBA colour per voxel code
COLOURS: dict[int, tuple[int, int, int, int]] = {
    EMPTY: (255, 255, 255, 0),
    RIGID: (38, 38, 38, 255),
    SOFT: (191, 191, 191, 255),
    H_ACT: (253, 142, 62, 255),
    V_ACT: (105, 173, 213, 255),
}
_PALETTE = np.array([COLOURS[c] for c in sorted(COLOURS)], dtype=np.uint8)
_EDGE = np.array([90, 90, 90, 255], dtype=np.uint8)


def body_image(body: Body, scale: int = 16) -> np.ndarray:
    """(H*scale, W*scale, 4) uint8 RGBA picture; filled voxels get a thin dark outline."""
    codes = np.asarray(body.voxels)
    image = _PALETTE[np.kron(codes, np.ones((scale, scale), dtype=np.int8))]
    if scale >= 4:
        filled = np.kron(codes != EMPTY, np.ones((scale, scale), dtype=bool))
        border = np.zeros((scale, scale), dtype=bool)
        border[0, :] = border[-1, :] = border[:, 0] = border[:, -1] = True
        outline = filled & np.tile(border, codes.shape)
        image[outline] = _EDGE
    return image


def voxel_legend() -> list[Patch]:
    """Legend handles naming the voxel colours."""
    return [
        Patch(facecolor=np.array(COLOURS[c][:3]) / 255, edgecolor="0.35", label=VOXEL_NAMES[c])
        for c in (RIGID, SOFT, H_ACT, V_ACT)
    ]


def bodies_figure(
    bodies: Sequence[Body],
    captions: Sequence[str],
    *,
    title: str = "",
    ncols: int = 8,
    row_labels: Sequence[str] | None = None,
    tile: float = 1.15,
) -> Figure:
    """A grid of body pictures with a caption under each.

    With ``row_labels`` the bodies are laid out one labelled row per label, ``ncols`` each (a
    row may be short: pass ``None`` entries to leave a cell empty).
    """
    n = len(bodies)
    ncols = max(1, min(ncols, n)) if row_labels is None else max(1, ncols)
    nrows = max(1, math.ceil(n / ncols))
    fig = Figure(figsize=(tile * ncols + (1.0 if row_labels else 0.2), tile * 1.25 * nrows + 0.9), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False)
    for i, ax in enumerate(axes.flat):
        if i >= n or bodies[i] is None:
            ax.set_axis_off()
            continue
        ax.imshow(body_image(bodies[i]), interpolation="nearest")
        ax.set_xticks([])
        ax.set_yticks([])
        for spine in ax.spines.values():  # a light frame shows the grid's extent around empty voxels
            spine.set_color("0.85")
        ax.set_title(captions[i], fontsize=7, pad=2)
    if row_labels:
        for r, label in enumerate(row_labels[:nrows]):
            axes[r, 0].text(-0.15, 0.5, label, transform=axes[r, 0].transAxes, ha="right", va="center", fontsize=9, rotation=90)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.legend(handles=voxel_legend(), loc="outside lower center", ncols=4, fontsize=7, frameon=False)
    return fig
