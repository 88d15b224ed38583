"""Replay a run's body as it was scored: ``gdabench replay RUN_DIR [--body HASH] --gif out.gif``.

The run's environment and controller are rebuilt from ``run.json`` and asked for frames of the
body with the evaluation seed and work directory the run used (``Environment.render_frames``).
A controller that saved what it learned there (``ppo`` saves its trained policy) plays that
again instead of learning anew; ``open-loop`` simply plays its pattern again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from .body import Body, as_body
from .errors import ConfigError, RunDirectoryError
from .experiment.config import Experiment
from .experiment.plan import Plan
from .plugins import registry
from .report.animation import animate
from .results import RunDirectory, atomic_write_bytes
from .statuses import OK


@dataclass(frozen=True)
class Replayed:
    body: Body
    designer: str
    seed: int
    reward: float
    gif: Path | None


def pick_body(frame: pd.DataFrame, body_hash: str | None = None, designer: str | None = None) -> pd.Series:
    """The row of the body to replay: ``body_hash`` (a unique prefix is enough) or the best scored one."""
    rows = frame[frame["status"] == OK]
    if designer is not None:
        rows = rows[rows["designer"] == designer]
        if rows.empty:
            raise ConfigError(
                f"no scored body of designer {designer!r} in this run; designers: "
                f"{', '.join(sorted(set(frame['designer'])))}"
            )
    if body_hash is not None:
        rows = rows[rows["body_hash"].astype(str).str.startswith(body_hash)]
        if rows.empty:
            raise ConfigError(f"no scored body with hash {body_hash!r} in this run")
        if rows["body_hash"].nunique() > 1:
            raise ConfigError(
                f"hash prefix {body_hash!r} matches {rows['body_hash'].nunique()} bodies; give more characters"
            )
    if rows.empty:
        raise RunDirectoryError("this run has no scored body to replay")
    return rows.loc[rows["reward"].idxmax()]


def replay_run(
    run_dir: str | Path, *, body_hash: str | None = None, designer: str | None = None, gif: Path | None = None
) -> Replayed:
    """Replay one body of a run (the best unless ``body_hash`` says otherwise); write a GIF if asked."""
    run = RunDirectory.open(run_dir)
    row = pick_body(run.load_evaluations(), body_hash, designer)
    plan = Plan.resolve(Experiment.from_json(run.meta["config"]), registry(), designers=False)
    env_label = str(row["env"])
    env, controller = plan.scorers(env_label)
    body, label, seed = as_body(row["body"]), str(row["designer"]), int(row["seed"])
    data = animate(env, controller, body, seed=seed, workdir=plan.workdir(run.path, env_label, label, seed, body.hash))
    if gif is not None:
        if data is None:
            raise ConfigError(f"environment {env_label!r} has nothing to show (it renders no frames)")
        atomic_write_bytes(Path(gif), data)
    reward = float(row["reward"]) if math.isfinite(float(row["reward"])) else math.nan
    return Replayed(body, label, seed, reward, Path(gif) if gif is not None and data is not None else None)
