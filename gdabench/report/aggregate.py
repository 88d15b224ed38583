"""Over environments: normalised scores, IQM, performance profiles, probability of improvement.

The definitions are rliable's (Agarwal et al., "Deep RL at the edge of the statistical
precipice", 2021), computed with numpy and scipy: rliable 1.2.0 cannot be imported next to
pandas 3 (its ``arch < 8`` dependency fails to import; ``arch`` 8 breaks rliable's bootstrap), so
the tests check these functions against values rliable computed on hand-made data
(``benchmarks/ops/rliable_reference.py``, run in a venv with rliable and pandas 2), and against rliable
itself wherever it imports:

* each run's score on an environment is *normalised* as rliable normalises Atari scores
  (``(score - random) / (best - random)``): 0 = the median score of the ``random`` designer's runs
  on that environment where it ran there (else the lowest score of any run), 1 = the environment's
  optimum where it is known (else the highest score of any run), so a designer no better than
  random search scores about 0 and one that finds the optimum 1;
* the **IQM** is the mean of the middle 50% of all normalised run scores pooled over
  environments (``scipy.stats.trim_mean(..., 0.25)``): robust to outlier runs, yet uses half
  of them, unlike the median;
* a **performance profile** gives, for each threshold tau, the share of runs scoring above tau,
  averaged over environments (rliable's run-score distribution);
* the **probability of improvement** of X over Y is P(X > Y) + P(X = Y) / 2 between a run of X
  and a run of Y on the same environment (A12), averaged over environments;
* intervals are **stratified** percentile bootstraps: runs are resampled with replacement within
  each environment (each designer independently), never across environments.

Only designers with runs on every environment are aggregated (a designer missing an
environment would be ranked on easier or harder tasks than the others).
"""

from __future__ import annotations

import math
from itertools import permutations
from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from scipy.stats import trim_mean

from ..stats.core import BOOTSTRAP_SEED, CONFIDENCE, RESAMPLES
from .pairwise import a12
from .runtimes import run_scores

#: thresholds of the default performance profile
PROFILE_POINTS = 51
#: the designer whose median score counts 0 on an environment where it ran (random search)
BASELINE = "random"

Tasks = Sequence[np.ndarray]  # one array of run scores per environment


def iqm(tasks: Tasks) -> float:
    """Interquartile mean of the run scores pooled over environments."""
    pooled = np.concatenate([np.asarray(t, dtype=float) for t in tasks]) if len(tasks) else np.array([])
    return float(trim_mean(pooled, 0.25)) if len(pooled) else math.nan


def profile(tasks: Tasks, taus: ArrayLike) -> np.ndarray:
    """Share of runs scoring above each tau, averaged over environments."""
    taus = np.asarray(taus, dtype=float)
    return np.mean([(np.asarray(t, dtype=float)[:, None] > taus[None, :]).mean(axis=0) for t in tasks], axis=0)


def improvement_probability(x: Tasks, y: Tasks) -> float:
    """P(X > Y) + P(X = Y) / 2 for runs on the same environment, averaged over environments."""
    return float(np.mean([a12(a, b) for a, b in zip(x, y)]))


def stratified_bootstrap(
    statistic: Callable[..., np.ndarray],
    *samples: Tasks,
    confidence: float = CONFIDENCE,
    resamples: int = RESAMPLES,
    seed: int = BOOTSTRAP_SEED,
) -> tuple[np.ndarray, np.ndarray]:
    """Percentile interval of ``statistic`` when runs are resampled within each environment.

    ``statistic`` receives, for each sample, a list (one per environment) of resampled score
    matrices of shape (resamples, runs) and returns one value (or a vector) per resample.
    """
    rng = np.random.default_rng(seed)
    drawn = [
        [np.asarray(t, dtype=float)[rng.integers(0, len(t), size=(resamples, len(t)))] for t in tasks]
        for tasks in samples
    ]
    values = np.asarray(statistic(*drawn), dtype=float)
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(values, [alpha, 1.0 - alpha], axis=0)
    return low, high


def _iqm_rows(tasks: list[np.ndarray]) -> np.ndarray:
    return trim_mean(np.concatenate(tasks, axis=1), 0.25, axis=1)


def _profile_rows(taus: np.ndarray) -> Callable[[list[np.ndarray]], np.ndarray]:
    return lambda tasks: np.mean([(t[:, :, None] > taus[None, None, :]).mean(axis=1) for t in tasks], axis=0)


def _improvement_rows(x: list[np.ndarray], y: list[np.ndarray]) -> np.ndarray:
    per_task = [
        (a[:, :, None] > b[:, None, :]).mean(axis=(1, 2)) + 0.5 * (a[:, :, None] == b[:, None, :]).mean(axis=(1, 2))
        for a, b in zip(x, y)
    ]
    return np.mean(per_task, axis=0)


