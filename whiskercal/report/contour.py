"""The report of a contour run: its numbers (``contour.summary``), a figure, a page.

docs/contour.md explains each number.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from whiskercal.artifacts.contour_run import ContourRunFile
from whiskercal.atomic import write_text
from whiskercal.contour.metrics import distances_mm
from whiskercal.contour.summary import followed, outline_of, summarize
from whiskercal.paths import ensure_dir
from whiskercal.plotting import pyplot, save_png
from whiskercal.report.html import Section, figure, key_values, paragraph, render


def draw(run: ContourRunFile, path: Path) -> Path:
    """The outline, the contacts coloured by their distance to it, slips marked."""
    plt = pyplot()
    shape = outline_of(run)
    outline = np.vstack([shape.points(), shape.points()[:1]]) if shape.closed else shape.points()
    mask, columns = followed(run), run.columns
    points = columns["estimate_mm"][mask]
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.plot(*outline.T, color="k", lw=1, label="true outline")
    if len(points):
        errors = distances_mm(points, outline_of(run).dense())[0]
        shown = ax.scatter(*points.T, c=errors, s=3, cmap="viridis", vmin=0, vmax=max(1.0, float(np.percentile(errors, 99))))
        fig.colorbar(shown, ax=ax, label="distance to the outline (mm)")
    slips = columns["estimate_mm"][columns["slip"].astype(bool) & np.isfinite(columns["estimate_mm"][:, 0])]
    if len(slips):
        ax.scatter(*slips.T, marker="x", color="r", s=40, label="slip")
    ax.plot(*columns["pose"][:, :2].T, color="grey", lw=0.5, label="sensor base")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm, world)")
    ax.set_ylabel("y (mm, world)")
    ax.set_title(f"{run.shape}: contacts against the true outline, no alignment")
    ax.legend(fontsize=7, loc="upper right")
    return save_png(fig, path)


REPORT_FILES = ("contour.png", "contour.html", "contour.json")


def report_paths(out_dir: str | Path) -> list[Path]:
    """Where :func:`write_report` writes (:data:`REPORT_FILES`)."""
    return [Path(out_dir) / name for name in REPORT_FILES]


def write_report(run: ContourRunFile, out_dir: str | Path) -> dict:
    """Write contour.png, contour.html and contour.json into ``out_dir``; return the summary."""
    out_dir = ensure_dir(Path(out_dir))
    summary = summarize(run)
    png = draw(run, out_dir / "contour.png")
    page = render(f"Contour following: {run.shape}", [
        Section("Against the true outline", key_values({k: v for k, v in summary.items()})
                + paragraph("Distances in the world frame, with no alignment; the aligned mean "
                            "(scale, rotation, translation fitted, as the paper's evaluation did) "
                            "is for comparison with the paper only.")),
        Section("Figure", figure(png.read_bytes(), "contacts coloured by their distance to the outline"))])
    for name, text in (("contour.html", page), ("contour.json", json.dumps(summary, indent=2))):
        write_text(out_dir / name, text)
    summary["figures"] = [str(png)]
    return summary
