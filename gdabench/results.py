"""The run directory: where every result row, the run's metadata and its checkpoints live.

::

    <run>/run.json              configuration, command line, versions, status
    <run>/evaluations.parquet   one row per proposed body (see COLUMNS) of every finished trial
    <run>/pending/<trial>/gen-<g>.parquet
                                rows of a trial still in progress, one file per generation;
                                merged into evaluations.parquet when the trial ends
    <run>/summary.csv           per designer: best reward, evaluations to the optimum, wall time
    <run>/checkpoints/<trial>.pkl
                                pickled designer state after each generation (for --resume)
    <run>/outcomes/             every body scored so far, while the run goes (:mod:`.running.outcomes`)
    <run>/.lock, .writer.json   held by the one process writing the run, and who that is

One process writes a run directory: a run or a resume holds an OS-level lock on it for its
whole life, and a second writer is refused before it touches anything.  Every file is written
to a uniquely named temporary file, flushed to disk and renamed, and generations are appended,
never rewritten, so a run killed at any instant (or a machine losing power) leaves readable
files behind, missing at most the generation in flight.  Readers need no lock:
:meth:`RunDirectory.load_evaluations` returns a consistent snapshot of finished and pending rows
while a run is going.
"""

from __future__ import annotations

import datetime as _dt
import errno
import io
import json
import os
import platform
import shutil
import socket
import sys
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import pandas as pd
from filelock import FileLock, Timeout

from . import faults
from .atomic import atomic_write_bytes
from .errors import ConfigError, GdabenchError, RunDirectoryError, RunFailure, RunLockedError
from .parquet import read_parquet
from .statuses import STATUSES

FORMAT = "gdabench-run/1"
RUN_JSON = "run.json"
EVALUATIONS = "evaluations.parquet"
SUMMARY = "summary.csv"
CHECKPOINTS = "checkpoints"
PENDING = "pending"
#: the re-evaluations of each trial's best bodies (written by :mod:`gdabench.running.reevaluation`)
REEVALUATIONS = "reevaluations.parquet"
REEVALUATION_COLUMNS = ["env", "designer", "seed", "run_id", "rank", "body", "body_hash", "first_reward", "replicate",
           "eval_seed", "reward", "status", "message", "eval_seconds"]  # fmt: skip
REEVALUATION_KEYS = ["env", "designer", "seed", "body_hash", "replicate"]
REEVALUATION_TYPES = {"env": str, "designer": str, "seed": "int64", "run_id": str, "rank": "int64", "body": str,
                      "body_hash": str, "first_reward": float, "replicate": "int64", "eval_seed": "int64",
                      "reward": float, "status": str, "message": str, "eval_seconds": float}  # fmt: skip
LOCK, WRITER = ".lock", ".writer.json"
#: times a reader starts over when a run finishes a trial under it
READ_ATTEMPTS = 20

#: columns of evaluations.parquet, in order; designers and environments may add their own after these
COLUMNS: dict[str, str] = {
    "run_id": "identifier of the compare/run call",
    "designer": "designer label as given (name, or name[params])",
    "designer_name": "registered designer name",
    "env": "environment label as given (name, or name[params])",
    "env_version": "version of the environment's dynamics or scoring, e.g. gdabench/Walker-v1 ('' when it declares "
                   "none)",
    "controller": "controller label ('' when the environment needs none)",
    "designer_params": "designer parameters as JSON (defaults included, converted to their declared types)",
    "env_params": "environment parameters as JSON",
    "controller_params": "controller parameters as JSON",
    "shape": "body shape HxW",
    "population": "population size",
    "budget": "evaluation budget of the trial",
    "seed": "seed of this repetition",
    "repetition": "index of the seed in the seed list",
    "generation": "generation index, from 0",
    "index": "position of the body in its generation",
    "body": "body in text form (rows joined by '/'), round-trips through Body.from_text",
    "body_hash": "stable hash of the body",
    "reward": "reward (NaN for invalid bodies and failed evaluations)",
    "status": " | ".join(STATUSES),
    "message": "why a body was invalid or its evaluation failed",
    "cached": "reward taken from the evaluation cache (--cache) instead of computed in this run",
    "n_evals": "evaluations used so far in this trial, this row included",
    "best_so_far": "best reward so far in this trial",
    "eval_seconds": "time spent evaluating this body",
    "design_seconds": "designer time for this generation (previous tell + ask)",
    "elapsed_seconds": "wall time of this trial when its generation finished",
    "timestamp": "UTC time the generation was written",
}

