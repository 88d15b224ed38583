"""How much one other busy process slows a co-design run, with the engine's threads as gdabench chooses
them (``GDABENCH_ENGINE_THREADS=auto``) and with Numba's default (a thread per CPU).

    python benchmarks/figures/engine_threads_load.py --repeats 3
    python benchmarks/figures/engine_threads_load.py --engine-only --repeats 5    # the engine's step alone, seconds
    python benchmarks/figures/engine_threads_load.py --loop-only --repeats 7      # no gdabench: a core's share

Each arm runs the same command (25 random bodies learning 2,048 timesteps in lockstep on the walker,
in the command's own process, without re-evaluation: the run of issue 57) and the arms alternate, so
that the machine's other load falls on all of them alike.  ``busy`` starts one process spinning on a
core for the run's length; ``1 thread, quiet`` is the run held to one engine thread on the quiet machine,
the core it can keep beside a busy process.  Prints each run's wall time, the medians and the ratios
busy/quiet, against either quiet arm; the goal is at most 1.3.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

COMMAND = ["-m", "gdabench", "compare", "-d", "random", "--env", "walker", "-c", "ppo[timesteps=2048]",
           "--population", "25", "--budget", "25", "--seeds", "0", "--jobs", "1", "--reevaluate", "off", "-q",
           "--no-report"]  # fmt: skip
SPIN = "import time\nwhile True:\n    pass\n"


@contextlib.contextmanager
def beside_busy(busy: bool, settle: float = 0.0) -> Iterator[None]:
    """One process spinning on a core for the block (where ``busy``), given ``settle`` seconds to start."""
    spinner = subprocess.Popen([sys.executable, "-c", SPIN]) if busy else None
    try:
        time.sleep(settle if busy else 0)
        yield
    finally:
        if spinner is not None:
            spinner.kill()
            spinner.wait()


def run(threads: str, busy: bool, out: Path) -> float:
    env = {**os.environ, "GDABENCH_ENGINE_THREADS": threads}
    with beside_busy(busy):
        start = time.perf_counter()
        subprocess.run([sys.executable, *COMMAND, "--out", str(out)], env=env, check=True)
        return time.perf_counter() - start


def engine_only(repeats: int, steps: int = 300) -> None:
    """The engine's batch step alone (25 bodies), on one thread and on every CPU, with and without one busy
    process beside it: what the choice of threads is worth, in seconds rather than a run's minutes."""
    import numba
    import numpy as np

    import gdabench
    from gdabench.envs.voxel.batch import TaskBatch

    rng = np.random.default_rng(0)
    batch = TaskBatch("Walker-v0", [gdabench.random_body(rng).text for _ in range(25)])
    batch.reset()
    actions = rng.uniform(0.6, 1.6, size=(steps, batch.num_envs, max(batch.act_sizes)))
    cpus = numba.config.NUMBA_NUM_THREADS
    arms = {(threads, busy): [] for busy in (False, True) for threads in sorted({1, cpus})}
    for _ in range(repeats):
        for (threads, busy), times in arms.items():
            numba.set_num_threads(threads)
            batch.step(actions[0])  # compiled and warm
            with beside_busy(busy, settle=0.2):
                start = time.perf_counter()
                for a in actions:
                    batch.step(a)
                times.append(time.perf_counter() - start)
    for (threads, busy), times in arms.items():
        rate = steps * 25 / statistics.median(times)
        print(f"{threads} thread(s), {'busy' if busy else 'quiet'}: median {statistics.median(times):.2f} s "
              f"({rate:,.0f} env steps/s; {', '.join(f'{t:.2f}' for t in times)}; load {os.getloadavg()[0]:.1f})")
    quiet = min(statistics.median(arms[(t, False)]) for t in sorted({1, cpus}))
    for threads in sorted({1, cpus}):
        ratio = statistics.median(arms[(threads, True)]) / quiet
        print(f"busy with {threads} thread(s) / quiet with the faster choice: x{ratio:.2f}")


def loop_only(repeats: int, n: int = 20_000_000) -> None:
    """A pure Python loop (no memory traffic, one thread) alone and beside one busy process: how much of its
    core a process keeps when the other core is busy, whatever gdabench does.  Above 1, the two CPUs share
    hardware (host hyper-threads, or a clock that drops when both cores run)."""
    times: dict[bool, list[float]] = {False: [], True: []}
    for _ in range(repeats):
        for busy in (False, True):
            with beside_busy(busy, settle=0.2):
                start = time.perf_counter()
                for _ in range(n):
                    pass
                times[busy].append(time.perf_counter() - start)
    for busy, t in times.items():
        print(f"loop, {'busy' if busy else 'quiet'}: median {statistics.median(t):.3f} s "
              f"({', '.join(f'{x:.3f}' for x in t)}; load {os.getloadavg()[0]:.1f})")
    print(f"loop busy / quiet: x{statistics.median(times[True]) / statistics.median(times[False]):.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--engine-only", action="store_true", help="time the engine's batch step alone")
    parser.add_argument("--loop-only", action="store_true", help="time a pure Python loop alone, no gdabench")
    parser.add_argument("--arms", default="", help="only these arms, separated by ';' ('auto, quiet;1 thread, quiet')")
    args = parser.parse_args()
    if args.engine_only:
        engine_only(args.repeats)
        return
    if args.loop_only:
        loop_only(args.repeats)
        return
    cpus = os.cpu_count() or 1
    # "1 thread, quiet": the run on one core of a quiet machine, what it can keep beside a process on the other
    arms = {"auto, quiet": ("auto", False), "auto, busy": ("auto", True), f"{cpus} threads, busy": (str(cpus), True),
            "1 thread, quiet": ("1", False)}  # fmt: skip
    chosen = [a.strip() for a in args.arms.split(";") if a.strip()] if args.arms else list(arms)
    if set(chosen) - set(arms):
        sys.exit(f"error: unknown arms {sorted(set(chosen) - set(arms))}; choose from {sorted(arms)}")
    arms = {arm: arms[arm] for arm in chosen}
    times: dict[str, list[float]] = {arm: [] for arm in arms}
    with tempfile.TemporaryDirectory() as tmp:
        for repeat in range(args.repeats):
            for arm, (threads, busy) in arms.items():
                seconds = run(threads, busy, Path(tmp) / f"{repeat}-{len(times[arm])}-{threads}-{busy}")
                times[arm].append(seconds)
                print(f"repeat {repeat}: {arm:>18}: {seconds:6.1f} s  (load {os.getloadavg()[0]:.1f})", flush=True)
    medians = {arm: statistics.median(t) for arm, t in times.items()}
    for arm, median in medians.items():
        print(f"{arm:>18}: median {median:6.1f} s  ({', '.join(f'{t:.1f}' for t in times[arm])})")
    for busy in ("auto, busy", f"{cpus} threads, busy"):
        for quiet in ("auto, quiet", "1 thread, quiet"):
            if busy in medians and quiet in medians:
                print(f"{busy} / {quiet}: x{medians[busy] / medians[quiet]:.2f}  (goal: at most x1.3)")


if __name__ == "__main__":
    main()
