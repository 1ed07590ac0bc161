"""Figures of one calibration, drawn to PNG bytes (matplotlib's Agg backend, no display).

Each function takes the artifact's content (:class:`~whiskercal.artifacts.calibration.CalibrationData`)
and what else it needs, and returns the PNG as bytes, ready to be embedded in the HTML report.
"""

from __future__ import annotations

import io

import numpy as np

from whiskercal.artifacts.calibration import CalibrationData, lookup_of, problem_of
from whiskercal.model.errors import TraceError
from whiskercal.model.trace import trace_paper
from whiskercal.plotting import pyplot

TRACED_LEVEL_SETS = 7
PATH_STEP_MM = 0.05  # fine enough to draw, far coarser than the paper's 1e-3 mm


def to_png(fig) -> bytes:
    """The figure as PNG bytes; the figure is closed."""
    plt = pyplot()
    buffer = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buffer, format="png", dpi=100)
    plt.close(fig)
    return buffer.getvalue()


def _hull(ax, data: CalibrationData) -> None:
    hull = np.vstack([data.hull_vertices_mm, data.hull_vertices_mm[:1]])
    ax.plot(hull[:, 0], hull[:, 1], "k-", lw=0.8, label="calibrated domain (hull)")


def grid_residuals(data: CalibrationData, contact_mm: np.ndarray, residual_uT: np.ndarray,
                   unused_mm: np.ndarray | None = None) -> bytes:
    """The fitted contact points coloured by the residual f - z (µT); unused grid points greyed."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 5))
    if unused_mm is not None and len(unused_mm):
        ax.plot(unused_mm[:, 0], unused_mm[:, 1], "x", color="0.6", ms=5, label="not fitted")
    # a robust colour scale: one point off by much would wash out the others
    limit = float(np.nanpercentile(np.abs(residual_uT), 98)) or 1.0
    dots = ax.scatter(contact_mm[:, 0], contact_mm[:, 1], c=residual_uT, cmap="coolwarm",
                      vmin=-limit, vmax=limit, s=28, edgecolors="k", linewidths=0.3)
    fig.colorbar(dots, ax=ax, label="residual f(x, y) - z (µT)")
    _hull(ax, data)
    ax.plot(0, 0, "k^", label="root")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"grid and fit residuals (RMS {np.sqrt(np.mean(residual_uT ** 2)):.1f} µT)")
    ax.legend(fontsize=7, loc="lower left")
    return to_png(fig)


def _traced_paths(problem, z_values: np.ndarray) -> list[tuple[float, np.ndarray | None, np.ndarray | None]]:
    traced = []
    for z in z_values:
        try:
            result = trace_paper(problem, float(z), step_mm=PATH_STEP_MM, keep_path=True)
        except TraceError:
            traced.append((float(z), None, None))
            continue
        path = np.vstack([result.root_mm, result.path_mm, result.tip_mm])
        traced.append((float(z), path, result.tip_mm))
    return traced


def level_sets(data: CalibrationData) -> bytes:
    """Contours of f over the domain, level sets traced from the root, and the lookup's tips."""
    plt = pyplot()
    problem = problem_of(data)
    fig, ax = plt.subplots(figsize=(7, 5.5))
    low, high = data.hull_vertices_mm.min(axis=0) - 5, data.hull_vertices_mm.max(axis=0) + 5
    xs, ys = np.meshgrid(np.linspace(max(low[0], 1.0), high[0], 160), np.linspace(low[1], high[1], 140))
    inside = problem.domain.contains(np.stack([xs, ys], axis=-1))
    surface = np.where(inside, problem.surface(np.stack([xs, ys], axis=-1)), np.nan)
    ax.contourf(xs, ys, surface, levels=20, cmap="viridis", alpha=0.6)
    _hull(ax, data)
    z_values = np.linspace(data.lookup_z_uT[0], data.lookup_z_uT[-1], TRACED_LEVEL_SETS)
    for z, path, tip in _traced_paths(problem, z_values):
        if path is not None:
            ax.plot(path[:, 0], path[:, 1], "-", lw=1.2, label=f"z = {z:.0f} µT")
            ax.plot(*tip, "o", color="k", ms=4)
    ax.plot(data.lookup_tip_mm[:, 0], data.lookup_tip_mm[:, 1], "r.", ms=5, label="lookup tips")
    ax.plot(0, 0, "k^")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title("level sets f = z traced from the root, and the traced tips")
    ax.legend(fontsize=6, loc="lower left", ncol=2)
    return to_png(fig)


def lookup_curve(data: CalibrationData, truth=None) -> bytes:
    """Tip x and y against z: the lookup's samples and interpolant, the twin's truth and the error.

    ``truth`` is a :class:`~whiskercal.fit.truth.TruthComparison` of this artifact's lookup, or
    None.
    """
    plt = pyplot()
    lookup = lookup_of(data)
    z = np.linspace(lookup.z_min_uT, lookup.z_max_uT, 400)
    tips = lookup(z)
    rows = 2 if truth is not None else 1
    fig, axes = plt.subplots(rows, 1, figsize=(7, 3.4 * rows), squeeze=False)
    ax = axes[0, 0]
    for axis, name in ((0, "x"), (1, "y")):
        ax.plot(z, tips[:, axis], "-", color=f"C{axis}", label=f"lookup {name} ({lookup.kind})")
        ax.plot(lookup.z_knots_uT, lookup.tips_mm[:, axis], "o", color=f"C{axis}", ms=4)
        if truth is not None:
            ax.plot(truth.z_uT, truth.true_tip_mm[:, axis], "k--", lw=0.8,
                    label="twin truth" if axis == 0 else None)
    ax.set_xlabel("z (µT)")
    ax.set_ylabel("tip (mm)")
    ax.set_title(f"lookup: {len(lookup.z_knots_uT)} samples, {lookup.kind}")
    ax.legend(fontsize=7)
    if truth is not None:
        axes[1, 0].plot(truth.z_uT, truth.error_mm, "C3.-")
        axes[1, 0].set_xlabel("z (µT)")
        axes[1, 0].set_ylabel("|lookup - truth| (mm)")
        axes[1, 0].set_title(f"lookup against the twin's true tip: RMS "
                             f"{truth.rmse_mm:.3f} mm, max {truth.max_mm:.3f} mm")
    return to_png(fig)
