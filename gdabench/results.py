"""The run directory: where every result row, the run's metadata and its checkpoints live.

::

    <run>/run.json              configuration, command line, versions, status
    <run>/evaluations.parquet   one row per proposed body (see COLUMNS) of every finished
                                (designer, seed) run
    <run>/pending/<designer>-seed<k>/gen-<g>.parquet
                                rows of a (designer, seed) run still in progress, one file per
                                generation; merged into evaluations.parquet when that run ends
    <run>/summary.csv           per designer: best reward, evaluations to the optimum, wall time
    <run>/checkpoints/          pickled designer state after each generation (for --resume)

Every file is written atomically (temporary file, then rename) and generations are appended,
never rewritten, so a run killed at any instant leaves readable files behind, missing at most
the generation in flight.  :meth:`RunDirectory.load_evaluations` returns finished and pending
rows together.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import pickle
import platform
import re
import shutil
import sys
import tempfile
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any, Mapping

import pandas as pd

from .errors import ConfigError, RunDirectoryError

FORMAT = "gdabench-run/1"
RUN_JSON = "run.json"
EVALUATIONS = "evaluations.parquet"
SUMMARY = "summary.csv"
CHECKPOINTS = "checkpoints"
PENDING = "pending"

#: columns of evaluations.parquet, in order; designers and environments may add their own after these
COLUMNS: dict[str, str] = {
    "run_id": "identifier of the compare/run call",
    "designer": "designer label as given (name, or name[params])",
    "designer_name": "registered designer name",
    "env": "environment name",
    "env_version": "version of the environment's dynamics or scoring, e.g. gdabench/Walker-v1 ('' when it declares none)",
    "controller": "controller name ('' when the environment needs none)",
    "designer_params": "designer parameters as JSON",
    "env_params": "environment parameters as JSON",
    "controller_params": "controller parameters as JSON",
    "shape": "body shape HxW",
    "population": "population size",
    "budget": "evaluation budget of the run",
    "seed": "seed of this repetition",
    "repetition": "index of the seed in the seed list",
    "generation": "generation index, from 0",
    "index": "position of the body in its generation",
    "body": "body in text form (rows joined by '/'), round-trips through Body.from_text",
    "body_hash": "stable hash of the body",
    "reward": "reward (NaN for invalid bodies and failed evaluations)",
    "status": "ok | invalid | duplicate | error | timeout",
    "message": "why a body was invalid or its evaluation failed",
    "cached": "reward taken from the evaluation cache (--cache) instead of computed in this run",
    "n_evals": "evaluations used so far in this run, this row included",
    "best_so_far": "best reward so far in this run",
    "eval_seconds": "time spent evaluating this body",
    "design_seconds": "designer time for this generation (previous tell + ask)",
    "elapsed_seconds": "wall time of this run when its generation finished",
    "timestamp": "UTC time the generation was written",
}


#: columns without which a table cannot be merged, resumed or reported
REQUIRED_COLUMNS = (
    "designer", "env", "controller", "seed", "generation", "index", "body", "body_hash",
    "reward", "status", "n_evals", "best_so_far", "elapsed_seconds",
)  # fmt: skip


def utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def atomic_write_bytes(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o644)  # mkstemp creates private files; results are meant to be shared
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def versions(distributions: Mapping[str, str]) -> dict[str, Any]:
    """Versions of Python, the core libraries and every plugin distribution."""

    def dist_version(name: str) -> str | None:
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            return None

    core = {name: dist_version(name) for name in ("gdabench", "numpy", "pandas", "pyarrow", "pluggy", "torch")}
    return {"python": sys.version.split()[0], **core, "plugins": dict(distributions)}


def platform_info() -> dict[str, Any]:
    return {"system": platform.system(), "release": platform.release(), "machine": platform.machine(), "cpus": os.cpu_count()}


@dataclass
class Checkpoint:
    """Designer state after a generation was told, and the generation to run next."""

    designer: Any
    next_generation: int


class RunDirectory:
    """A run's directory on disk."""

    def __init__(self, path: str | Path):
        self.path = Path(path)

    # -- creation and opening ------------------------------------------------------------------
    @classmethod
    def create(cls, path: str | Path, meta: Mapping[str, Any]) -> RunDirectory:
        run = cls(path)
        if run.path.exists() and any(run.path.iterdir()):
            raise ConfigError(f"output directory {run.path} already exists and is not empty; choose another --out or --resume it")
        run.path.mkdir(parents=True, exist_ok=True)
        run.write_meta({"format": FORMAT, **meta})
        return run

    @classmethod
    def open(cls, path: str | Path) -> RunDirectory:
        run = cls(path)
        if not run.path.is_dir():
            raise RunDirectoryError(f"{run.path} is not a directory")
        if not (run.path / RUN_JSON).is_file():
            raise RunDirectoryError(f"{run.path} is not a gdabench run (no {RUN_JSON})")
        meta = run.meta  # raises if unreadable
        if meta.get("format") != FORMAT:
            raise RunDirectoryError(f"{run.path / RUN_JSON} has unknown format {meta.get('format')!r}")
        return run

    # -- run.json ------------------------------------------------------------------------------
    @property
    def meta(self) -> dict[str, Any]:
        try:
            return json.loads((self.path / RUN_JSON).read_text())
        except (OSError, ValueError) as exc:
            raise RunDirectoryError(f"cannot read {self.path / RUN_JSON}: {exc}") from None

    def write_meta(self, meta: Mapping[str, Any]) -> None:
        atomic_write_bytes(self.path / RUN_JSON, (json.dumps(meta, indent=2, default=str) + "\n").encode())

    def update_meta(self, **changes: Any) -> None:
        self.write_meta({**self.meta, **changes})

    # -- evaluations ---------------------------------------------------------------------------
    @property
    def evaluations_path(self) -> Path:
        return self.path / EVALUATIONS

    def trial_name(self, label: str, seed: int) -> str:
        return f"{re.sub(r'[^A-Za-z0-9_.=-]+', '_', label)}-seed{seed}"

    def _read(self, path: Path) -> pd.DataFrame:
        try:
            frame = pd.read_parquet(path)
        except Exception as exc:  # noqa: BLE001 - pyarrow raises several types for corrupt files
            raise RunDirectoryError(f"cannot read {path}: {type(exc).__name__}: {exc}") from None
        missing = [c for c in REQUIRED_COLUMNS if c not in frame.columns]
        if missing:
            raise RunDirectoryError(f"{path} lacks the column(s) {', '.join(missing)}: not a gdabench evaluations table")
        return frame

    def _finished(self) -> pd.DataFrame | None:
        return self._read(self.evaluations_path) if self.evaluations_path.exists() else None

    def pending_rows(self, label: str, seed: int, before_generation: int | None = None) -> pd.DataFrame | None:
        """Rows of an unfinished (designer, seed) run; generation files from ``before_generation`` on are deleted."""
        folder = self.path / PENDING / self.trial_name(label, seed)
        frames = []
        for file in sorted(folder.glob("gen-*.parquet")):
            if before_generation is not None and int(file.stem[4:]) >= before_generation:
                file.unlink()
            else:
                frames.append(self._read(file))
        return pd.concat(frames, ignore_index=True) if frames else None

    def load_evaluations(self) -> pd.DataFrame:
        """All rows: finished (designer, seed) runs, then those still pending."""
        finished = self._finished()
        frames = [] if finished is None else [finished]
        done = set() if finished is None else set(zip(finished["designer"], finished["seed"]))
        for folder in sorted((self.path / PENDING).glob("*")):
            files = sorted(folder.glob("gen-*.parquet"))
            if not files:
                continue
            first = self._read(files[0])
            if (first["designer"].iloc[0], first["seed"].iloc[0]) in done:
                continue  # merged already; the folder outlived a kill during clean-up
            frames += [first, *(self._read(f) for f in files[1:])]
        if not frames:
            return pd.DataFrame({c: pd.Series(dtype=object) for c in COLUMNS})
        return _core_first(pd.concat(frames, ignore_index=True))

    def append_generation(self, label: str, seed: int, generation: int, rows: list[Mapping[str, Any]]) -> None:
        """Write one generation's rows of an unfinished (designer, seed) run."""
        frame = _core_first(pd.DataFrame.from_records(rows))
        path = self.path / PENDING / self.trial_name(label, seed) / f"gen-{generation:06d}.parquet"
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.tmp")
        frame.to_parquet(tmp, index=False)
        os.replace(tmp, path)

    def is_finished(self, label: str, seed: int) -> bool:
        """True once the (designer, seed) run's rows were merged into evaluations.parquet."""
        if not self.evaluations_path.exists():
            return False
        keys = pd.read_parquet(self.evaluations_path, columns=["designer", "seed"]).drop_duplicates()
        return bool(((keys["designer"] == label) & (keys["seed"] == seed)).any())

    def finish_trial(self, label: str, seed: int) -> None:
        """Merge a finished (designer, seed) run's pending rows into evaluations.parquet.

        Its checkpoint is deleted afterwards: the merged rows are what marks the run finished.
        """
        rows = self.pending_rows(label, seed)
        if rows is not None:
            finished = self._finished()
            merged = rows if finished is None else pd.concat([finished, rows], ignore_index=True)
            tmp = self.evaluations_path.with_name(f".{EVALUATIONS}.tmp")
            _core_first(merged).to_parquet(tmp, index=False)
            os.replace(tmp, self.evaluations_path)
        shutil.rmtree(self.path / PENDING / self.trial_name(label, seed), ignore_errors=True)
        self.checkpoint_path(label, seed).unlink(missing_ok=True)
        for folder in (self.path / PENDING, self.path / CHECKPOINTS):
            if folder.is_dir() and not any(folder.iterdir()):
                folder.rmdir()

    # -- checkpoints ---------------------------------------------------------------------------
    def checkpoint_path(self, label: str, seed: int) -> Path:
        return self.path / CHECKPOINTS / f"{self.trial_name(label, seed)}.pkl"

    def save_checkpoint(self, label: str, seed: int, checkpoint: Checkpoint) -> None:
        atomic_write_bytes(self.checkpoint_path(label, seed), pickle.dumps(checkpoint))

    def load_checkpoint(self, label: str, seed: int) -> Checkpoint | None:
        path = self.checkpoint_path(label, seed)
        if not path.exists():
            return None
        try:
            return pickle.loads(path.read_bytes())
        except Exception as exc:  # noqa: BLE001
            raise RunDirectoryError(f"cannot restore checkpoint {path}: {type(exc).__name__}: {exc}") from None


def _core_first(frame: pd.DataFrame) -> pd.DataFrame:
    """Core columns in their documented order, then designer/environment extras."""
    core = [c for c in COLUMNS if c in frame.columns]
    return frame[core + [c for c in frame.columns if c not in COLUMNS]]
