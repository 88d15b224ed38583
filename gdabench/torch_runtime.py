"""Where and how torch runs, for the plugins that use it (``gda``, ``ppo``, ``bo``): device and threads.

Their networks are tiny, so a step is many very small kernels: extra threads mostly add
synchronisation, and a GPU is used only when asked for.
"""

from __future__ import annotations

import contextlib
from typing import Iterator

import torch

from .errors import ConfigError


def resolve_device(name: str, owner: str) -> torch.device:
    """``cpu``, ``cuda``/``cuda:N`` when torch sees that GPU, ``auto`` (cuda if present), or a
    one-line error starting with ``owner`` (the plugin whose parameter it is)."""
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        device = torch.device(name)
    except (RuntimeError, TypeError):
        raise ConfigError(f"{owner}: unknown device {name!r}; use cpu, cuda, cuda:N or auto") from None
    if device.type == "cpu":
        return device
    if device.type != "cuda":
        raise ConfigError(f"{owner}: device {name!r} is not supported; use cpu, cuda, cuda:N or auto")
    if not torch.cuda.is_available():
        raise ConfigError(f"{owner}: device {name!r} requested but torch sees no CUDA GPU; use device=cpu")
    if device.index is not None and device.index >= torch.cuda.device_count():
        raise ConfigError(f"{owner}: device {name!r} does not exist; torch sees {torch.cuda.device_count()} GPU(s)")
    return device


@contextlib.contextmanager
def torch_threads(threads: int | None) -> Iterator[None]:
    """Use ``threads`` torch threads inside the block, then restore the process's setting.

    One thread is the default for ``gda`` and ``ppo``: their kernels are too small to split, and
    on a 2-core machine shared with other work a second thread mostly waits for a busy core
    (measured: several times slower).  None leaves torch's setting alone.
    """
    previous = torch.get_num_threads()
    if threads is not None and threads != previous:
        torch.set_num_threads(threads)
    try:
        yield
    finally:
        if torch.get_num_threads() != previous:
            torch.set_num_threads(previous)
