"""A run's table in other tools' formats: IOHprofiler's (for IOHanalyzer) and plain CSV.

**IOHprofiler** (``--format ioh``), the JSON-indexed format that the ``ioh`` package's
``Analyzer`` logger writes and IOHanalyzer (0.1.8 on) and IOHinspector read::

    <out>/<designer>/IOHprofiler_f<id>_<env>.json                 one per designer and environment
    <out>/<designer>/data_f<id>_<env>/IOHprofiler_f<id>_DIM<d>.dat   its runs

* one problem per environment (function ids 1, 2, ... in the order environments appear; the
  name is the environment's, with characters other than letters, digits, ``-``, ``_`` and
  ``.`` replaced by ``_``), maximised; the dimension is the number of voxels of a body;
* one algorithm per designer label (its parameters as the algorithm's info);
* one run per seed, all on instance 1 (a seed is a repetition, not a problem instance), in
  seed order, with the seed kept as the run attribute ``seed``;
* the ``.dat`` block of a run starts with a header line ``evaluations raw_y``, then has a line
  for the first evaluation, for every evaluation that improved the best-so-far reward and for
  the last evaluation (which IOHanalyzer needs to count the evaluations of a run that stopped
  improving), each with the best-so-far reward (``-inf`` while every evaluation so far failed).
  Evaluations are counted as gdabench counts them (unique valid bodies);
* the JSON lists, per run, its evaluations and its best body (reward, the evaluation that found
  it and its voxel codes, row by row).

**CSV** (``--format csv``): ``evaluations.csv``, the tidy table with every column, one row per
proposed body, for spreadsheets.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from ..body import Body
from ..errors import ConfigError
from ..names import file_name
from ..results import RunDirectory, atomic_write_bytes, is_dir, is_file
from ..stats.core import with_run_id
from ..statuses import OK
from .runtimes import RunTrace, run_traces
from .staging import staged_folder, writing

FORMATS = ("ioh", "csv")
#: the JSON format version written; IOHanalyzer reads JSON-indexed data of version 0.3.3 and later
IOH_VERSION = "0.3.3"
SUITE = "gdabench"
HEADER = "evaluations raw_y"


def _name(text: str) -> str:
    return file_name(text, "A-Za-z0-9_.-").strip("_") or "x"


def default_out(run: RunDirectory, fmt: str) -> Path:
    return run.path / "export" / ("ioh" if fmt == "ioh" else "evaluations.csv")


def export_run(run_dir: str | Path, fmt: str, out: str | Path | None = None) -> Path:
    """Write the run's table in ``fmt`` (ioh or csv) to ``out``; returns where it went."""
    if fmt not in FORMATS:
        raise ConfigError(f"unknown export format {fmt!r}; choose one of {', '.join(FORMATS)}")
    run = RunDirectory.open(run_dir)
    frame = run.load_evaluations()
    if frame.empty:
        raise ConfigError(f"{run.path} has no evaluations yet: nothing to export")
    target = Path(out) if out is not None else default_out(run, fmt)
    if fmt == "csv":
        if is_dir(target):
            raise ConfigError(f"--out {target} is a directory; give a file name for the CSV")
        with writing(target):
            atomic_write_bytes(target, frame.to_csv(index=False).encode())
        return target
    if is_file(target):
        raise ConfigError(f"--out {target} is a file; IOHprofiler data is a directory")
    write_ioh(frame, target)
    return target


def write_ioh(frame: pd.DataFrame, out: Path) -> list[Path]:
    """Write ``frame`` as IOHprofiler data into the directory ``out`` (replaced whole); returns
    the JSON index files."""
    with staged_folder(out, whole=True) as staging:
        written = _write_ioh(frame, staging)
    return [out / p.relative_to(staging) for p in written]


