"""Headless drawing of the walker world with Pillow (GIFs: :func:`gdabench.report.animation.frames_to_gif`).

Colours follow Evolution Gym's: rigid black, soft grey, horizontal actuators orange, vertical
actuators blue.  The camera follows the body's centre of mass; tick marks every metre along
the terrain make forward motion visible even though the camera moves with the body.
"""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw

from ...body import H_ACT, RIGID, SOFT, V_ACT
from .sim import Terrain

VOXEL_COLORS = {RIGID: (38, 38, 38), SOFT: (191, 191, 191), H_ACT: (253, 142, 62), V_ACT: (109, 175, 214)}
SKY, TERRAIN, FLOOR, TICK = (250, 250, 255), (120, 100, 80), (170, 160, 150), (60, 60, 60)


class Renderer:
    """Draws one body's voxels (given point positions) over the terrain."""

    def __init__(
        self,
        voxel_corners: np.ndarray,
        voxel_codes: np.ndarray,
        terrain: Terrain,
        *,
        size: tuple[int, int] = (480, 240),
        pixels_per_meter: float = 160.0,
    ):
        self.corners = np.asarray(voxel_corners)
        self.colors = [VOXEL_COLORS[int(c)] for c in voxel_codes]
        self.terrain = terrain
        self.size = size
        self.ppm = pixels_per_meter

    def draw(self, positions: np.ndarray) -> np.ndarray:
        """An (H, W, 3) uint8 frame of the body with point positions ``positions``."""
        width, height = self.size
        t = self.terrain
        centre_x = float(positions[:, 0].mean())
        left = centre_x - width / (2 * self.ppm)
        bottom = t.top - 0.25  # the terrain surface sits a quarter metre above the frame's bottom

        def px(x: float | np.ndarray, y: float | np.ndarray) -> tuple:
            return (x - left) * self.ppm, height - (y - bottom) * self.ppm

        image = Image.new("RGB", self.size, SKY)
        canvas = ImageDraw.Draw(image)
        canvas.rectangle([px(left, t.floor), px(left + width / self.ppm, bottom)], fill=FLOOR)
        canvas.rectangle([px(t.x_start, t.top), px(t.x_end, bottom)], fill=TERRAIN)
        for metre in range(int(np.floor(left)), int(np.ceil(left + width / self.ppm)) + 1):
            x, y = px(metre, t.top)
            canvas.line([(x, y), (x, y + 8)], fill=TICK, width=2)
            canvas.text((x + 3, y + 8), f"{metre} m", fill=TICK)
        for corners, color in zip(self.corners, self.colors):
            quad = positions[corners]
            xs, ys = px(quad[:, 0], quad[:, 1])
            canvas.polygon(list(zip(xs.tolist(), ys.tolist())), fill=color, outline=(0, 0, 0))
        return np.asarray(image)
