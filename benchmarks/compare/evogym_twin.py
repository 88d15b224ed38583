"""One of Evolution Gym's tasks in both simulators, side by side: the shared part of the task benchmarks.

``task_parity.py``, ``task_fidelity.py`` and ``task_stability.py`` play the same bodies and actions on
Evolution Gym 2.0's own Gymnasium environment (:class:`EvogymEnv`) and on the voxel engine (:class:`VoxelEnv`
for one body, :func:`play_batch` for many in one :class:`~gdabench.envs.voxel.batch.TaskBatch`).  Both
faces answer the same calls, so the comparisons run with any pair of them: the tests use the voxel
engine as a stand-in for Evolution Gym, which CI does not have.

Random set-ups (Catcher-v0's offset, BidirectionalWalker-v0's goals) come from Evolution Gym's draw: it
draws from Python's global ``random``, seeded here with the episode's set-up seed before its environment
is made; the voxel engine is given that draw through ``reset(options=...)``.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import random
import sys
import time
import warnings
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Protocol, Sequence

import numpy as np
from walker_fidelity import TRACE_EVERY

import gdabench
from gdabench.envs.tasks import task as definition
from gdabench.envs.voxel.batch import TaskBatch

#: what an episode of either simulator reports (see :func:`play`)
Episode = dict[str, Any]


class Twin(Protocol):
    """One environment of a task, in either simulator."""

    setup: dict[str, Any]
    moving: list[str]

    def first(self) -> np.ndarray: ...
    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool]: ...
    def positions(self, name: str) -> np.ndarray: ...
    def close(self) -> None: ...


def moving_objects(task: str) -> list[str]:
    """The objects that can move (any voxel neither empty nor fixed), robot first, as the recorder lists them."""
    grids = definition(task).objects()
    return ["robot", *sorted(name for name, (grid, _) in grids.items() if np.any((grid != 0) & (grid != 5)))]


def actuators(body: gdabench.Body) -> np.ndarray:
    """(row, col, code) of each actuator of ``body``, in action order (row-major from the top row)."""
    cells = np.argwhere(np.isin(body.voxels, (3, 4)))
    return np.column_stack([cells, body.voxels[cells[:, 0], cells[:, 1]]]).astype(np.int64)


@contextlib.contextmanager
def quiet() -> Iterator[None]:
    """Evolution Gym announces itself and every unstable step on stdout, and old versions of its tasks."""
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


def evogym_installed() -> bool:
    try:
        with quiet():
            import evogym.envs  # noqa: F401
    except ImportError:
        return False
    return True


def refuse_unknown(kind: str, names: list[str], known: Iterable[str]) -> None:
    """The scripts' command lines: an unknown task (or gait) is one ``error:`` line and exit 2."""
    known = list(known)
    unknown = [n for n in names if n not in known]
    if unknown:
        print(f"error: unknown {kind} {unknown[0]!r}; {kind}s: {', '.join(known)}", file=sys.stderr)
        raise SystemExit(2)


def require_evogym() -> None:
    """Exit 2 with one ``error:`` line where Evolution Gym cannot be imported."""
    if not evogym_installed():
        print("error: Evolution Gym is not installed; run this in the venv that has it (/work/venv-evogym)",
              file=sys.stderr)
        raise SystemExit(2)


class EvogymEnv:
    """Evolution Gym 2.0's own environment of ``task`` for ``body`` (its ``gymnasium.make``), reset with its
    random set-up drawn from ``random.seed(setup_seed)``; :meth:`step` also says whether the step was unstable
    (the simulator's own flag, which the task turns into ``done`` and a penalty)."""

    def __init__(self, task: str, body: gdabench.Body, setup_seed: int = 0):
        import gymnasium
        from evogym_record import load_evogym

        with quiet():
            load_evogym()
        from evogym.simulator_cpp import Sim

        self._read = Sim.object_pos_at_time
        random.seed(setup_seed)
        with quiet():
            self.env = gymnasium.make(task, body=body.voxels.astype(int))
            self.obs0, _ = self.env.reset(seed=0)
        raw = self.env.unwrapped
        self.sim = raw.sim
        self.setup: dict[str, Any] = {}
        if hasattr(raw, "offsetx"):
            self.setup["offset"] = [int(raw.offsetx), int(raw.offsety)]
        if hasattr(raw, "goals"):
            self.setup["goals"] = [int(g.x_goal) for g in raw.goals]
        self.moving = moving_objects(task)
        self.unstable = False
        original = self.sim.step

        def step() -> bool:
            self.unstable = bool(original())
            return self.unstable

        self.sim.step = step  # what EvoGymBase.step calls

    def first(self) -> np.ndarray:
        return np.asarray(self.obs0, dtype=np.float64)

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool]:
        with quiet():
            obs, reward, terminated, _, _ = self.env.step(np.array(action, dtype=np.float64))
        return np.asarray(obs, dtype=np.float64), float(reward), bool(terminated), self.unstable

    def positions(self, name: str) -> np.ndarray:
        return self._read(self.sim, self.sim.get_time(), name).T.copy()

    def close(self) -> None:
        self.env.close()