#: columns without which a table cannot be merged, resumed or reported
REQUIRED_COLUMNS = (
    "designer", "env", "controller", "seed", "generation", "index", "body", "body_hash",
    "reward", "status", "n_evals", "best_so_far", "elapsed_seconds",
)  # fmt: skip
#: how the results table identifies a trial
TRIAL_KEY = ["env", "designer", "seed"]


def utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def parquet_bytes(frame: pd.DataFrame) -> bytes:
    buffer = io.BytesIO()
    frame.to_parquet(buffer, index=False)
    return buffer.getvalue()


def no_space(exc: BaseException) -> bool:
    """Whether ``exc`` says the disk (or the user's quota) is full."""
    return isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT)


def write_error(exc: OSError, where: Path) -> GdabenchError:
    """One line for a write under ``where`` that the system refused: a full disk is a failed run
    (exit 1, wherever it happens), anything else (a read-only or odd place the user chose) an input error."""
    if no_space(exc):
        return RunFailure(f"no space left on the device of {where}")
    return ConfigError(f"cannot write to {where}: {exc.strerror or exc}")


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
    """The machine, its CPU (model, the instruction sets that choose torch's kernels, the kernels in force)."""
    from . import cpu

    return {
        "system": platform.system(),
        "release": platform.release(),
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "cpu": cpu.info(),
    }


@dataclass
class Checkpoint:
    """Designer state after a generation was told, and the generation to run next."""

    designer: Any
    next_generation: int


def is_file(path: Path) -> bool:
    """Whether ``path`` is a file; False also for a path the system cannot look up (a name too long)."""
    try:
        return path.is_file()
    except OSError:
        return False


def is_dir(path: Path) -> bool:
    """Whether ``path`` is a directory; False also for a path the system cannot look up."""
    try:
        return path.is_dir()
    except OSError:
        return False


def check_out_dir(path: Path) -> None:
    """Refuse an output path that cannot become a run directory, before anything is created."""
    try:
        _check_out_dir(path)
    except OSError as exc:  # e.g. a name longer than the filesystem allows
        raise ConfigError(f"output path {path}: {exc.strerror or exc}") from None


def _check_out_dir(path: Path) -> None:
    if path.exists() and not path.is_dir():
        raise ConfigError(f"output path {path} exists and is not a directory")
    ancestor = path
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise ConfigError(f"output path {path} is under {ancestor}, which is not a directory")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise ConfigError(f"output path {path}: {ancestor} is not writable")


def _wall_time_parts(meta: Mapping[str, Any]) -> list[float | None]:
    """run.json's ``wall_seconds_by_part``: the seconds of each part of the run (the first run, then each
    resume), None for a part that recorded none (killed with ``kill -9``, or still going); a run written
    before the field existed has one None per part."""
    parts = meta.get("wall_seconds_by_part")
    return list(parts) if isinstance(parts, list) else [None] * (1 + len(meta.get("resumed") or []))


