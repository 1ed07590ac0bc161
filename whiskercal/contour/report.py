"""The report of a contour run: metrics against the true outline, a figure, a page.

Only the samples the controller was following with (phase "follow") count as reconstructed
contacts. docs/contour.md explains each number.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from whiskercal.artifacts.contour_run import ContourRunFile
from whiskercal.atomic import atomic_path
from whiskercal.contour.metrics import contour_metrics, distances_mm
from whiskercal.paths import ensure_dir
from whiskercal.plotting import pyplot, save_png
from whiskercal.report.html import Section, figure, key_values, paragraph, render
from whiskercal.twin.outlines import Outline


def outline_of(run: ContourRunFile) -> Outline:
    """The run's object, as recorded."""
    return Outline(run.shape, np.asarray(run.core_mm, float), run.radius_mm)


def followed(run: ContourRunFile) -> np.ndarray:
    """Mask of the samples with a reconstructed contact while following."""
    estimate = run.columns["estimate_mm"]
    return (run.columns["phase"] == "follow") & np.isfinite(estimate[:, 0])


def time_to_go_round_s(run: ContourRunFile) -> float:
    """Robot time (s) until the contacts have swept 360° about the object's centre (NaN: never)."""
    mask = followed(run)
    if mask.sum() < 2:
        return float("nan")
    points = run.columns["estimate_mm"][mask] - np.mean(run.core_mm, axis=0)
    swept = np.abs(np.unwrap(np.arctan2(points[:, 1], points[:, 0])) - math.atan2(points[0, 1], points[0, 0]))
    done = np.flatnonzero(swept >= 2 * math.pi)
    return float(run.columns["t_s"][mask][done[0]] - run.columns["t_s"][mask][0]) if done.size else float("nan")


def summarize(run: ContourRunFile) -> dict:
    """Every number of the report (JSON-able)."""
    mask, columns = followed(run), run.columns
    metrics = contour_metrics(columns["estimate_mm"][mask], outline_of(run).dense())
    duration = float(columns["t_s"][-1]) if len(columns["t_s"]) else 0.0
    return {"shape": run.shape, "sensor_id": run.sensor_id, "target_z_uT": run.target_z_uT,
            **metrics, "slips": int(np.sum(columns["slip"])),
            "contacts_lost": int(np.sum((columns["phase"][1:] == "back-off") & (columns["phase"][:-1] == "follow"))),
            "time_to_go_round_s": time_to_go_round_s(run), "duration_s": duration,
            "follow_share": float(np.mean(mask)) if len(mask) else 0.0,
            "z_mean_follow_uT": float(np.mean(columns["z_uT"][mask])) if mask.any() else float("nan"),
            "tip_contact_share": float(np.mean(columns["kind"][mask] == "tip")) if mask.any() else float("nan"),
            "control_ms_mean": 1e3 * float(np.mean(columns["control_s"])) if len(columns["control_s"]) else 0.0,
            "control_ms_max": 1e3 * float(np.max(columns["control_s"])) if len(columns["control_s"]) else 0.0,
            "realtime_factor": duration / run.wall_s if run.wall_s > 0 else float("nan"),
            "complete": run.complete, "seed": run.seed}


def draw(run: ContourRunFile, path: Path) -> Path:
    """The outline, the contacts coloured by their distance to it, slips marked."""
    plt = pyplot()
    outline = outline_of(run).points()
    mask, columns = followed(run), run.columns
    points = columns["estimate_mm"][mask]
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.plot(*np.vstack([outline, outline[:1]]).T, color="k", lw=1, label="true outline")
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
        with atomic_path(out_dir / name) as scratch:
            scratch.write_text(text, encoding="utf-8")
    summary["figures"] = [str(png)]
    return summary
