"""Plots of the statistics pages: runtime ECDFs, IQM intervals, performance profiles.

Same conventions as :mod:`.plots` (matplotlib's object API, designer i drawn in colour Ci).
"""

from __future__ import annotations

import pandas as pd
from matplotlib.figure import Figure


def _colours(designers: list[str]) -> dict[str, str]:
    return {d: f"C{i % 10}" for i, d in enumerate(designers)}


def ecdf_figure(ecdf: pd.DataFrame, designers: list[str], env: str, targets: int) -> Figure:
    """Share of (run, target) pairs reached against evaluations, log x axis (COCO's runtime ECDF)."""
    fig = Figure(figsize=(7.5, 4.2), layout="constrained")
    ax = fig.subplots()
    colours = _colours(designers)
    for designer, g in ecdf[ecdf["env"] == env].groupby("designer", sort=False):
        ax.plot(
            g["evaluations"], g["fraction"], drawstyle="steps-post", color=colours[designer], lw=1.8, label=designer
        )
    ax.set_xscale("log")
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("evaluations")
    ax.set_ylabel(f"share of (run, target) pairs reached\n({targets} targets)")
    ax.set_title(env)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize="small")
    return fig


def iqm_figure(iqm: pd.DataFrame, designers: list[str], confidence: float) -> Figure:
    """IQM of normalised scores per designer with its stratified-bootstrap interval."""
    fig = Figure(figsize=(6.5, 0.6 * len(iqm) + 1.2), layout="constrained")
    ax = fig.subplots()
    colours = _colours(designers)
    for i, row in enumerate(iqm.itertuples()):
        ax.plot([row.ci_low, row.ci_high], [i, i], color=colours[row.designer], lw=6, alpha=0.45, solid_capstyle="butt")
        ax.plot([row.iqm], [i], "|", color=colours[row.designer], ms=18, mew=2.5)
    ax.set_yticks(range(len(iqm)), list(iqm["designer"]))
    ax.invert_yaxis()
    ax.set_xlabel(f"IQM of normalised scores ({confidence:.0%} stratified-bootstrap CI)")
    ax.grid(axis="x", alpha=0.3)
    return fig


def profile_figure(profiles: pd.DataFrame, designers: list[str], confidence: float) -> Figure:
    """Share of runs above each normalised score, with its band (rliable's performance profile)."""
    fig = Figure(figsize=(7.5, 4.2), layout="constrained")
    ax = fig.subplots()
    colours = _colours(designers)
    for designer, g in profiles.groupby("designer", sort=False):
        ax.plot(g["tau"], g["fraction"], color=colours[designer], lw=1.8, label=designer)
        ax.fill_between(g["tau"], g["ci_low"], g["ci_high"], color=colours[designer], alpha=0.2, lw=0)
    ax.set_xlabel("normalised score tau")
    ax.set_ylabel("share of runs with score > tau")
    ax.set_title(f"Performance profiles (band: {confidence:.0%} stratified-bootstrap CI)")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower left", fontsize="small")
    return fig