class RunDirectory:
    """A run's directory on disk; the writer of a run holds its lock (:meth:`lock`)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._lock: FileLock | None = None

    # -- creation, opening, the writer's lock --------------------------------------------------
    @classmethod
    def create(cls, path: str | Path, meta: Mapping[str, Any]) -> RunDirectory:
        """Make a new run directory (an empty existing one is taken) and lock it for this process."""
        run = cls(path)
        check_out_dir(run.path)
        made = False
        try:
            run.path.parent.mkdir(parents=True, exist_ok=True)
            os.mkdir(run.path)
            made = True
        except FileExistsError:
            if not run.path.is_dir():
                raise ConfigError(f"output path {run.path} exists and is not a directory") from None
        except OSError as exc:
            if no_space(exc):
                raise write_error(exc, run.path) from None
            raise ConfigError(f"cannot create the run directory {run.path}: {exc.strerror or exc}") from None
        run.lock()
        try:
            if run._wrote_nothing():
                run._clear()  # a run that failed before its first generation: start over, as the user meant
            if any(entry not in (LOCK, WRITER) for entry in os.listdir(run.path)):
                raise ConfigError(
                    f"output directory {run.path} already exists and is not empty; choose another --out or --resume it"
                )
            try:
                run.write_meta({"format": FORMAT, **meta})
            except OSError as exc:
                raise write_error(exc, run.path) from None
        except BaseException:
            run.unlock()
            if made:
                shutil.rmtree(run.path, ignore_errors=True)
            raise
        return run

    def _wrote_nothing(self) -> bool:
        """Whether this is a run that failed or was interrupted before it wrote a single row."""
        try:
            status = self.meta.get("status") if (self.path / RUN_JSON).is_file() else None
        except RunDirectoryError:
            return False
        if status not in ("failed", "interrupted"):
            return False
        rows = [
            self.evaluations_path,
            *self.path.glob(f"{PENDING}/*/gen-*.parquet"),
            *self.path.glob(f"{CHECKPOINTS}/*"),
        ]
        return not any(path.exists() for path in rows) and set(os.listdir(self.path)) <= {
            LOCK,
            WRITER,
            RUN_JSON,
            PENDING,
            CHECKPOINTS,
            "artifacts",
        }

    def _clear(self) -> None:
        for entry in (RUN_JSON, PENDING, CHECKPOINTS, "artifacts"):
            path = self.path / entry
            if path.is_dir():
                shutil.rmtree(path)
            else:
                path.unlink(missing_ok=True)

    @classmethod
    def open(cls, path: str | Path) -> RunDirectory:
        """Open an existing run for reading (call :meth:`lock` to write to it)."""
        run = cls(path)
        try:
            is_dir = run.path.is_dir()
        except OSError as exc:  # e.g. a name longer than the filesystem allows
            raise RunDirectoryError(f"{run.path}: {exc.strerror or exc}") from None
        if not is_dir:
            raise RunDirectoryError(f"{run.path} is not a directory")
        if not (run.path / RUN_JSON).is_file():
            raise RunDirectoryError(f"{run.path} is not a gdabench run (no {RUN_JSON})")
        meta = run.meta  # raises if unreadable
        if meta.get("format") != FORMAT:
            raise RunDirectoryError(f"{run.path / RUN_JSON} has unknown format {meta.get('format')!r}")
        if not isinstance(meta.get("config"), dict):
            raise RunDirectoryError(f"{run.path / RUN_JSON} has no 'config' table: not a run this version can read")
        return run

    def lock(self) -> None:
        """Become the run's one writer, or raise :class:`RunLockedError` naming the current one."""
        lock = FileLock(self.path / LOCK, timeout=0)
        try:
            lock.acquire()
        except Timeout:
            raise RunLockedError(
                f"run {self.path} is being written by {self._writer()}; wait for it to end, or stop it first"
            ) from None
        except OSError as exc:
            raise ConfigError(f"cannot lock the run directory {self.path}: {exc.strerror or exc}") from None
        self._lock = lock
        # temporary files a writer left when it died (the report folder is not the run's to clean)
        for stale in [
            *self.path.glob(".*.tmp"),
            *self.path.glob(f"{PENDING}/*/.*.tmp"),
            *self.path.glob(f"{CHECKPOINTS}/.*.tmp"),
            *self.path.glob("outcomes/*/.*.tmp"),
        ]:
            stale.unlink(missing_ok=True)
        writer = {"pid": os.getpid(), "host": socket.gethostname(), "since": utc_now()}
        try:
            atomic_write_bytes(self.path / WRITER, json.dumps(writer).encode())
        except OSError:
            pass  # who holds the lock is a courtesy for the message above; the lock itself is what counts

    def _writer(self) -> str:
        try:
            who = json.loads((self.path / WRITER).read_text())
            return f"process {who['pid']} on {who['host']} since {who['since']}"
        except (OSError, ValueError, KeyError, TypeError):
            return "another process"

    def unlock(self) -> None:
        if self._lock is not None:
            (self.path / WRITER).unlink(missing_ok=True)
            self._lock.release()
            self._lock = None

    # -- run.json ------------------------------------------------------------------------------
    @property
    def meta(self) -> dict[str, Any]:
        try:
            meta = json.loads((self.path / RUN_JSON).read_text())
        except (OSError, ValueError) as exc:
            raise RunDirectoryError(f"cannot read {self.path / RUN_JSON}: {exc}") from None
        if not isinstance(meta, dict):
            raise RunDirectoryError(f"{self.path / RUN_JSON} is not a JSON object")
        return meta

    def write_meta(self, meta: Mapping[str, Any]) -> None:
        atomic_write_bytes(self.path / RUN_JSON, (json.dumps(meta, indent=2, default=str) + "\n").encode())

    def update_meta(self, **changes: Any) -> None:
        """Change fields of run.json; on a full disk, overwrite it in place (it needs no new blocks)."""
        data = (json.dumps({**self.meta, **changes}, indent=2, default=str) + "\n").encode()
        try:
            atomic_write_bytes(self.path / RUN_JSON, data)
        except OSError as exc:
            if not no_space(exc):
                raise
            with open(self.path / RUN_JSON, "r+b") as fh:
                fh.write(data)
                fh.truncate()
                fh.flush()
                os.fsync(fh.fileno())

    def part_started(self) -> dict[str, Any]:
        """The wall-time fields of run.json as a new part of the run (a resume) starts: its time unknown."""
        return {"wall_seconds_by_part": [*_wall_time_parts(self.meta), None]}

    def part_ended(self, seconds: float) -> dict[str, Any]:
        """The wall-time fields of run.json once its last part has run ``seconds``: that part's time, and
        ``wall_seconds``, the sum over the parts that recorded one."""
        parts = [*_wall_time_parts(self.meta)[:-1], round(seconds, 3)]
        return {"wall_seconds": round(sum(p for p in parts if p is not None), 3), "wall_seconds_by_part": parts}

    # -- evaluations ---------------------------------------------------------------------------
    @property
    def evaluations_path(self) -> Path:
        return self.path / EVALUATIONS

    def _read(self, path: Path) -> pd.DataFrame:
        try:
            frame = read_parquet(path)
        except FileNotFoundError:
            raise
        except Exception as exc:  # noqa: BLE001 - pyarrow raises several types for corrupt files
            raise RunDirectoryError(f"cannot read {path}: {type(exc).__name__}: {exc}") from None
        missing = [c for c in REQUIRED_COLUMNS if c not in frame.columns]
        if missing:
            raise RunDirectoryError(
                f"{path} lacks the column(s) {', '.join(missing)}: not a gdabench evaluations table"
            )
        return frame

    def _finished(self) -> pd.DataFrame | None:
        try:
            return self._read(self.evaluations_path)
        except FileNotFoundError:
            return None

    def pending_rows(self, name: str, before_generation: int | None = None) -> pd.DataFrame | None:
        """Rows of an unfinished trial; generation files from ``before_generation`` on are deleted.

        With ``before_generation`` (the trial's checkpoint), every generation before it must have its
        file: a gap would silently change the table, so it is refused naming the first missing file.
        """
        folder = self.path / PENDING / name
        files = {int(file.stem[4:]): file for file in folder.glob("gen-*.parquet")}
        if before_generation is not None:
            missing = next((g for g in range(before_generation) if g not in files), None)
            if missing is not None:
                raise RunDirectoryError(
                    f"{folder / f'gen-{missing:06d}.parquet'} is missing, but the trial's checkpoint is at generation "
                    f"{before_generation}: restore the file, or delete {folder} and {self.checkpoint_path(name)} "
                    "to run this trial again from its start")
        frames = []
        for generation, file in sorted(files.items()):
            if before_generation is not None and generation >= before_generation:
                file.unlink()
            else:
                frames.append(self._read(file))
        return pd.concat(frames, ignore_index=True) if frames else None

    def load_evaluations(self) -> pd.DataFrame:
        """All rows: finished trials, then those still pending; a consistent snapshot even mid-run."""
        for _ in range(READ_ATTEMPTS):
            try:
                return self._snapshot()
            except FileNotFoundError:
                continue  # a trial was merged (its pending files removed) while we read: read again
        raise RunDirectoryError(f"{self.path} kept changing while it was read; try again")

    def _snapshot(self) -> pd.DataFrame:
        # pending files first: a trial merged meanwhile then shows up in the finished table too, and
        # its pending copy is dropped below, instead of being missed by both reads
        pending = []
        for folder in sorted((self.path / PENDING).glob("*")):
            files = sorted(folder.glob("gen-*.parquet"))
            if files:
                pending.append(pd.concat([self._read(f) for f in files], ignore_index=True))
        finished = self._finished()
        frames = [] if finished is None else [finished]
        done = set() if finished is None else set(finished[TRIAL_KEY].itertuples(index=False, name=None))
        frames += [f for f in pending if tuple(f[TRIAL_KEY].iloc[0]) not in done]
        if not frames:
            return pd.DataFrame({c: pd.Series(dtype=object) for c in COLUMNS})
        return core_first(pd.concat(frames, ignore_index=True))

    def evaluations_made(self) -> dict[tuple[str, str, int], int]:
        """Evaluations each trial has made so far, by (env, designer, seed): where resuming it starts."""
        frame = self.load_evaluations()
        if not len(frame):
            return {}
        made = frame.groupby(TRIAL_KEY)["n_evals"].max()
        return {(str(e), str(d), int(s)): int(n) for (e, d, s), n in made.items()}

    def append_generation(self, name: str, generation: int, rows: Sequence[Mapping[str, Any]]) -> None:
        """Write one generation's rows of an unfinished trial."""
        frame = core_first(pd.DataFrame.from_records(rows))
        atomic_write_bytes(self.path / PENDING / name / f"gen-{generation:06d}.parquet", parquet_bytes(frame))

    def finished_trials(self) -> set[tuple[str, str, int]]:
        """(env, designer, seed) of every trial merged into evaluations.parquet."""
        if not self.evaluations_path.exists():
            return set()
        keys = read_parquet(self.evaluations_path, columns=TRIAL_KEY).drop_duplicates()
        return {(str(e), str(d), int(s)) for e, d, s in keys.itertuples(index=False, name=None)}

    def finish_trial(self, name: str, order: Callable[[tuple[str, str, int]], int]) -> None:
        """Merge a finished trial's pending rows into evaluations.parquet, trials sorted by ``order``.

        Its checkpoint is deleted afterwards: the merged rows are what marks the trial finished,
        and the table is the same whichever trials finished first.
        """
        rows = self.pending_rows(name)
        if rows is not None:
            finished = self._finished()
            merged = rows if finished is None else pd.concat([finished, rows], ignore_index=True)
            position = [
                order((str(e), str(d), int(s))) for e, d, s in merged[TRIAL_KEY].itertuples(index=False, name=None)
            ]
            merged = merged.iloc[sorted(range(len(merged)), key=position.__getitem__)].reset_index(drop=True)
            atomic_write_bytes(self.evaluations_path, parquet_bytes(core_first(merged)))
            faults.point("trial-merged")
        self.discard_trial_files(name)

    def discard_trial_files(self, name: str) -> None:
        """Remove a merged trial's pending rows and checkpoint (also what a kill during that left)."""
        shutil.rmtree(self.path / PENDING / name, ignore_errors=True)
        faults.point("pending-removed")
        self.checkpoint_path(name).unlink(missing_ok=True)
        faults.point("checkpoint-removed")
        for folder in (self.path / PENDING, self.path / CHECKPOINTS):
            if folder.is_dir() and not any(folder.iterdir()):
                folder.rmdir()

    # -- checkpoints ---------------------------------------------------------------------------
    def checkpoint_path(self, name: str) -> Path:
        return self.path / CHECKPOINTS / f"{name}.pkl"

    def save_checkpoint(self, name: str, data: bytes) -> None:
        atomic_write_bytes(self.checkpoint_path(name), data)

    def load_checkpoint(self, name: str) -> bytes | None:
        path = self.checkpoint_path(name)
        return path.read_bytes() if path.exists() else None

    def artifacts(self, name: str) -> Path:
        """Where a trial's evaluations may keep files (e.g. trained policies), one folder per body."""
        return self.path / "artifacts" / name


def core_first(frame: pd.DataFrame) -> pd.DataFrame:
    """Core columns in their documented order, then designer/environment extras by name (so the
    table's columns do not depend on which trial finished first)."""
    core = [c for c in COLUMNS if c in frame.columns]
    return frame[core + sorted(c for c in frame.columns if c not in COLUMNS)]


def load_reevaluations(run_path: str | Path) -> pd.DataFrame:
    """The run's re-evaluations so far (an empty table with :data:`REEVALUATION_COLUMNS` where there are none)."""
    path = Path(run_path) / REEVALUATIONS
    if not path.exists():
        return pd.DataFrame(columns=REEVALUATION_COLUMNS).astype(REEVALUATION_TYPES)
    return read_parquet(path)