#: the controls: Evolution Gym against itself with every action changed by this much (about 50 ulps of 1.0)
NUDGE = 1e-14


class NudgedEvogym(EvogymEnv):
    """Evolution Gym with every action raised by :data:`NUDGE`: how fast a difference of the size of a rounding
    error grows in Evolution Gym itself.  The same set-up seed draws the same set-up."""

    def __init__(self, task: str, body: gdabench.Body, setup_seed: int = 0, setup: dict[str, Any] | None = None):
        super().__init__(task, body, setup_seed)
        assert setup is None or setup == self.setup, "the control drew another set-up"

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool]:
        return super().step(np.asarray(action) + NUDGE)


def setup_drawn(batch: TaskBatch, i: int) -> dict[str, Any]:
    """The random set-up environment ``i`` of ``batch`` drew, as reset options (empty for a fixed set-up)."""
    task = batch.task
    if "offset" in batch.task_type.reset_options:
        return {"offset": [int(v) for v in task.offset[i]]}
    if "goals" in batch.task_type.reset_options:
        return {"goals": [int(g) for g in task.goals[i, : task.n_goals[i]]]}
    return {}


class VoxelEnv:
    """The voxel engine's environment of ``task`` for ``body`` (a one-environment :class:`TaskBatch`), with
    the set-up ``setup`` imposed, or, when None, drawn from ``setup_seed`` by the engine's own generator."""

    def __init__(self, task: str, body: gdabench.Body, setup_seed: int = 0, setup: dict[str, Any] | None = None):
        self.batch = TaskBatch(task, [body])
        self.batch.seed([setup_seed])
        self.obs0 = self.batch.reset(options=setup)[0]
        self.setup = setup_drawn(self.batch, 0) if setup is None else setup
        self.size = self.batch.obs_sizes[0]
        self.moving = moving_objects(task)

    def first(self) -> np.ndarray:
        return self.obs0[: self.size]

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool]:
        obs, reward, terminated, unstable = self.batch.step(np.asarray(action)[None])
        return obs[0, : self.size], float(reward[0]), bool(terminated[0]), bool(unstable[0])

    def positions(self, name: str) -> np.ndarray:
        return batch_positions(self.batch, 0, name)

    def close(self) -> None:
        pass


def batch_positions(batch: TaskBatch, i: int, name: str) -> np.ndarray:
    """Object ``name``'s points in environment ``i`` of ``batch``, as Evolution Gym's ``object_pos_at_time``."""
    if name == "robot":
        start = batch.tables.robot_start
        return batch.state.pos[i, start:start + batch.robot_points[i]]
    return batch.frame().positions(name)[i]


def play(env: Twin, actions: np.ndarray) -> Episode:
    """One episode of ``actions`` (or until it ends): its return, whether a step was unstable, the robot's
    centre-of-mass x every ``TRACE_EVERY`` steps (walker_fidelity's trace), its steps, set-up and time."""
    com_x = lambda: float(env.positions("robot")[:, 0].mean())  # noqa: E731
    trace, total, unstable, steps = [com_x()], 0.0, False, 0
    start = time.perf_counter()
    for action in actions:
        _, reward, terminated, bad = env.step(action)
        total += reward
        unstable |= bad
        steps += 1
        if steps % TRACE_EVERY == 0:
            trace.append(com_x())
        if terminated:
            break
    return {"return": total, "unstable": unstable, "trace": trace, "steps": steps, "setup": env.setup,
            "seconds": time.perf_counter() - start}


def play_evogym(task: str, body: gdabench.Body, actions: np.ndarray, setup_seed: int) -> Episode:
    """Evolution Gym's episode of ``actions``, its random set-up drawn from ``setup_seed``."""
    env = EvogymEnv(task, body, setup_seed)
    try:
        return play(env, actions)
    finally:
        env.close()


