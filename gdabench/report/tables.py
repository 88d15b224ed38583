"""The per-designer table as text cells, shared by the terminal, the markdown and the HTML report.

Formatting lives in one place so that the three views of a run can never disagree.
"""

from __future__ import annotations

import math

import pandas as pd

from ..stats.core import CONFIDENCE

NOT_REACHED = "not reached"


def number(value: float, digits: int = 4) -> str:
    """A number for a table: ``-`` for missing, ``not reached`` for a censored (+inf) time."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if value == math.inf:
        return NOT_REACHED
    return f"{value:.{digits}g}"


def with_interval(
    median: float, low: float, high: float, digits: int = 4, level: float | None = None, confidence: float = CONFIDENCE
) -> str:
    """``median [low, high]``, or just the median when the interval is a single point; an interval whose
    coverage ``level`` falls short of ``confidence`` (too few seeds) says its coverage: ``[low, high] 94%``."""
    if low == high == median or (math.isnan(low) and math.isnan(high)):
        return number(median, digits)
    short = level is not None and not math.isnan(level) and level < confidence - 1e-9
    return f"{number(median, digits)} [{number(low, digits)}, {number(high, digits)}]" + (
        f" {level:.1%}" if short else ""
    )


def interval_cell(row: pd.Series | dict, name: str, confidence: float, digits: int = 4) -> str:
    """A summary row's ``<name>_median`` with its interval and, where it falls short, its coverage."""
    level = row.get(f"{name}_ci_level")
    return with_interval(row[f"{name}_median"], row[f"{name}_ci_low"], row[f"{name}_ci_high"], digits,
                         None if level is None else float(level), confidence)  # fmt: skip


def has_threshold(summary: pd.DataFrame) -> bool:
    return bool(len(summary)) and bool(summary["threshold"].notna().any())


def summary_cells(
    summary: pd.DataFrame, confidence: float = CONFIDENCE, compact: bool = False
) -> tuple[list[str], list[list[str]]]:
    """Headers and rows of the per-designer table built from :func:`gdabench.stats.summary.summarize`.

    ``compact`` is the terminal's view, which fits 80 columns: the best reward with its
    interval, seeds reaching the threshold and the median evaluations to it, and wall time;
    the environment only when there are several (the report has every column).
    """
    if compact:
        return _compact_cells(summary, confidence)
    ci = f"median [{confidence:.0%} CI]"
    again = "reevaluated_median" in summary.columns
    headers = ["designer", "env", "seeds", f"best reward, {ci}", *([f"re-evaluated best, {ci}"] if again else [])]
    threshold = has_threshold(summary)
    targets = summary["threshold"].dropna().unique()
    per_env = threshold and len(targets) > 1  # a suite: each environment has its own threshold
    if threshold:
        target = "the threshold" if per_env else number(float(targets[0]))
        headers += [*(["threshold"] if per_env else []), f"seeds reaching {target}", f"evaluations to {target}, {ci}"]
    headers += [f"mean best-so-far, {ci}", "wall time s, median"]
    rows = []
    for _, r in summary.iterrows():
        env = r["env"] + (f" / {r['controller']}" if r["controller"] else "")
        cells = [
            str(r["designer"]),
            env,
            str(r["seeds"]),
            interval_cell(r, "best", confidence),
            *([interval_cell(r, "reevaluated", confidence)] if again else []),
        ]
        if threshold:
            cells += [
                *([number(r["threshold"])] if per_env else []),
                f"{r['seeds_reached']}/{r['seeds']}",
                interval_cell(r, "evals_to_threshold", confidence, digits=6),
            ]
        cells += [
            interval_cell(r, "mean_best_so_far", confidence),
            f"{r['wall_seconds_median']:.1f}",
        ]
        rows.append(cells)
    return headers, rows


def _compact_cells(summary: pd.DataFrame, confidence: float) -> tuple[list[str], list[list[str]]]:
    several = summary["env"].nunique() > 1 or bool(summary["controller"].astype(bool).any())
    threshold = has_threshold(summary)
    targets = summary["threshold"].dropna().unique()
    target = number(float(targets[0])) if len(targets) == 1 else "target"
    again = "reevaluated_median" in summary.columns
    headers = ["designer", *(["env"] if several else []), f"best [{confidence:.0%} CI]"]
    headers += ["re-evaluated"] if again else []
    headers += [f"hit {target}", f"evals to {target}"] if threshold else []
    headers += ["seconds"]
    rows = []
    for _, r in summary.iterrows():
        cells = [
            str(r["designer"]),
            *([r["env"] + (f" / {r['controller']}" if r["controller"] else "")] if several else []),
        ]
        cells.append(interval_cell(r, "best", confidence))
        if again:
            cells.append(number(r["reevaluated_median"]))
        if threshold:
            cells += [f"{r['seeds_reached']}/{r['seeds']}", number(r["evals_to_threshold_median"], 6)]
        cells.append(f"{r['wall_seconds_median']:.1f}")
        rows.append(cells)
    return headers, rows
