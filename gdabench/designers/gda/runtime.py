"""Where and how torch runs: device choice and thread count.

The model is tiny (90,833 parameters, 5x5 inputs), so a training step is a few hundred very
small kernels: extra threads mostly add synchronisation.  A GPU is used only when asked for.
"""

from __future__ import annotations

import contextlib
from typing import Iterator

import torch

from ...errors import ConfigError


def resolve_device(name: str) -> torch.device:
    """'cpu', 'cuda' (error if absent), 'cuda:N' or 'auto' (cuda when available, else cpu)."""
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name == "cpu":
        return torch.device("cpu")
    if name.startswith("cuda"):
        if not torch.cuda.is_available():
            raise ConfigError(f"gda: device {name!r} asked for, but torch sees no CUDA GPU (use device=cpu or device=auto)")
        try:
            return torch.device(name)
        except RuntimeError:
            raise ConfigError(f"gda: malformed device {name!r}") from None
    raise ConfigError(f"gda: unknown device {name!r}; choose cpu, cuda, cuda:N or auto")


def check_threads(threads: int | None) -> None:
    if threads is not None and (not isinstance(threads, int) or threads < 1):
        raise ConfigError(f"gda: threads must be at least 1, got {threads!r}")


@contextlib.contextmanager
def torch_threads(threads: int | None) -> Iterator[None]:
    """Use ``threads`` torch threads inside the block, then restore the process's setting.

    One thread is the default for GDA: its kernels are too small to split, and on a 2-core
    machine shared with other work a second thread mostly waits for a busy core (measured:
    several times slower).  None leaves torch's setting alone.
    """
    previous = torch.get_num_threads()
    if threads is not None and threads != previous:
        torch.set_num_threads(threads)
    try:
        yield
    finally:
        if torch.get_num_threads() != previous:
            torch.set_num_threads(previous)
