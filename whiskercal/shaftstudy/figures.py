"""Figures of the shaft study report (PNG, matplotlib's Agg backend).

- ``shaft_error_vs_travel.png``: the contact error against travel since contact, per trial;
- ``shaft_estimates.png``: estimated against true contact points in the whisker frame.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from whiskercal.plotting import pyplot, save_png

NAMES = ("shaft_error_vs_travel.png", "shaft_estimates.png")


def figure_paths(out_dir: str | Path) -> list[Path]:
    """Where the figures go."""
    return [Path(out_dir) / name for name in NAMES]


def write_figures(series: list, out_dir: str | Path) -> list[str]:
    """Draw both figures; return their paths."""
    error_path, estimate_path = figure_paths(out_dir)
    return [str(error_vs_travel(series, error_path)), str(estimates(series, estimate_path))]


def error_vs_travel(series: list, path: Path) -> Path:
    """Error (mm, log scale) against travel since contact (mm), one line per trial."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 5))
    colours = plt.cm.viridis(np.linspace(0, 1, max(len(series), 1)))
    for colour, trial in zip(colours, series):
        shown = np.isfinite(trial.error_mm) & np.isfinite(trial.travel_mm)
        ax.plot(trial.travel_mm[shown], np.maximum(trial.error_mm[shown], 1e-3), color=colour, lw=1,
                label=trial.name)
    ax.axhline(0.5, color="k", ls=":", lw=1)
    ax.axvline(5.0, color="grey", ls="--", lw=1)
    ax.set_yscale("log")
    ax.set_xlabel("travel since contact (mm)")
    ax.set_ylabel("contact point error (mm)")
    ax.set_title("shaft localizer: error against travel (dotted: 0.5 mm goal)")
    ax.legend(fontsize=6, ncol=2)
    return save_png(fig, path)


def estimates(series: list, path: Path) -> Path:
    """True contact paths (grey) and the estimates (coloured dots) in the whisker frame."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 5))
    colours = plt.cm.viridis(np.linspace(0, 1, max(len(series), 1)))
    for colour, trial in zip(colours, series):
        inside = np.isfinite(trial.travel_mm)
        ax.plot(trial.true_mm[inside, 0], trial.true_mm[inside, 1], color="0.6", lw=2)
        ax.plot(trial.estimate_mm[inside, 0], trial.estimate_mm[inside, 1], ".", ms=1.5,
                color=colour)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm, whisker frame)")
    ax.set_ylabel("y (mm)")
    ax.set_title("contact points: true (grey) and estimated (dots)")
    return save_png(fig, path)
