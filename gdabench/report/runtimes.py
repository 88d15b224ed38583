"""Fixed-target and fixed-budget views of a run table, as COCO and IOHprofiler define them.

Every function takes the tidy evaluations table (one row per proposed body, see
:data:`gdabench.results.COLUMNS`) and works per environment, so a table that holds several
environments (a suite, or runs concatenated with :func:`pandas.concat`) is analysed one
environment at a time.  A *run* is one (environment, designer, run id, seed).

* **Fixed target** (how many evaluations to reach a reward?).  A run's *runtime* to a target is
  the evaluation count at which its best-so-far reward first reached it; a run that never did is
  unsuccessful.  The *expected running time* (ERT) is COCO's: the evaluations spent by all runs
  (an unsuccessful run contributes every evaluation it made) divided by the number of successful
  runs, i.e. the expected cost of restarting until success.  It is infinite when no run succeeds.
  The *ECDF of runtimes* is the share of (run, target) pairs reached after each evaluation count.
* **Fixed budget** (what reward after so many evaluations?): each run's best-so-far reward at the
  budget, summarised over seeds.

Default targets span the rewards the runs made progress over: from the median over runs of the
best reward in their first generation up to the best reward any run found, plus the
environment's optimum when it is known and no run found it; default budgets are 10%, 25%, 50% and
100% of the evaluation budget.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from ..errors import ConfigError
from ..stats.core import (
    BOOTSTRAP_SEED,
    CONFIDENCE,
    RESAMPLES,
    TOLERANCE,
    best_so_far_curve,
    censored_median,
    mean_best_so_far,
    median_interval,
    with_run_id,
)
from ..statuses import COUNTED

#: targets in the ERT table, and in the ECDF (where many targets make a smooth curve)
TABLE_TARGETS = 5
ECDF_TARGETS = 50
#: fractions of the evaluation budget shown in the fixed-budget table
BUDGET_FRACTIONS = (0.1, 0.25, 0.5, 1.0)

Targets = Mapping[str, Sequence[float]] | Sequence[float] | None


@dataclass(frozen=True)
class RunTrace:
    """Best-so-far reward of one run after each of its evaluations."""

    env: str
    designer: str
    run_id: str
    seed: int
    curve: np.ndarray  # curve[n - 1] = best reward after n evaluations; NaN until the first success
    population: int

    @property
    def evaluations(self) -> int:
        return len(self.curve)

    @property
    def final(self) -> float:
        """Best reward of the run (NaN if no evaluation succeeded)."""
        finite = self.curve[~np.isnan(self.curve)]
        return float(finite[-1]) if len(finite) else math.nan

    def runtime(self, target: float, tol: float = TOLERANCE) -> float:
        """Evaluations until the best-so-far first reached ``target``; NaN if it never did."""
        reached = self.curve >= target - tol  # NaN compares False
        return float(np.argmax(reached) + 1) if reached.any() else math.nan

    def at(self, budget: int, optimum: float | None = None, tol: float = TOLERANCE) -> float:
        """Best-so-far reward after ``budget`` evaluations.

        NaN when the run made fewer evaluations, unless it stopped at the optimum (then its
        reward cannot change any more and the optimum stands).
        """
        if budget <= self.evaluations:
            return float(self.curve[budget - 1])
        if optimum is not None and self.final >= optimum - tol:
            return self.final
        return math.nan


def run_traces(frame: pd.DataFrame) -> list[RunTrace]:
    """One trace per run, environments and designers in the order they appear, seeds ascending."""
    if frame.empty:
        return []
    frame = with_run_id(frame)
    envs = _order(frame["env"])
    designers = _order(frame["designer"])
    traces = []
    for (env, designer, run_id, seed), run in frame.groupby(["env", "designer", "run_id", "seed"], sort=False):
        used = int(run["status"].isin(COUNTED).sum())
        population = int(run["population"].iloc[0]) if "population" in run.columns else 1
        traces.append(
            RunTrace(str(env), str(designer), str(run_id), int(seed), best_so_far_curve(run, used), population)
        )
    return sorted(traces, key=lambda t: (envs[t.env], designers[t.designer], t.run_id, t.seed))


def _order(column: pd.Series) -> dict[str, int]:
    return {str(v): i for i, v in enumerate(pd.unique(column))}


def by_env(traces: Sequence[RunTrace]) -> dict[str, list[RunTrace]]:
    out: dict[str, list[RunTrace]] = {}
    for t in traces:
        out.setdefault(t.env, []).append(t)
    return out


def by_designer(traces: Sequence[RunTrace]) -> dict[str, list[RunTrace]]:
    out: dict[str, list[RunTrace]] = {}
    for t in traces:
        out.setdefault(t.designer, []).append(t)
    return out


# -- per-run scores -------------------------------------------------------------------------------
#: per-run scores the pairwise tests and the aggregates can compare (all: higher is better)
METRICS: dict[str, tuple[str, Callable[[RunTrace], float]]] = {
    "best_reward": ("best reward", lambda t: t.final),
    "mean_best_so_far": ("mean best-so-far reward", lambda t: mean_best_so_far(t.curve)),
}
#: the trial's best body's mean over further training seeds (:mod:`.reevaluated`), from the re-evaluations
REEVALUATED = "reevaluated_best"
METRIC_NAMES = {**{k: v[0] for k, v in METRICS.items()}, REEVALUATED: "re-evaluated best reward"}


def resolve_metric(metric: str, reevaluations: pd.DataFrame | None) -> str:
    """``auto``: the re-evaluated best where the run has re-evaluations, else the best reward."""
    if metric == "auto":
        return REEVALUATED if reevaluations is not None and len(reevaluations) else "best_reward"
    return metric


def run_scores(
    frame: pd.DataFrame, metric: str = "best_reward", reevaluations: pd.DataFrame | None = None
) -> pd.DataFrame:
    """One row per run: env, designer, run_id, seed, evaluations and the metric's value as ``score``
    (``reevaluated_best`` needs the run's re-evaluations; a run without any scores NaN)."""
    metric = resolve_metric(metric, reevaluations)
    if metric not in METRIC_NAMES:
        raise ConfigError(f"unknown metric {metric!r}; choose one of {', '.join(METRIC_NAMES)}")
    columns = ["env", "designer", "run_id", "seed", "evaluations", "score"]
    if metric == REEVALUATED:
        from ..stats.reevaluated import TRIAL, trial_scores

        if reevaluations is None or not len(reevaluations):
            raise ConfigError("the re-evaluated best needs the run's re-evaluations (gdabench reevaluate RUN_DIR)")
        runs = pd.DataFrame([(t.env, t.designer, t.run_id, t.seed, t.evaluations) for t in run_traces(frame)],
                            columns=columns[:-1])  # fmt: skip
        scores = trial_scores(frame, reevaluations)[[*TRIAL, "reevaluated_best"]].rename(
            columns={"reevaluated_best": "score"}
        )
        return runs.merge(scores.astype({"seed": runs["seed"].dtype}), on=TRIAL, how="left")[columns]
    score = METRICS[metric][1]
    rows = [(t.env, t.designer, t.run_id, t.seed, t.evaluations, score(t)) for t in run_traces(frame)]
    return pd.DataFrame(rows, columns=columns)


# -- targets and budgets ---------------------------------------------------------------------------
def default_targets(traces: Sequence[RunTrace], count: int, optimum: float | None = None) -> list[float]:
    """``count`` targets evenly spaced from above the first generation's median best reward up to
    the best reward any run found, plus the optimum when it is known and higher.

    Targets below the top are rounded to three significant digits so that a table reads well.
    """
    finals = [t.final for t in traces if not math.isnan(t.final)]
    if not finals:
        return []
    top = max(finals)
    starts = [t.at(min(t.population, t.evaluations)) for t in traces if t.evaluations]
    starts = [s for s in starts if not math.isnan(s)]
    low = float(np.median(starts)) if starts else min(finals)
    chosen = {top} | ({float(optimum)} if optimum is not None and optimum > top else set())
    if low < top:
        rounded = (float(f"{low + (top - low) * k / count:.3g}") for k in range(1, count))
        chosen |= {r for r in rounded if low < r < top}
    return sorted(chosen)


def _targets_for(
    env: str, targets: Targets, traces: Sequence[RunTrace], count: int, optima: Mapping[str, float] | None
) -> list[float]:
    if targets is None:
        return default_targets(traces, count, (optima or {}).get(env))
    if isinstance(targets, Mapping):
        return sorted(map(float, targets.get(env, ())))
    return sorted(map(float, targets))


def horizon(traces: Sequence[RunTrace], frame: pd.DataFrame | None = None) -> int:
    """The evaluation budget of these runs (the largest budget recorded, else the most evaluations)."""
    most = max((t.evaluations for t in traces), default=0)
    if frame is not None and "budget" in frame.columns and frame["budget"].notna().any():
        return max(int(frame["budget"].max()), most)
    return most


def default_budgets(budget: int) -> list[int]:
    return sorted({max(1, round(budget * f)) for f in BUDGET_FRACTIONS})


# -- fixed target ---------------------------------------------------------------------------------
def expected_runtime(runtimes: ArrayLike, evaluations: ArrayLike) -> float:
    """COCO's ERT: evaluations of all runs (the runtime of a successful run, all evaluations of an
    unsuccessful one, marked NaN in ``runtimes``) over the number of successes; inf without any."""
    rt = np.asarray(runtimes, dtype=float)
    success = ~np.isnan(rt)
    if not success.any():
        return math.inf
    return float(np.where(success, rt, np.asarray(evaluations, dtype=float)).sum() / success.sum())


def expected_runtime_ci(
    runtimes: Sequence[float],
    evaluations: Sequence[float],
    *,
    confidence: float = CONFIDENCE,
    resamples: int = RESAMPLES,
    seed: int = BOOTSTRAP_SEED,
) -> tuple[float, float]:
    """Percentile-bootstrap interval of the ERT, resampling runs (inf where a resample has no success)."""
    rt = np.asarray(runtimes, dtype=float)
    if len(rt) < 2:
        value = expected_runtime(rt, evaluations)
        return value, value
    success = ~np.isnan(rt)
    cost = np.where(success, rt, np.asarray(evaluations, dtype=float))
    idx = np.random.default_rng(seed).integers(0, len(rt), size=(resamples, len(rt)))
    hits = success[idx].sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        erts = np.where(hits > 0, cost[idx].sum(axis=1) / np.maximum(hits, 1), np.inf)
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(erts, [alpha, 1.0 - alpha], method="inverted_cdf")
    return float(low), float(high)


def runtimes(
    frame: pd.DataFrame, targets: Targets = None, *, optima: Mapping[str, float] | None = None
) -> pd.DataFrame:
    """One row per run and target: the runtime (NaN when not reached) and the evaluations the run made."""
    rows = []
    for env, traces in by_env(run_traces(frame)).items():
        for target in _targets_for(env, targets, traces, TABLE_TARGETS, optima):
            rows += [(env, t.designer, t.run_id, t.seed, target, t.runtime(target), t.evaluations) for t in traces]
    return pd.DataFrame(rows, columns=["env", "designer", "run_id", "seed", "target", "runtime", "evaluations"])


def fixed_target(
    frame: pd.DataFrame,
    targets: Targets = None,
    *,
    optima: Mapping[str, float] | None = None,
    confidence: float = CONFIDENCE,
    resamples: int = RESAMPLES,
) -> pd.DataFrame:
    """ERT and success rate per (env, designer, target).

    ``targets`` is one list for every environment, a mapping env -> list, or None for
    :func:`default_targets` (``optima`` maps env -> known optimum).  ``median_runtime`` is inf
    when half the runs or more did not reach the target (censored, never dropped).
    """
    rt = runtimes(frame, targets, optima=optima)
    rows = []
    for (env, designer, target), g in rt.groupby(["env", "designer", "target"], sort=False):
        low, high = expected_runtime_ci(g["runtime"], g["evaluations"], confidence=confidence, resamples=resamples)
        successes = int(g["runtime"].notna().sum())
        rows.append(
            {
                "env": env, "designer": designer, "target": target, "runs": len(g), "successes": successes,
                "success_rate": successes / len(g), "ert": expected_runtime(g["runtime"], g["evaluations"]),
                "ert_ci_low": low, "ert_ci_high": high, "median_runtime": censored_median(g["runtime"]),
            }
        )  # fmt: skip
    columns = [
        "env",
        "designer",
        "target",
        "runs",
        "successes",
        "success_rate",
        "ert",
        "ert_ci_low",
        "ert_ci_high",
        "median_runtime",
    ]
    return (
        pd.DataFrame(rows, columns=columns)
        .sort_values(["env", "target"], kind="stable", key=_appearance(rt))
        .reset_index(drop=True)
    )


def _appearance(table: pd.DataFrame) -> Callable[[pd.Series], pd.Series]:
    """Sort key keeping environments in the order they appear; other columns sort by value."""
    envs = {e: i for i, e in enumerate(pd.unique(table["env"]))}
    return lambda column: column.map(envs) if column.name == "env" else column


def runtime_ecdf(
    frame: pd.DataFrame,
    targets: Targets = None,
    *,
    optima: Mapping[str, float] | None = None,
    points: int = 200,
) -> pd.DataFrame:
    """Share of (run, target) pairs reached after each evaluation count, per (env, designer).

    The default targets are :data:`ECDF_TARGETS` evenly spaced ones (see :func:`default_targets`).
    Evaluation counts are ``points`` log-spaced values from 1 to the budget.
    """
    traces = run_traces(frame)
    rows = []
    for env, env_traces in by_env(traces).items():
        chosen = _targets_for(env, targets, env_traces, ECDF_TARGETS, optima)
        top = horizon(env_traces, frame[frame["env"] == env])
        grid = np.unique(np.round(np.geomspace(1, max(top, 1), points)).astype(int))
        for designer, mine in by_designer(env_traces).items():
            rt = np.array([[t.runtime(target) for target in chosen] for t in mine], dtype=float).ravel()
            reached = np.where(np.isnan(rt), np.inf, rt)
            share = (reached[None, :] <= grid[:, None]).mean(axis=1) if len(reached) else np.zeros(len(grid))
            rows += [(env, designer, int(n), float(s)) for n, s in zip(grid, share)]
    return pd.DataFrame(rows, columns=["env", "designer", "evaluations", "fraction"])


# -- fixed budget ---------------------------------------------------------------------------------
def fixed_budget(
    frame: pd.DataFrame,
    budgets: Mapping[str, Sequence[int]] | Sequence[int] | None = None,
    *,
    optima: Mapping[str, float] | None = None,
    confidence: float = CONFIDENCE,
) -> pd.DataFrame:
    """Best-so-far reward at each budget per (env, designer): median over runs with its order-statistic
    interval and that interval's coverage (``ci_level``, see :func:`.stats.median_interval`), quartiles
    and mean.  ``runs`` counts the runs that got that far (see :meth:`RunTrace.at`)."""
    rows = []
    for env, env_traces in by_env(run_traces(frame)).items():
        optimum = (optima or {}).get(env)
        if budgets is None:
            chosen = default_budgets(horizon(env_traces, frame[frame["env"] == env]))
        else:
            chosen = list(budgets.get(env, ())) if isinstance(budgets, Mapping) else list(budgets)
        for designer, mine in by_designer(env_traces).items():
            for b in sorted(int(x) for x in chosen):
                values = np.array([t.at(b, optimum) for t in mine], dtype=float)
                values = values[~np.isnan(values)]
                interval = median_interval(values, confidence)
                rows.append(
                    {
                        "env": env, "designer": designer, "budget": b, "runs": len(values),
                        "median": interval.median, "ci_low": interval.low, "ci_high": interval.high,
                        "ci_level": interval.level,
                        "q25": float(np.quantile(values, 0.25)) if len(values) else math.nan,
                        "q75": float(np.quantile(values, 0.75)) if len(values) else math.nan,
                        "mean": float(values.mean()) if len(values) else math.nan,
                    }
                )  # fmt: skip
    return pd.DataFrame(
        rows,
        columns=["env", "designer", "budget", "runs", "median", "ci_low", "ci_high", "ci_level", "q25", "q75", "mean"],
    )
