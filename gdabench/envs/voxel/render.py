"""Headless frames of a voxel world with Pillow: the robot, the task's moving objects and its terrain.

Colours follow Evolution Gym's: rigid black, soft grey, horizontal actuators orange, vertical actuators
blue, fixed voxels brown.  The camera follows the robot's centre of mass; tick marks every metre along
the bottom make motion visible although the camera moves with the robot.
"""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw

from .engine import BodyTables
from .model import FIXED, H_ACT, RIGID, SOFT, V_ACT

COLORS = {RIGID: (38, 38, 38), SOFT: (191, 191, 191), H_ACT: (253, 142, 62), V_ACT: (109, 175, 214),
          FIXED: (120, 100, 80)}
SKY, FLOOR, TICK = (250, 250, 255), (170, 160, 150), (60, 60, 60)


class WorldRenderer:
    """Draws body ``b`` of ``tables`` in its world, given an environment's point positions."""

    def __init__(self, tables: BodyTables, b: int, *, size: tuple[int, int] = (480, 240),
                 pixels_per_meter: float = 160.0):
        w = tables.world
        self.size, self.ppm = size, pixels_per_meter
        self.static = [obj.pos[obj.boxel_points] for obj in w.static]  # (n, 4, 2) corners, never moving
        self.static_colors = [[COLORS[int(c)] for c in obj.boxel_type] for obj in w.static]
        #: each moving object whole: its boxels, its points at rest, which of them are simulated and where
        self.objects = []
        start = 0
        for part, whole, kept, rest in zip(w.moving, w.whole, w.kept, w.rest):
            self.objects.append((whole.boxel_points, [COLORS[int(c)] for c in whole.boxel_type], kept, rest, start))
            start += len(part.pos)
        robot = tables.robots[b]
        self.robot_quads = robot.boxel_points + tables.robot_start
        self.robot_colors = [COLORS[int(c)] for c in robot.boxel_type]
        self.robot = slice(tables.robot_start, tables.robot_start + int(tables.n_robot_points[b]))

    def draw(self, positions: np.ndarray) -> np.ndarray:
        """An (H, W, 3) uint8 frame for the environment's point positions ``(P, 2)``."""
        width, height = self.size
        centre = positions[self.robot].mean(axis=0)
        left = float(centre[0]) - width / (2 * self.ppm)
        bottom = min(-0.15, float(centre[1]) - height / (2 * self.ppm))

        def px(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return (x - left) * self.ppm, height - (y - bottom) * self.ppm

        image = Image.new("RGB", self.size, SKY)
        canvas = ImageDraw.Draw(image)
        floor_x, floor_y = px(np.array([left, left + width / self.ppm]), np.array([0.0, bottom]))
        canvas.rectangle([floor_x[0], floor_y[0], floor_x[1], floor_y[1]], fill=FLOOR)
        for metre in range(int(np.floor(left)), int(np.ceil(left + width / self.ppm)) + 1):
            (x,), (y,) = px(np.array([metre]), np.array([bottom + 0.05]))
            canvas.line([(x, y - 8), (x, y)], fill=TICK, width=2)
            canvas.text((x + 3, y - 12), f"{metre} m", fill=TICK)
        quads = [(corners, fill) for obj, fills in zip(self.static, self.static_colors)
                 for corners, fill in zip(obj, fills)]
        for boxels, fills, kept, rest, start in self.objects:
            points = rest.copy()
            points[kept] = positions[start:start + len(kept)]
            quads += [(points[q], fill) for q, fill in zip(boxels, fills)]
        quads += [(positions[q], fill) for q, fill in zip(self.robot_quads, self.robot_colors)]
        for corners, fill in quads:
            xs, ys = px(corners[:, 0], corners[:, 1])
            canvas.polygon(list(zip(xs.tolist(), ys.tolist())), fill=fill, outline=(0, 0, 0))
        return np.asarray(image)