def nudges(runs: int) -> np.ndarray:
    """The action offsets of ``runs`` nudged runs: +1, -1, +2, -2, ... times :data:`NUDGE`."""
    j = np.arange(runs)
    return (j // 2 + 1) * np.where(j % 2 == 0, 1.0, -1.0) * NUDGE


def nudged_episodes(task: str, body: gdabench.Body, actions: np.ndarray, setup_seed: int, runs: int,
                    theirs_player: Callable[[str, gdabench.Body, np.ndarray, int], Episode] = play_evogym,
                    ) -> tuple[list[Episode], list[Episode]]:
    """One episode played ``runs`` times in each simulator, every action changed by a few rounding errors
    (:func:`nudges`): the voxel engine's runs (one batch, with the set-up Evolution Gym drew from
    ``setup_seed``) and Evolution Gym's.  What each simulator's own rounding-sized changes do to an outcome."""
    offsets = nudges(runs)
    theirs = [theirs_player(task, body, actions + o, setup_seed) for o in offsets]
    ours = play_batch(task, [body] * runs, [actions + o for o in offsets], [theirs[0]["setup"]] * runs)
    return ours, theirs


def start_batch(task: str, bodies: Sequence[gdabench.Body], setups: Sequence[dict[str, Any]]) -> TaskBatch:
    """A batch of one environment per body, environment ``i`` reset with ``setups[i]`` imposed."""
    batch = TaskBatch(task, list(bodies))
    for i, setup in enumerate(setups):
        if setup:
            batch.reset(np.arange(len(bodies)) == i, options=setup)
    return batch


def first_observations(batch: TaskBatch) -> np.ndarray:
    """Every environment's current observation, without resetting any (a reset of none returns them all)."""
    return batch.reset(np.zeros(batch.num_envs, dtype=bool))


def padded(actions: Sequence[np.ndarray], width: int, t: int) -> np.ndarray:
    """Step ``t`` of every environment's actions, padded to ``width`` (ones; past its end: ones)."""
    out = np.ones((len(actions), width))
    for i, a in enumerate(actions):
        if t < len(a):
            out[i, : a.shape[1]] = a[t]
    return out


class Watch(Protocol):
    """Sees every step of :func:`play_batch` (the checks of ``task_stability``)."""

    def start(self, batch: TaskBatch, obs: np.ndarray) -> None: ...
    def before(self, batch: TaskBatch) -> None: ...
    def after(self, batch: TaskBatch, obs: np.ndarray, reward: np.ndarray, terminated: np.ndarray,
              unstable: np.ndarray, active: np.ndarray) -> None: ...


def play_batch(task: str, bodies: Sequence[gdabench.Body], actions: Sequence[np.ndarray],
               setups: Sequence[dict[str, Any]], watch: Watch | None = None) -> list[Episode]:
    """:func:`play` for many episodes at once on the voxel engine, one environment each (bodies may repeat)."""
    batch = start_batch(task, bodies, setups)
    if watch is not None:
        watch.start(batch, first_observations(batch))
    n = len(bodies)
    robot = batch.tables.robot_start

    def com_x() -> np.ndarray:
        return np.array([batch.state.pos[i, robot:robot + batch.robot_points[i], 0].mean() for i in range(n)])

    limit = max(len(a) for a in actions)
    ends = np.array([len(a) for a in actions])
    totals, unstable, steps = np.zeros(n), np.zeros(n, dtype=bool), np.zeros(n, dtype=np.int64)
    traces = [[x] for x in com_x()]
    batch.done |= ends == 0
    start = time.perf_counter()
    for t in range(limit):
        active = ~batch.done
        if not active.any():
            break
        if watch is not None:
            watch.before(batch)
        obs, reward, terminated, bad = batch.step(padded(actions, batch.tables.max_actuators, t))
        if watch is not None:
            watch.after(batch, obs, reward, terminated, bad, active)
        totals += reward
        unstable |= bad
        steps += active
        if (t + 1) % TRACE_EVERY == 0:
            for i, x in zip(np.flatnonzero(active), com_x()[active]):
                traces[i].append(float(x))
        batch.done |= ends <= t + 1
    seconds = (time.perf_counter() - start) / n
    return [{"return": float(totals[i]), "unstable": bool(unstable[i]), "trace": traces[i], "steps": int(steps[i]),
             "setup": dict(setups[i]), "seconds": seconds} for i in range(n)]


def gait_actions(pattern: Callable[[int, int], np.ndarray], n: int, steps: int) -> np.ndarray:
    """``(steps, n)`` actions of ``pattern(t, n)``, clipped to Evolution Gym's range."""
    return np.clip(np.array([pattern(t, n) for t in range(steps)]).reshape(steps, n), 0.6, 1.6)


class Rows:
    """A JSON-lines file of finished rows: appended as each finishes, read back on a restart (resumable runs)."""

    def __init__(self, path: Path | None):
        self.path = path
        self.rows: list[dict[str, Any]] = []
        if path is not None and path.exists():
            self.rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]

    def find(self, **match: Any) -> dict[str, Any] | None:
        for row in self.rows:
            if all(row.get(k) == v for k, v in match.items()):
                return row
        return None

    def add(self, row: dict[str, Any]) -> None:
        self.rows.append(row)
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            with self.path.open("a") as out:
                out.write(json.dumps(row, default=_plain) + "\n")


def _plain(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot write {type(value).__name__} as JSON")


def rounded(value: Any, digits: int = 4) -> Any:
    """``value`` with floats to ``digits`` significant digits (compact committed outputs)."""
    if isinstance(value, float):
        return value if not math.isfinite(value) or value == 0 else float(f"{value:.{digits}g}")
    if isinstance(value, dict):
        return {k: rounded(v, digits) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [rounded(v, digits) for v in value]
    return value
