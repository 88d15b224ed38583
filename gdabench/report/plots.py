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

from .diversity import CATEGORIES, COLUMNS as DIVERSITY_COLUMNS
from .stats import CONFIDENCE

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


def _generation_axis(ax, generations: Sequence[int]) -> None:
    ax.set_xlabel("generation")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    if len(set(generations)) == 1:  # a run of one generation: whole generations around it, not matplotlib's +-0.05
        ax.set_xlim(generations[0] - 1, generations[0] + 1)


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
    """All designers on one plot: median best-so-far reward over seeds with its bootstrap band."""
    fig = Figure(figsize=(7.5, 4.5), layout="constrained")
    ax = fig.subplots()
    for i, (designer, (x, median, low, high)) in enumerate(curves.items()):
        colour = f"C{i % 10}"
        ax.plot(x, median, color=colour, lw=1.8, label=f"{designer} ({seeds[designer]} seeds)", drawstyle="steps-post")
        ax.fill_between(x, low, high, color=colour, alpha=0.2, lw=0, step="post")
    if threshold is not None:
        ax.axhline(threshold, color="0.3", ls="--", lw=1, label=f"threshold {threshold:g}")
    ax.set_xlabel("evaluations")
    ax.set_ylabel("best reward so far")
    ax.set_title(
        f"Best-so-far reward: median over seeds, band = {confidence:.0%} bootstrap CI of the median", fontsize=10
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
    for ax, designer in zip(axes, designers):
        mine = generations[generations["designer"] == designer]
        seeds = mine["seed"].nunique()
        for stat in ("max", "mean", "min"):
            by_gen = mine.groupby("generation")[stat]
            median = by_gen.median()
            ax.plot(median.index, median.to_numpy(), color=STAT_COLOURS[stat], lw=1.5, marker=".", ms=3, label=stat)
            if seeds > 1:
                ax.fill_between(
                    median.index,
                    by_gen.quantile(0.25).to_numpy(),
                    by_gen.quantile(0.75).to_numpy(),
                    color=STAT_COLOURS[stat],
                    alpha=0.15,
                    lw=0,
                )
        ax.set_title(f"{designer} ({seeds} seed{'s' if seeds != 1 else ''})", fontsize=10)
        _generation_axis(ax, list(mine["generation"]))
        ax.grid(alpha=0.3)
        ax.yaxis.set_tick_params(labelleft=True)
    axes[0].set_ylabel("reward")
    axes[0].legend(fontsize=8)
    fig.suptitle("Reward per generation (median over seeds, band = inter-quartile range over seeds)", fontsize=10)
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
    for ax, (column, label) in zip(axes, panels):
        for i, designer in enumerate(designers):
            by_gen = div[div["designer"] == designer].groupby("generation")[column]
            median = by_gen.median()
            ax.plot(median.index, median.to_numpy(), color=f"C{i % 10}", lw=1.5, marker=".", ms=3, label=designer)
            ax.fill_between(
                median.index,
                by_gen.quantile(0.25).to_numpy(),
                by_gen.quantile(0.75).to_numpy(),
                color=f"C{i % 10}",
                alpha=0.15,
                lw=0,
            )
        ax.set_title(label, fontsize=9)
        _generation_axis(ax, list(div["generation"]))
        if not div[column].notna().any():
            _empty(ax, "needs a previous generation")
        ax.grid(alpha=0.3)
    axes[0].set_ylim(0, 1.05)
    axes[0].legend(fontsize=8)
    fig.suptitle("Diversity of proposals (median over seeds, band = inter-quartile range)", fontsize=10)
    return fig


def novelty_figure(div: pd.DataFrame, designers: Sequence[str], near_copy: int) -> Figure:
    """Per designer, the share of proposals in each category (copy ... novel shape) per generation."""
    share_columns = DIVERSITY_COLUMNS[-len(CATEGORIES) :]
    fig, axes = _grid(len(designers))
    for ax, designer in zip(axes, designers):
        mine = div[(div["designer"] == designer) & div[share_columns[0]].notna()]
        mean = mine.groupby("generation")[share_columns].mean()
        if len(mean):
            ax.stackplot(mean.index, mean.to_numpy().T, labels=CATEGORIES, colors=CATEGORY_COLOURS, step="mid")
        else:
            _empty(ax, "needs a previous generation")
        ax.set_title(designer, fontsize=10)
        _generation_axis(ax, list(div["generation"]))
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
