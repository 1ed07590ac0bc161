"""Figures of the study (PNG, matplotlib's Agg backend: no display needed).

- ``errors.png``: the distribution of the distance-to-plane error per depth, raw and filtered;
- ``estimates.png``: the tip estimates against each trial's plane line, in the whisker frame;
- ``z_over_time.png``: z over each slide with detected slips marked, failing trials in red.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from whiskercal.plotting import pyplot, save_png
from whiskercal.study.analysis import TrialMetrics, TrialSeries, distance_to_line_mm


def _errors(series: TrialSeries, which: str) -> np.ndarray:
    tips = series.raw_tip_mm if which == "raw" else series.filtered_tip_mm
    error = distance_to_line_mm(tips, series.plane_point_mm, series.plane_normal)
    error = error[np.asarray(series.contact, bool)]
    return error[np.isfinite(error)]


def error_distribution(series: list[TrialSeries], rows: list[TrialMetrics], path: Path) -> Path:
    """Box plots of raw and filtered errors per depth; failing depths are labelled."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 4.5))
    failing = {row.depth_mm for row in rows if row.failing}
    positions = np.arange(len(series), dtype=float)
    for offset, which, color in ((-0.18, "raw", "tab:gray"), (0.18, "filtered", "tab:blue")):
        data = [errors if errors.size else np.array([np.nan])
                for errors in (_errors(s, which) for s in series)]
        parts = ax.boxplot(data, positions=positions + offset, widths=0.3, showfliers=False,
                           patch_artist=True)
        for box in parts["boxes"]:
            box.set_facecolor(color)
            box.set_alpha(0.6)
        ax.plot([], [], color=color, linewidth=8, alpha=0.6, label=which)
    ax.set_xticks(positions)
    ax.set_xticklabels([f"{s.depth_mm:g}" + (" ✗" if s.depth_mm in failing else "") for s in series])
    ax.set_xlabel("contact distance (mm); ✗ failing")
    ax.set_ylabel("distance to the plane (mm)")
    ax.set_yscale("log")
    ax.legend()
    ax.set_title("Tip error against the plane per depth")
    return save_png(fig, path)


def estimates_against_plane(series: list[TrialSeries], path: Path) -> Path:
    """Raw and filtered tip estimates over each trial's plane line (whisker frame)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 7))
    colors = plt.cm.viridis(np.linspace(0, 1, max(len(series), 1)))
    for s, color in zip(series, colors):
        _plane_segment(ax, s, color)
        contact = np.asarray(s.contact, bool)
        ax.plot(*s.raw_tip_mm[contact].T, ".", color=color, markersize=1, alpha=0.2)
        ax.plot(*s.filtered_tip_mm[contact].T, "-", color=color, linewidth=1.2,
                label=f"{s.depth_mm:g} mm")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm, whisker frame)")
    ax.set_ylabel("y (mm)")
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title("Estimates (dots raw, lines filtered) against the plane lines (dashed)")
    return save_png(fig, path)


def _plane_segment(ax, s: TrialSeries, color) -> None:
    """The plane's line near the trial's estimates, dashed."""
    if not len(s.plane_point_mm):
        return
    point, normal = s.plane_point_mm[0], s.plane_normal[0]
    direction = np.array([normal[1], -normal[0]])
    tips = s.raw_tip_mm[np.all(np.isfinite(s.raw_tip_mm), axis=1)]
    centre = point + direction * (direction @ (tips.mean(axis=0) - point)) if len(tips) else point
    ends = centre + np.outer([-25.0, 25.0], direction)
    ax.plot(ends[:, 0], ends[:, 1], "--", color=color, linewidth=0.8)


def z_over_time(series: list[TrialSeries], rows: list[TrialMetrics], path: Path) -> Path:
    """z over each slide, slips marked, one panel per trial."""
    plt = pyplot()
    by_depth = {row.depth_mm: row for row in rows}
    fig, axes = plt.subplots(len(series), 1, figsize=(9, 1.6 * len(series) + 0.6), sharex=True,
                             squeeze=False)
    for ax, s in zip(axes[:, 0], series):
        row = by_depth[s.depth_mm]
        t = s.t_s - s.t_s[0] if len(s.t_s) else s.t_s
        ax.plot(t, s.z_uT, color="tab:red" if row.failing else "tab:blue", linewidth=0.8)
        slips = np.asarray(row.slip_indices, int)
        ax.plot(t[slips], s.z_uT[slips], "v", color="black", markersize=5)
        label = f"{s.depth_mm:g} mm" + (" failing" if row.failing else "")
        ax.set_ylabel("z (µT)", fontsize=7)
        ax.text(0.01, 0.1, f"{label}, {row.n_slips} slips", transform=ax.transAxes, fontsize=8)
    axes[-1, 0].set_xlabel("time in the slide (s)")
    fig.suptitle("Deflection z over each slide (▼ detected slips)")
    return save_png(fig, path)





def write_figures(series: list[TrialSeries], rows: list[TrialMetrics], out_dir: Path) -> list[Path]:
    """Draw the three figures into ``out_dir``; returns their paths."""
    errors, estimates, over_time = figure_paths(out_dir)
    return [error_distribution(series, rows, errors),
            estimates_against_plane(series, estimates),
            z_over_time(series, rows, over_time)]


def figure_paths(out_dir: Path) -> list[Path]:
    """Where :func:`write_figures` draws: errors.png, estimates.png, z_over_time.png."""
    return [Path(out_dir) / name for name in ("errors.png", "estimates.png", "z_over_time.png")]
