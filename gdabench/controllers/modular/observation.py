"""Per-voxel observations as ModularEvoGym defines them, built from the voxel engine's flat observation.

ModularEvoGym (Wang et al., the modular state-action space of CuCo, "Curriculum-based Co-design of
Morphology and Control of Voxel-based Soft Robots", ICLR 2023; public code: github.com/Yuxing-Wang-THU/
ModularEvoGym, ``examples/modular_envs/wrappers/modular_wrapper.py``) gives every voxel of the body's
bounding box, row by row, a vector of 9 numbers:

* the x of its four corner point masses relative to the robot's centre of mass (Evolution Gym's
  ``get_relative_pos_obs``), corners in the order top-left, top-right, bottom-left, bottom-right;
* then the y of the same four corners;
* then the voxel's material code (0 empty, 1 rigid, 2 soft, 3 horizontal, 4 vertical actuator).

Empty voxels are all zeros.  The non-empty voxels come first (in row-major order), then the empty ones;
``obs_mask`` marks the empty (padding) rows with 1, ``act_mask`` the voxels that are not actuators.  The
task's other observations (``other``: centre-of-mass velocity on Walker-v0, orientation, terrain...) are
the flat observation's rows that are not point positions, as ModularEvoGym's ``get_other_obs`` lists
them per task.

Here the corners are read from the voxel engine's own point numbering (each voxel's corner points), so a
voxel's corners are exactly the points the flat observation reports, including two points at one corner
where two voxels touch only there (ModularEvoGym re-derives the numbering from the body's layout).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: numbers per voxel: 4 corner x's, 4 corner y's, the material
PER_VOXEL = 9
#: the engine's corner order (top-left, top-right, bottom-right, bottom-left) -> ModularEvoGym's (TL, TR, BL, BR)
TO_MODULAR = (0, 1, 3, 2)


@dataclass(frozen=True)
class ModularView:
    """How one body's flat observation becomes ModularEvoGym's per-voxel rows."""

    #: (V, 8) rows of the flat observation holding each voxel's corner x's then y's; -1 for an empty voxel
    index: np.ndarray
    #: (V,) material codes, in the view's voxel order
    material: np.ndarray
    #: (V,) grid cell (row * width + column) of each of the view's voxels
    cell: np.ndarray
    #: rows of the flat observation that are not point positions (ModularEvoGym's ``other``)
    other: np.ndarray
    #: (A,) index in the view's voxel order of each action's actuator (the flat action order)
    actuator: np.ndarray

    @property
    def obs_mask(self) -> np.ndarray:
        """1 where the view's voxel is empty (padding), as ModularEvoGym's ``obs_mask``."""
        return (self.material == 0).astype(np.int64)

    @property
    def act_mask(self) -> np.ndarray:
        """1 where the view's voxel is not an actuator, as ModularEvoGym's ``act_mask`` (in grid order there)."""
        return (~np.isin(self.material, (3, 4))).astype(np.int64)

    def observe(self, flat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(modular (..., V, 9), other (..., k))`` for flat observations ``(..., n_obs)``."""
        flat = np.asarray(flat, dtype=np.float64)
        corners = np.where(self.index >= 0, flat[..., np.maximum(self.index, 0)], 0.0)
        material = np.broadcast_to(self.material.astype(np.float64), corners.shape[:-1])[..., None]
        return np.concatenate([corners, material], axis=-1), flat[..., self.other]


def modular_view(env: object) -> ModularView:
    """The view of a voxel-engine environment's body (``voxel/<task>``, ``gdabench/Walker-v2``); a one-line
    ``TypeError`` for another environment."""
    from ..ppo.layout import point_block

    base = getattr(env, "unwrapped", env)
    batch = getattr(base, "batch", None)
    if batch is None or not hasattr(batch, "tables"):
        raise TypeError(f"modular observations need a voxel-engine environment, got {type(base).__name__}")
    start, n_obs = point_block(batch)
    if start is None:
        raise TypeError(f"{batch.task_type.id}'s observation has no relative point positions")
    body = np.asarray(batch.bodies[0].voxels)
    robot = batch.tables.robots[0]
    points = len(robot.pos)
    h, w = body.shape
    cells = robot.boxel_cell[:, 1] * w + robot.boxel_cell[:, 0]
    filled = np.flatnonzero(body.reshape(-1))
    order = np.concatenate([filled, np.flatnonzero(body.reshape(-1) == 0)])  # non-empty first, then padding
    index = np.full((h * w, 8), -1, dtype=np.int64)
    for boxel, cell in enumerate(cells):
        corner_points = robot.boxel_points[boxel][list(TO_MODULAR)]
        index[cell] = np.concatenate([start + corner_points, start + points + corner_points])
    position = {int(c): i for i, c in enumerate(order)}
    actuator = np.array([position[int(cells[b])] for b in robot.actuators], dtype=np.int64)
    other = np.array([r for r in range(n_obs) if not start <= r < start + 2 * points], dtype=np.int64)
    return ModularView(index[order], body.reshape(-1)[order].astype(np.int64), order, other, actuator)
