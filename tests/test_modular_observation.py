"""ModularEvoGym's per-voxel observation (the modular state space of CuCo, ICLR 2023), built from the voxel
engine's flat observation: hand-computed on a fixed body, and against ModularEvoGym's own corner indexing."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest

from gdabench.controllers.modular.observation import modular_view


def env_of(body: str, task: str = "Walker-v0") -> gymnasium.Env:
    return gymnasium.make(f"voxel/{task}", body=body)


def test_two_voxels_side_by_side_by_hand():
    env = env_of("00000/00000/00000/00000/34000")
    view = modular_view(env)
    obs, _ = env.reset(seed=0)
    modular, other = view.observe(obs)
    # six points at rest on a 0.1 m lattice: the centre of mass is 0.1 right of the left column and 0.05 above
    # the bottom row; voxel (4, 0) is left of it, voxel (4, 1) right; corners TL, TR, BL, BR: x's, then y's
    assert modular.shape == (25, 9)
    np.testing.assert_allclose(modular[0], [-0.1, 0, -0.1, 0, 0.05, 0.05, -0.05, -0.05, 3], atol=1e-9)
    np.testing.assert_allclose(modular[1], [0, 0.1, 0, 0.1, 0.05, 0.05, -0.05, -0.05, 4], atol=1e-9)
    assert not modular[2:].any()  # the 23 empty voxels come after, as zeros
    np.testing.assert_allclose(other, [0.0, 0.0])  # Walker-v0's other: the centre of mass's velocity, at rest
    assert view.obs_mask.tolist() == [0, 0] + [1] * 23
    assert view.act_mask.tolist() == [0, 0] + [1] * 23
    assert view.actuator.tolist() == [0, 1] and view.cell[:2].tolist() == [20, 21]


def modular_evogym_corner_index(body: np.ndarray) -> np.ndarray:
    """ModularEvoGym's ``transform_to_modular_obs``: the index in Evolution Gym's point order of each voxel's
    corners (TL, TR, BL, BR), derived from the body's layout alone (-1 for an empty voxel).  Written here from
    its description, independently of the engine's numbering."""
    h, w = body.shape
    corner = np.full((h, w, 2, 2), -1, dtype=int)
    nxt = 0
    for y in range(h):
        for x in range(w):
            if body[y, x] == 0:
                continue
            up = y > 0 and body[y - 1, x] != 0
            left = x > 0 and body[y, x - 1] != 0
            right = x + 1 < w and body[y, x + 1] != 0
            up_right = x + 1 < w and y > 0 and body[y - 1, x + 1] != 0
            if up:
                corner[y, x, 0, :] = corner[y - 1, x, 1, :]
            if left:
                corner[y, x, :, 0] = corner[y, x - 1, :, 1]
            if not (up or left):
                corner[y, x, 0, 0], nxt = nxt, nxt + 1
            if not up:
                if right and up_right:
                    corner[y, x, 0, 1] = corner[y - 1, x + 1, 1, 0]
                else:
                    corner[y, x, 0, 1], nxt = nxt, nxt + 1
            if not left:
                corner[y, x, 1, 0], nxt = nxt, nxt + 1
            corner[y, x, 1, 1], nxt = nxt, nxt + 1
    return corner.reshape(h * w, 4)


@pytest.mark.filterwarnings("ignore:.*is out of date")
@pytest.mark.parametrize("task", ["Walker-v0", "BridgeWalker-v0", "Carrier-v0"])
@pytest.mark.parametrize(
    "body", ["00000/44444/44444/40004/40004", "33333/30103/32223/04140/44044", "03300/03300/44444/40104/40004"])
def test_the_view_is_modular_evogyms_definition_after_steps_on_any_task(body, task):
    env = env_of(body, task)
    view = modular_view(env)
    env.reset(seed=1)
    rng = np.random.default_rng(0)
    for _ in range(20):
        obs, *_ = env.step(rng.uniform(0.6, 1.6, env.action_space.shape))
    modular, other = view.observe(obs)
    grid = np.array([[int(c) for c in row] for row in body.split("/")])
    points = (env.observation_space.shape[0] - len(other)) // 2
    start = int(np.flatnonzero(np.isin(np.arange(len(obs)), view.other, invert=True))[0])
    xs, ys = obs[start:start + points], obs[start + points:start + 2 * points]
    index = modular_evogym_corner_index(grid)
    flat_cells = grid.reshape(-1)
    order = [c for c in range(25) if flat_cells[c]] + [c for c in range(25) if not flat_cells[c]]
    expected = np.array([
        np.concatenate([xs[index[c]], ys[index[c]], [flat_cells[c]]]) if flat_cells[c] else np.zeros(9)
        for c in order
    ])
    np.testing.assert_array_equal(modular, expected)
    assert len(other) == env.observation_space.shape[0] - 2 * points


def test_another_environment_is_refused_in_one_line():
    with pytest.raises(TypeError, match="voxel-engine environment"):
        modular_view(gymnasium.make("Pendulum-v1"))