# -- from a run table ------------------------------------------------------------------------------
def normalised_scores(
    frame: pd.DataFrame,
    metric: str = "best_reward",
    *,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    optima: Mapping[str, float] | None = None,
    baseline: str | None = BASELINE,
    reevaluations: pd.DataFrame | None = None,
) -> pd.DataFrame:
    """Per-run scores (see :func:`.runtimes.run_scores`) with a ``normalised`` column, and the score each
    environment maps to 0 (``zero``, from ``zero_from``) and to 1 (``one``, from ``one_from``).

    ``bounds`` maps env -> (score that counts 0, score that counts 1); environments it does not name get
    the default bounds (module docstring; ``baseline`` names the designer whose median is 0, None: the
    lowest run).  When the two bounds are equal, every run gets 1.
    """
    scores = run_scores(frame, metric, reevaluations)
    out = scores.assign(normalised=np.nan, zero=np.nan, one=np.nan, zero_from="", one_from="")
    for env, g in scores.groupby("env", sort=False):
        if bounds and env in bounds:
            (low, high), why = map(float, bounds[env]), ("given", "given")
        else:
            base = g.loc[g["designer"] == baseline, "score"].dropna() if baseline else pd.Series(dtype=float)
            low, low_from = (float(base.median()), f"{baseline}'s median") if len(base) else (
                float(g["score"].min()), "lowest run")  # fmt: skip
            optimum = (optima or {}).get(env)
            high, high_from = (float(optimum), "optimum") if optimum is not None else (
                float(g["score"].max()), "best run")  # fmt: skip
            why = (low_from, high_from)
        value = (g["score"] - low) / (high - low) if high > low else pd.Series(1.0, index=g.index)
        out.loc[g.index, "normalised"] = value
        out.loc[g.index, ["zero", "one"]] = [low, high]
        out.loc[g.index, "zero_from"], out.loc[g.index, "one_from"] = why
    return out


def normalisation_words(scores: pd.DataFrame) -> str:
    """How each environment's scores were normalised, in one sentence."""
    parts = []
    for env, g in scores.groupby("env", sort=False):
        r = g.iloc[0]
        parts.append(f"{env}: 0 = {r['zero']:.4g} ({r['zero_from']}), 1 = {r['one']:.4g} ({r['one_from']})")
    return "; ".join(parts)


def _tasks(scores: pd.DataFrame) -> tuple[dict[str, list[np.ndarray]], list[str]]:
    """Normalised run scores per designer and environment, for designers on every environment."""
    envs = list(pd.unique(scores["env"]))
    tasks: dict[str, list[np.ndarray]] = {}
    for designer, g in scores.dropna(subset=["normalised"]).groupby("designer", sort=False):
        per_env = [g.loc[g["env"] == env, "normalised"].to_numpy(dtype=float) for env in envs]
        if all(len(t) for t in per_env):
            tasks[str(designer)] = per_env
    return tasks, envs


def aggregate_scores(
    scores: pd.DataFrame,
    *,
    confidence: float = CONFIDENCE,
    resamples: int = RESAMPLES,
    taus: Sequence[float] | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """From :func:`normalised_scores`: (IQM per designer, performance profiles, probabilities of
    improvement for every ordered pair of designers), each with stratified-bootstrap intervals."""
    tasks, envs = _tasks(scores)
    grid = np.linspace(0.0, 1.0, PROFILE_POINTS) if taus is None else np.asarray(taus, dtype=float)
    iqm_rows, profile_rows, poi_rows = [], [], []
    for designer, t in tasks.items():
        low, high = stratified_bootstrap(_iqm_rows, t, confidence=confidence, resamples=resamples)
        iqm_rows.append(
            {
                "designer": designer,
                "envs": len(envs),
                "runs": sum(map(len, t)),
                "iqm": iqm(t),
                "ci_low": float(low),
                "ci_high": float(high),
            }
        )
        p_low, p_high = stratified_bootstrap(_profile_rows(grid), t, confidence=confidence, resamples=resamples)
        for tau, share, lo, hi in zip(grid, profile(t, grid), p_low, p_high):
            profile_rows.append(
                {
                    "designer": designer,
                    "tau": float(tau),
                    "fraction": float(share),
                    "ci_low": float(lo),
                    "ci_high": float(hi),
                }
            )
    for x, y in permutations(tasks, 2):
        low, high = stratified_bootstrap(
            _improvement_rows, tasks[x], tasks[y], confidence=confidence, resamples=resamples
        )
        poi_rows.append(
            {
                "designer_x": x,
                "designer_y": y,
                "probability": improvement_probability(tasks[x], tasks[y]),
                "ci_low": float(low),
                "ci_high": float(high),
            }
        )
    return (
        pd.DataFrame(iqm_rows, columns=["designer", "envs", "runs", "iqm", "ci_low", "ci_high"]),
        pd.DataFrame(profile_rows, columns=["designer", "tau", "fraction", "ci_low", "ci_high"]),
        pd.DataFrame(poi_rows, columns=["designer_x", "designer_y", "probability", "ci_low", "ci_high"]),
    )
