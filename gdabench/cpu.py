"""The CPU a run computes on: what ``run.json`` records, and the instruction set torch's kernels may use.

torch chooses its CPU kernels by the instruction set it finds (AVX-512 where the CPU has it, else AVX2),
and so do the libraries under it: inductor for the kernels ``torch.compile`` generates, oneDNN for
convolutions, MKL for matrix products.  Kernels of another vector width add in another order, so a
model trained on an AVX-512 CPU rounds differently from one trained on an AVX2 CPU, and ``gda`` proposes
other bodies from its first trained generation on.  So, before torch is imported, :func:`pin` restricts
all four to AVX2, which every x86-64 CPU of the last decade has, with MKL in its conditional numerical
reproducibility mode for that code path: ``gda``'s rows are then the same on any such CPU.  What that
costs is measured in docs/benchmarks/gda.md.  ``GDABENCH_ISA=native`` lifts the pin (each CPU's own
fastest kernels, results that depend on it).

Importing this module pins (``gdabench/__init__.py`` imports it first); nothing here imports torch.
"""

from __future__ import annotations

import os
import platform
import sys
from typing import Any

#: the environment variable that chooses: ``avx2`` (default, the same results on any x86-64 CPU with
#: AVX2) or ``native`` (each CPU's own kernels)
ISA_VARIABLE = "GDABENCH_ISA"
CHOICES = ("avx2", "native")
#: what the pin sets (each read once, when torch, oneDNN or MKL first needs it)
PINS = {
    "ATEN_CPU_CAPABILITY": "avx2",  # torch's own kernels (and inductor's vector width, which follows it)
    "ONEDNN_MAX_CPU_ISA": "AVX2",  # oneDNN's convolutions
    "MKL_CBWR": "AVX2",  # MKL's matrix products: the AVX2 code path (STRICT would make ppo's bmm depend on the batch)
    "TORCHINDUCTOR_CPP_MARCH": "haswell",  # what inductor's C++ compiler may emit (default: -march=native)
}
#: instruction-set extensions worth recording: the ones that change which kernels run
_FLAGS = ("sse4_2", "avx", "avx2", "fma", "avx512f", "avx512_vnni", "avx512_bf16", "avx512_fp16", "amx_tile")


def choice() -> str:
    """``avx2`` or ``native``, as ``GDABENCH_ISA`` says (an unknown value counts as the default)."""
    value = os.environ.get(ISA_VARIABLE, "avx2").strip().lower()
    return value if value in CHOICES else "avx2"


def _cpuinfo() -> tuple[str, set[str]]:
    """The CPU's model name and flags (Linux; elsewhere what the platform module says, no flags)."""
    try:
        with open("/proc/cpuinfo") as fh:
            text = fh.read()
    except OSError:
        return platform.processor() or platform.machine(), set()
    model, flags = "", set[str]()
    for line in text.splitlines():
        key, _, value = line.partition(":")
        if key.strip() == "model name" and not model:
            model = value.strip()
        elif key.strip() == "flags" and not flags:
            flags = set(value.split())
    return model or platform.processor() or platform.machine(), flags


def pinnable() -> bool:
    """Whether this CPU can run the AVX2 kernels (x86-64 with AVX2 and FMA)."""
    _, flags = _cpuinfo()
    return platform.machine().lower() in ("x86_64", "amd64") and {"avx2", "fma"} <= flags


def pin() -> None:
    """Restrict torch, inductor, oneDNN and MKL to AVX2 in this process and the ones it starts, unless
    ``GDABENCH_ISA=native``, the CPU lacks AVX2, or torch is already imported (too late: see :func:`pinned`).
    A variable the user set stays as set."""
    if choice() != "avx2" or "torch" in sys.modules or not pinnable():
        return
    for name, value in PINS.items():
        os.environ.setdefault(name, value)


def pinned() -> bool:
    """Whether this process computes with the pinned kernels (every pin in force as set)."""
    if any(os.environ.get(name) != value for name, value in PINS.items()):
        return False
    if "torch" in sys.modules:  # imported before pin() ran, its capability may already be chosen
        import torch

        return str(torch.backends.cpu.get_cpu_capability()).lower() == "avx2"
    return True


def info() -> dict[str, Any]:
    """For ``run.json``: the CPU's model, the extensions that choose kernels, and the kernels in force."""
    model, flags = _cpuinfo()
    return {
        "model": model,
        "isa": [flag for flag in _FLAGS if flag in flags],
        "kernels": "avx2 (pinned)" if pinned() else "native",
    }


pin()


#: ``GDABENCH_ENGINE_THREADS``: Numba threads the voxel engine uses in a trial's process: a number, or ``auto``
#: (the default: :func:`gdabench.running.cores.engine_threads` in the run's own process, one in a worker)
THREADS_VARIABLE = "GDABENCH_ENGINE_THREADS"


def requested_threads(value: str | None) -> int | None:
    """The engine threads the user asked for (a :data:`THREADS_VARIABLE` value); None for ``auto``."""
    value = (value or "auto").strip().lower()
    if value == "auto":
        return None
    try:
        return max(1, int(value))
    except ValueError:
        return 1


def set_numba_threads(threads: int) -> None:
    """Run this process's Numba kernels (the voxel engine's) on ``threads`` threads (Numba's pool started)."""
    import numba

    start_numba_threads()
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))  # type: ignore[attr-defined]


def worker_numba_threads() -> None:
    """A worker's Numba threads: one (the run starts a worker per core), or what the user asked for.

    Where Numba is not loaded yet, only its variable is set, which it reads when something loads it: a
    worker of a run on ``simple`` never needs Numba, and importing it took a second of every such worker.
    """
    threads = requested_threads(os.environ.get(THREADS_VARIABLE)) or 1
    if "numba" in sys.modules:
        set_numba_threads(threads)
    else:
        os.environ["NUMBA_NUM_THREADS"] = str(threads)


def start_numba_threads() -> None:
    """Start Numba's thread pool now, leaving torch's thread count as it was.

    Numba's OpenMP layer, as it starts its pool, sets the OpenMP thread count of the calling thread to a thread
    per CPU, and torch, which shares the process's OpenMP runtime, reads that count as its own.  Started by the
    engine's first step inside a PPO training (torch set to one thread), it gave every optimiser step two
    threads: with the other core busy, 3 bodies at 512 timesteps learned in 54 s instead of 11 (each Adam step
    waited for the core the other process held).  Started here, before a training sets torch's threads, it
    changes nothing after.
    """
    import numba

    torch = sys.modules.get("torch")
    before = torch.get_num_threads() if torch is not None else None
    numba.get_num_threads()  # starts the pool if it is not running
    if torch is not None and torch.get_num_threads() != before:
        torch.set_num_threads(before)


def cpu_count() -> int:
    """CPUs this process may use (its affinity mask where the platform has one)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1
