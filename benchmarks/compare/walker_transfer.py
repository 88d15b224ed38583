"""Transfer check of a walker run: each designer's best body per seed, trained again in Evolution Gym itself.

    plugins/gdabench-evogym/install.sh /work/venv-evogym          # once: Evolution Gym's own simulator
    python benchmarks/compare/walker_transfer.py results/reference/walker --python /work/venv-evogym/bin/python

Every (designer, seed) trial's best body is scored with ``gdabench evaluate`` on ``evogym/Walker-v0``
with the run's controller and the trial's seed (the same PPO at the same budget, Evolution Gym's
simulator instead of gdabench's engine), in ``--jobs`` processes under ``nice``.  Rows go to
``<run>/transfer.csv`` as they finish, so an interrupted check resumes where it stopped.  It prints the
table, the designer ranking by the mean over seeds in both simulators, and the per-body agreement
(Spearman's rank correlation, and how often two bodies are ordered alike).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pandas as pd
from scipy import stats

COLUMNS = ["designer", "seed", "body", "walker", "evogym"]


def best_bodies(run: Path) -> pd.DataFrame:
    """The highest-reward body of every (designer, seed) trial, with its reward on the run's environment."""
    rows = pd.read_parquet(run / "evaluations.parquet", columns=["designer", "seed", "body", "reward"])
    best = rows.loc[rows.groupby(["designer", "seed"], sort=True)["reward"].idxmax()]
    return best.rename(columns={"reward": "walker"}).reset_index(drop=True)


def controller_of(run: Path) -> str:
    """The run's controller as ``name[key=value,...]``, as the command line takes it."""
    choice = json.loads((run / "run.json").read_text())["config"]["controller"]
    params = ",".join(f"{k}={v}" for k, v in sorted(choice.get("params", {}).items()))
    return f"{choice['name']}[{params}]" if params else choice["name"]


def evogym_reward(python: str, body: str, controller: str, seed: int, env: str) -> float:
    command = ["nice", "-n", "10", python, "-m", "gdabench", "evaluate", body, "--env", env,
               "--controller", controller, "--seed", str(seed)]  # fmt: skip
    done = subprocess.run(command, capture_output=True, text=True,
                          env={**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"})  # fmt: skip
    if done.returncode:
        raise SystemExit(f"error: {' '.join(command[3:])} failed: {done.stderr.strip().splitlines()[-1:]}")
    return float(done.stdout.strip().splitlines()[-1])


def pair_agreement(a: pd.Series, b: pd.Series) -> float:
    """The share of body pairs that both simulators order the same way (ties in either left out)."""
    agree = total = 0
    x, y = a.to_numpy(), b.to_numpy()
    for i in range(len(x)):
        for j in range(i + 1, len(x)):
            s = (x[i] - x[j]) * (y[i] - y[j])
            if s != 0:
                total += 1
                agree += s > 0
    return agree / total if total else float("nan")


def read_transfer(path: Path) -> pd.DataFrame:
    """The rows of a ``transfer.csv``, by designer and seed."""
    return pd.read_csv(path, dtype={"body": str}).sort_values(["designer", "seed"]).reset_index(drop=True)


def ranking(table: pd.DataFrame) -> pd.DataFrame:
    """Per designer: its best bodies' mean reward in both simulators and its rank in each, best first."""
    means = table.groupby("designer")[["walker", "evogym"]].mean()
    means.insert(0, "seeds", table.groupby("designer").size())
    means["rank walker"] = means["walker"].rank(ascending=False, method="min").astype(int)
    means["rank evogym"] = means["evogym"].rank(ascending=False, method="min").astype(int)
    return means.sort_values("walker", ascending=False)


def agreement(table: pd.DataFrame) -> tuple[float, float]:
    """Per body: Spearman's rank correlation of the two rewards, and the share of pairs ordered alike."""
    rho = float(stats.spearmanr(table["walker"], table["evogym"]).statistic)
    return rho, pair_agreement(table["walker"], table["evogym"])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("--python", default=sys.executable, help="a Python with gdabench-evogym installed")
    parser.add_argument("--env", default="evogym/Walker-v0")
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args()

    out = args.run / "transfer.csv"
    done = pd.read_csv(out, dtype={"body": str}) if out.exists() else pd.DataFrame(columns=COLUMNS)
    best = best_bodies(args.run)
    todo = best.merge(done[["designer", "seed"]], how="left", indicator=True).query("_merge == 'left_only'")
    controller = controller_of(args.run)
    print(f"{len(todo)} of {len(best)} bodies to train on {args.env} with {controller}", flush=True)

    def one(row: pd.Series) -> None:
        reward = evogym_reward(args.python, row.body, controller, int(row.seed), args.env)
        line = pd.DataFrame([[row.designer, int(row.seed), row.body, row.walker, reward]], columns=COLUMNS)
        line.to_csv(out, mode="a", header=not out.exists(), index=False)  # one row per line: appends are whole
        print(f"{row.designer} seed {row.seed}: walker {row.walker:.2f}, evogym {reward:.2f}", flush=True)

    with ThreadPoolExecutor(args.jobs) as pool:
        list(pool.map(one, (row for _, row in todo.iterrows())))

    table = read_transfer(out)
    print(table.to_string(index=False, float_format="%.2f"))
    print(ranking(table).to_string(float_format="%.2f"))
    rho, alike = agreement(table)
    print(f"per body ({len(table)}): Spearman {rho:.2f}, pairs ordered alike {alike:.0%}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
