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
        Patch(
            facecolor=(COLOURS[c][0] / 255, COLOURS[c][1] / 255, COLOURS[c][2] / 255),
            edgecolor="0.35",
            label=VOXEL_NAMES[c],
        )
        for c in (RIGID, SOFT, H_ACT, V_ACT)
    ]


def bodies_figure(
    bodies: Sequence[Body | None],
    captions: Sequence[str],
    *,
    title: str = "",
    ncols: int = 8,
    row_labels: Sequence[str] | None = None,
    scale: int = 18,
    dpi: int = 100,
) -> Figure:
    """A grid of body pictures, a caption above each (one or more lines), drawn as one image (fast for many bodies).

    ``None`` leaves a cell empty; with ``row_labels`` each row of ``ncols`` cells gets a heading.
    """
    n = len(bodies)
    shapes = {b.shape for b in bodies if b is not None}
    if len(shapes) > 1:
        raise ValueError(f"bodies of different shapes cannot share one grid: {sorted(shapes)}")
    h, w = shapes.pop() if shapes else (5, 5)
    ncols = max(1, min(ncols, n)) if row_labels is None else max(1, ncols)
    nrows = max(1, math.ceil(n / ncols))
    lines = max((text.count("\n") + 1 for text in captions), default=1)
    pad, caption, heading = 12, 7 + 9 * lines, (18 if row_labels else 0)
    cell_w, cell_h = w * scale + pad, heading + h * scale + caption + pad
    canvas = np.full((nrows * cell_h + pad, ncols * cell_w + pad, 3), 255, dtype=np.uint8)
    origins = []
    for i, body in enumerate(bodies):
        r, c = divmod(i, ncols)
        y, x = pad + r * cell_h + heading + caption, pad + c * cell_w
        origins.append((y, x))
        if body is None:
            continue
        canvas[y - 1 : y + h * scale + 1, x - 1 : x + w * scale + 1] = 217  # light frame: the grid's extent
        canvas[y : y + h * scale, x : x + w * scale] = body_image(body, scale)[..., :3]
    top, bottom = (0.35 if title else 0.05), 0.35  # inches for the title and the legend
    height_in = canvas.shape[0] / dpi
    fig = Figure(figsize=(max(canvas.shape[1] / dpi, 4.5), height_in + top + bottom), dpi=dpi)
    total = height_in + top + bottom
    ax = fig.add_axes((0, bottom / total, 1, height_in / total))
    ax.imshow(canvas, interpolation="nearest")
    ax.set_axis_off()
    for (y, x), text, body in zip(origins, captions, bodies):
        if body is not None:
            ax.text(x + w * scale / 2, y - 3, text, ha="center", va="bottom", fontsize=6.5)
    for r, label in enumerate((row_labels or [])[:nrows]):
        ax.text(pad, pad + r * cell_h, label, ha="left", va="top", fontsize=9, fontweight="bold")
    if title:
        fig.suptitle(title, fontsize=10, y=1 - 0.08 / total, va="top")
    fig.legend(handles=voxel_legend(), loc="lower center", ncols=4, fontsize=7, frameon=False)
    return fig
