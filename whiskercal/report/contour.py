"""The report of a contour run: its numbers (``contour.summary``), a figure of the contacts, a
figure of the controller's phases along the sensor's path, the phases' changes, a page.

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
from whiskercal.report.html import Section, figure, key_values, paragraph, render, table

# one colour per phase (follow.phases.Phase's names; "gave-up" in runs written before them)
PHASE_COLOURS = {"approach": "tab:blue", "press": "tab:cyan", "follow": "tab:green",
                 "round-edge": "tab:olive", "enter-corner": "tab:orange", "back-off": "tab:red",
                 "search": "tab:purple", "stopped": "black", "gave-up": "black"}


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


REPORT_FILES = ("contour.png", "phases.png", "contour.html", "contour.json")


def report_paths(out_dir: str | Path) -> list[Path]:
    """Where :func:`write_report` writes (:data:`REPORT_FILES`)."""
    return [Path(out_dir) / name for name in REPORT_FILES]


def draw_phases(run: ContourRunFile, path: Path) -> Path:
    """The sensor's path (its free tip's place, the undeflected whisker's end) coloured by the
    controller's phase, each change of phase marked where it happened, over the outline."""
    plt = pyplot()
    shape = outline_of(run)
    outline = np.vstack([shape.points(), shape.points()[:1]]) if shape.closed else shape.points()
    columns = run.columns
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.plot(*outline.T, color="k", lw=1, label="true outline")
    pose = columns["pose"]
    for phase in dict.fromkeys(columns["phase"]):
        mask = columns["phase"] == phase
        ax.scatter(pose[mask, 0], pose[mask, 1], s=1, color=PHASE_COLOURS.get(phase, "grey"),
                   label=f"sensor base: {phase}")
    changes = run.transitions.get("sample", np.zeros(0, int))
    if len(changes):
        ax.scatter(pose[changes, 0], pose[changes, 1], marker="|", color="k", s=30,
                   label="change of phase")
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm, world)")
    ax.set_ylabel("y (mm, world)")
    ax.set_title(f"{run.shape}: the controller's phase along the sensor's path")
    ax.legend(fontsize=7, loc="upper right", markerscale=6)
    return save_png(fig, path)


def transition_rows(run: ContourRunFile) -> list[dict]:
    """The changes of phase, one row each (time s, from, to, the rule)."""
    changes = run.transitions
    return [{"t_s": float(t), "from": source, "to": target, "rule": rule}
            for t, source, target, rule in zip(changes.get("t_s", ()), changes.get("source", ()),
                                               changes.get("target", ()), changes.get("rule", ()))]


def write_report(run: ContourRunFile, out_dir: str | Path) -> dict:
    """Write contour.png, phases.png, contour.html and contour.json into ``out_dir``; return the
    summary."""
    out_dir = ensure_dir(Path(out_dir))
    summary = summarize(run)
    png = draw(run, out_dir / "contour.png")
    phases_png = draw_phases(run, out_dir / "phases.png")
    page = render(f"Contour following: {run.shape}", [
        Section("Against the true outline", key_values({k: v for k, v in summary.items()})
                + paragraph("Distances in the world frame, with no alignment; the aligned mean "
                            "(scale, rotation, translation fitted, as the paper's evaluation did) "
                            "is for comparison with the paper only.")),
        Section("Figure", figure(png.read_bytes(), "contacts coloured by their distance to the outline")),
        Section("Phases", figure(phases_png.read_bytes(), "the controller's phase along the path")
                + table(transition_rows(run), ["t_s", "from", "to", "rule"]))])
    for name, text in (("contour.html", page), ("contour.json", json.dumps(summary, indent=2))):
        write_text(out_dir / name, text)
    summary["figures"] = [str(png), str(phases_png)]
    return summary
