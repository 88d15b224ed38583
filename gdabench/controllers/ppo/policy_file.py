"""A body's trained policy on disk: ``ppo_policy.pt`` (weights) + ``ppo_policy.json`` (what it is).

The harness gives every evaluated body its own work directory
(``<run>/artifacts/<designer>-seed<k>/<body hash>/``); the ``ppo`` controller writes the best
policy of the body's training there.  The JSON says how it was trained (settings, seed,
timesteps, every evaluation) and which evaluation it won, so replaying it reproduces the
episode and reward it was scored with.  Files are written to a temporary name and renamed, so
a killed run never leaves half a policy behind.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch

from ...errors import GdabenchError
from .networks import ActorCritic

WEIGHTS_FILE = "ppo_policy.pt"
META_FILE = "ppo_policy.json"
#: 3: networks trained in lockstep batches (padded sizes in the JSON), with observation statistics;
#: policies of earlier formats are trained again
FORMAT = 3


@dataclass(frozen=True)
class SavedPolicy:
    nets: ActorCritic
    meta: dict[str, Any]


def save_policy(workdir: Path, nets: ActorCritic, meta: dict[str, Any]) -> None:
    """Write the networks and their description into ``workdir`` (created if needed)."""
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    weights = {"dims": nets.dims(), "state_dict": {k: v.detach().cpu() for k, v in nets.state_dict().items()}}
    _atomic(workdir / WEIGHTS_FILE, lambda path: torch.save(weights, path))
    text = json.dumps({"format": FORMAT, **meta}, indent=1, sort_keys=True)
    _atomic(workdir / META_FILE, lambda path: path.write_text(text))


def has_policy(workdir: Path | None) -> bool:
    return workdir is not None and (Path(workdir) / WEIGHTS_FILE).is_file() and (Path(workdir) / META_FILE).is_file()


def readable_policy(workdir: Path | None) -> bool:
    """``workdir`` holds a policy in the format this gdabench reads (one of an older format is trained again)."""
    if workdir is None or not has_policy(workdir):
        return False
    try:
        return json.loads((Path(workdir) / META_FILE).read_text()).get("format") == FORMAT
    except (OSError, ValueError):
        return False


def load_policy(workdir: Path, device: torch.device | str = "cpu") -> SavedPolicy:
    """The policy saved in ``workdir``, or a one-line :class:`GdabenchError`."""
    workdir = Path(workdir)
    if not has_policy(workdir):
        raise GdabenchError(f"no saved ppo policy in {workdir} (expected {WEIGHTS_FILE} and {META_FILE})")
    try:
        meta = json.loads((workdir / META_FILE).read_text())
        weights = torch.load(workdir / WEIGHTS_FILE, map_location=device, weights_only=True)
        dims = weights["dims"]
        nets = ActorCritic(dims["n_obs"], dims["n_act"], dims["hidden"]).to(device)
        nets.load_state_dict(weights["state_dict"])
    except Exception as exc:  # noqa: BLE001 - any unreadable file is reported in one line
        raise GdabenchError(f"cannot read the ppo policy in {workdir}: {type(exc).__name__}: {exc}") from None
    if meta.get("format") != FORMAT:
        raise GdabenchError(
            f"ppo policy in {workdir} has format {meta.get('format')!r}; this gdabench reads format {FORMAT}"
        )
    return SavedPolicy(nets, meta)


def _atomic(path: Path, write: Any) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    write(tmp)
    os.replace(tmp, path)
