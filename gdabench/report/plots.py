"""The report's plots, drawn with matplotlib's object API (no pyplot, no global backend state).

Figures are built as :class:`matplotlib.figure.Figure` objects and rendered to PNG bytes by the
Agg renderer, so reports can be written from any thread or worker without a display.
"""

from __future__ import annotations

import io
import math
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from ..stats.core import CONFIDENCE
from .diversity import CATEGORIES, COLUMNS as DIVERSITY_COLUMNS

CATEGORY_COLOURS = ("#7f7f7f", "#c7c7c7", "#fdae6b", "#6baed6")
STAT_COLOURS = {"max": "tab:green", "mean": "tab:blue", "min": "tab:red"}


def png(fig: Figure, dpi: int = 100) -> bytes:
    """Render a figure to PNG bytes; no timestamp or software tag, so equal inputs give equal files."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi, metadata={"Software": None})
    return buffer.getvalue()


def _grid(n: int, max_cols: int = 3, size: tuple[float, float] = (4.2, 3.0)) -> tuple[Figure, np.flatiter[Any]]:
    cols = max(1, min(max_cols, n))
    rows = max(1, math.ceil(n / cols))
    fig = Figure(figsize=(size[0] * cols, size[1] * rows + 0.4), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False, sharey=True)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    return fig, axes.flat


def _generation_axis(ax, generations: Sequence[int], lone: bool = False) -> None:
    """Whole-generation ticks; around a lone point, limits that span the run's generations.

    Left alone, matplotlib puts a single x at the centre of a +-0.05 range with fractional ticks.
    """
    ax.set_xlabel("generation")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    first, last = min(generations, default=0), max(generations, default=0)
    if first == last:  # a run of one generation: whole generations around it
        ax.set_xlim(first - 1, last + 1)
    elif lone:  # lines elsewhere, one point here: the same generations as the lines
        ax.set_xlim(first - 0.5, last + 0.5)


def _dodge(i: int, n: int, width: float = 0.3) -> float:
    """Offset of series ``i`` of ``n`` beside a whole generation, so that lone points do not hide each other."""
    return 0.0 if n < 2 else width * (i / (n - 1) - 0.5)


def _median_and_spread(ax, by_gen: Any, *, colour: str, label: str, spread: bool = True, offset: float = 0.0) -> bool:
    """Draw the median over seeds per generation and its inter-quartile range; True if it was a lone point.

    Across generations that is a line with a band; a single generation (or a single one with data) is
    a point with error bars, since a line and a band through one x draw nothing.
    """
    median = by_gen.median()
    if median.notna().sum() != 1:
        ax.plot(median.index, median.to_numpy(), color=colour, lw=1.5, marker=".", ms=3, label=label)
        if spread:
            low, high = by_gen.quantile(0.25).to_numpy(), by_gen.quantile(0.75).to_numpy()
            ax.fill_between(median.index, low, high, color=colour, alpha=0.15, lw=0)
        return False
    at = median.notna()
    y = median[at].to_numpy()
    yerr = None
    if spread:
        yerr = np.vstack([y - by_gen.quantile(0.25)[at].to_numpy(), by_gen.quantile(0.75)[at].to_numpy() - y])
    x = median.index[at].to_numpy() + offset
    ax.errorbar(x, y, yerr=yerr, fmt="o", ms=5, capsize=4, color=colour, label=label)
    return True


def _spread_words(lone: Sequence[bool]) -> str:
    """How the inter-quartile range is drawn: a band along lines, error bars on lone points."""
    words = [word for kind, word in ((False, "band"), (True, "error bars")) if kind in lone]
    return " or ".join(words) or "band"


def _empty(ax, why: str) -> None:
    """Say why a panel has nothing to draw, instead of leaving it blank."""
    ax.text(0.5, 0.5, why, transform=ax.transAxes, ha="center", va="center", fontsize=8, color="0.4", wrap=True)
    ax.set_yticks([])


def best_so_far_figure(
    curves: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
    *,
    seeds: Mapping[str, int],
    threshold: float | None = None,
    confidence: float = CONFIDENCE,
) -> Figure:
    """All designers on one plot: median best-so-far reward over seeds with its order-statistic band."""
    fig = Figure(figsize=(7.5, 4.5), layout="constrained")
    ax = fig.subplots()
    for i, (designer, (x, median, low, high)) in enumerate(curves.items()):
        colour = f"C{i % 10}"
        label = f"{designer} ({seeds[designer]} seed{'s' if seeds[designer] != 1 else ''})"
        ax.plot(x, median, color=colour, lw=1.8, label=label, drawstyle="steps-post")
        ax.fill_between(x, low, high, color=colour, alpha=0.2, lw=0, step="post")
    if threshold is not None:
        ax.axhline(threshold, color="0.3", ls="--", lw=1, label=f"threshold {threshold:g}")
    ax.set_xlabel("evaluations")
    ax.set_ylabel("best reward so far")
    ax.set_title(
        "Best-so-far reward: median over seeds, band = order-statistic interval of the median", fontsize=10
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    return fig


def generation_rewards_figure(generations: pd.DataFrame, designers: Sequence[str]) -> Figure:
    """Per designer, reward per generation as min / mean / max (the thesis's figures 5.1-5.7).

    With several seeds each line is the median over seeds of that statistic, and the band its
    inter-quartile range over seeds; with one seed it is exactly the thesis's plot.
    """
    fig, axes = _grid(len(designers))
    lone: list[bool] = []
    for ax, designer in zip(axes, designers):
        mine = generations[generations["designer"] == designer]
        seeds = mine["seed"].nunique()
        for i, stat in enumerate(("max", "mean", "min")):
            by_gen = mine.groupby("generation")[stat]
            colour, offset = STAT_COLOURS[stat], _dodge(i, 3)
            lone.append(_median_and_spread(ax, by_gen, colour=colour, label=stat, spread=seeds > 1, offset=offset))
        ax.set_title(f"{designer} ({seeds} seed{'s' if seeds != 1 else ''})", fontsize=10)
        _generation_axis(ax, list(mine["generation"]), lone=lone[-1])
        ax.grid(alpha=0.3)
        ax.yaxis.set_tick_params(labelleft=True)
    axes[0].set_ylabel("reward")
    axes[0].legend(fontsize=8)
    fig.suptitle(
        f"Reward per generation (median over seeds, {_spread_words(lone)} = inter-quartile range over seeds)",
        fontsize=10,
    )
    return fig


def diversity_figure(div: pd.DataFrame, designers: Sequence[str]) -> Figure:
    """Unique share, mean pairwise distance and distance to the nearest survivor, per generation."""
    panels = [
        ("unique_share", "unique proposals (share)"),
        ("mean_pairwise_hamming", "mean pairwise Hamming distance (voxels)"),
        ("nearest_survivor_mean", "mean distance to nearest survivor (voxels)"),
    ]
    fig = Figure(figsize=(13, 3.6), layout="constrained")
    axes = fig.subplots(1, len(panels))
    lone: list[bool] = []
    for ax, (column, label) in zip(axes, panels):
        drawn = []
        for i, designer in enumerate(designers):
            by_gen = div[div["designer"] == designer].groupby("generation")[column]
            offset = _dodge(i, len(designers))
            drawn.append(_median_and_spread(ax, by_gen, colour=f"C{i % 10}", label=designer, offset=offset))
        ax.set_title(label, fontsize=9)
        _generation_axis(ax, list(div["generation"]), lone=any(drawn))
        if not div[column].notna().any():
            _empty(ax, "needs a previous generation")
        else:
            lone += drawn
        ax.grid(alpha=0.3)
    axes[0].set_ylim(0, 1.05)
    axes[0].legend(fontsize=8)
    fig.suptitle(
        f"Diversity of proposals (median over seeds, {_spread_words(lone)} = inter-quartile range)", fontsize=10
    )
    return fig


def _stacked_bar(ax, mean: pd.DataFrame) -> None:
    """The category shares of the one generation that has them, as a bar: a stack plot of one x is empty."""
    bottom = 0.0
    for share, category, colour in zip(mean.iloc[0].to_numpy(), CATEGORIES, CATEGORY_COLOURS):
        ax.bar(mean.index[0], share, bottom=bottom, width=0.6, color=colour, label=category)
        bottom += share


def novelty_figure(div: pd.DataFrame, designers: Sequence[str], near_copy: int) -> Figure:
    """Per designer, the share of proposals in each category (copy ... novel shape) per generation."""
    share_columns = DIVERSITY_COLUMNS[-len(CATEGORIES) :]
    fig, axes = _grid(len(designers))
    for ax, designer in zip(axes, designers):
        mine = div[(div["designer"] == designer) & div[share_columns[0]].notna()]
        mean = mine.groupby("generation")[share_columns].mean()
        if len(mean) > 1:
            ax.stackplot(mean.index, mean.to_numpy().T, labels=CATEGORIES, colors=CATEGORY_COLOURS, step="mid")
        elif len(mean):
            _stacked_bar(ax, mean)
        else:
            _empty(ax, "needs a previous generation")
        ax.set_title(designer, fontsize=10)
        _generation_axis(ax, list(div["generation"]), lone=len(mean) == 1)
        ax.set_ylim(0, 1)
        ax.yaxis.set_tick_params(labelleft=True)
    axes[0].set_ylabel("share of proposals")
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside lower center", ncols=len(CATEGORIES), fontsize=8, frameon=False)
    fig.suptitle(
        f"Proposals by distance to the nearest survivor (near-copy: at most {near_copy} voxels differ; mean over "
        f"seeds)",
        fontsize=10,
    )
    return fig