def _write_ioh(frame: pd.DataFrame, root: Path) -> list[Path]:
    traces = run_traces(frame)
    envs = list(dict.fromkeys(t.env for t in traces))
    designers = list(dict.fromkeys(t.designer for t in traces))
    folders = _unique_names(designers)
    best_bodies = _best_bodies(frame)
    written = []
    for fid, env in enumerate(envs, start=1):
        fname = _name(env)
        env_rows = frame[frame["env"] == env]
        for designer in designers:
            mine = [t for t in traces if t.env == env and t.designer == designer]
            if not mine:
                continue
            rows = env_rows[env_rows["designer"] == designer]
            folder = root / folders[designer]
            dimension = _dimension(rows)
            data_path = f"data_f{fid}_{fname}/IOHprofiler_f{fid}_DIM{dimension}.dat"
            (folder / data_path).parent.mkdir(parents=True, exist_ok=True)
            (folder / data_path).write_text("".join(dat_block(t) for t in mine))
            index = {
                "version": IOH_VERSION,
                "suite": SUITE,
                "function_id": fid,
                "function_name": fname,
                "maximization": True,
                "algorithm": {
                    "name": designer,
                    "info": str(rows["designer_params"].iloc[0]) if "designer_params" in rows else "",
                },
                "experiment_attributes": _experiment_attributes(rows, env),
                "run_attributes": ["seed"],
                "attributes": HEADER.split(),
                "scenarios": [
                    {"dimension": dimension, "path": data_path, "runs": [_run_entry(t, best_bodies) for t in mine]}
                ],
            }
            path = folder / f"IOHprofiler_f{fid}_{fname}.json"
            path.write_text(json.dumps(index, indent=1) + "\n")
            written.append(path)
    return written


def _unique_names(labels: list[str]) -> dict[str, str]:
    names: dict[str, str] = {}
    for label in labels:
        base, i = _name(label), 1
        name = base
        while name in names.values():
            i += 1
            name = f"{base}-{i}"
        names[label] = name
    return names


def _dimension(rows: pd.DataFrame) -> int:
    """Voxels of a body (25 for 5x5): the problem's dimension."""
    return int(Body.from_text(str(rows["body"].iloc[0])).voxels.size)


def _experiment_attributes(rows: pd.DataFrame, env: str) -> list[dict[str, str]]:
    attributes = [{"env": env}]
    for column in ("controller", "budget", "population", "run_id"):  # run_id is a reader's column name: prefixed
        if column in rows.columns and rows[column].notna().any():
            attributes.append({f"gdabench_{column}" if column == "run_id" else column: str(rows[column].iloc[0])})
    return attributes


def _value(x: float) -> str:
    return "-inf" if np.isnan(x) else repr(float(x))


def dat_block(trace: RunTrace) -> str:
    """Header, then the first, every improving and the last evaluation with its best-so-far."""
    curve = trace.curve
    if not len(curve):
        return HEADER + "\n"
    filled = np.where(np.isnan(curve), -np.inf, curve)
    keep = np.zeros(len(curve), dtype=bool)
    keep[0] = keep[-1] = True
    keep[1:] |= filled[1:] > filled[:-1]
    lines = [f"{n + 1} {_value(curve[n])}" for n in np.nonzero(keep)[0]]
    return HEADER + "\n" + "\n".join(lines) + "\n"


def _best_bodies(frame: pd.DataFrame) -> dict[tuple[str, str, str, int], tuple[int, str]]:
    """(env, designer, run_id, seed) -> (evaluation that first found the run's best reward, body)."""
    ok = with_run_id(frame[frame["status"] == OK])
    ranked = ok.sort_values(["reward", "n_evals"], ascending=[False, True], kind="stable")
    first = ranked.drop_duplicates(["env", "designer", "run_id", "seed"])
    return {
        (str(r.env), str(r.designer), str(r.run_id), int(r.seed)): (int(r.n_evals), str(r.body))
        for r in first.itertuples()
    }


def _run_entry(trace: RunTrace, best_bodies: dict[tuple[str, str, str, int], tuple[int, str]]) -> dict:
    found = best_bodies.get((trace.env, trace.designer, trace.run_id, trace.seed))
    best: dict = {"evals": 0, "y": None, "x": []}
    if found is not None:
        evals, body = found
        best = {"evals": evals, "y": trace.final, "x": [int(v) for v in Body.from_text(body).voxels.ravel()]}
    return {"instance": 1, "evals": trace.evaluations, "best": best, "seed": trace.seed}
