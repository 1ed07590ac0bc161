"""How far a reconstruction's points lie from an object's outline (mm), under a given pose or a
fitted one (docs/evaluate.md).

For each point, the distance to the continuous outline placed at the pose, in the points' frame:
``mean_mm``, ``std_mm``, ``median_mm``, ``p95_mm``, ``max_mm``; and ``coverage``, the share of
the outline's length within :data:`COVERAGE_RADIUS_MM` of some point. ``none`` places the
outline at the given pose; ``rigid`` fits the pose; ``similarity`` fits a free scale too, the
paper's metric, and is always shown beside the rigid figures: a free scale lays an outline of
the wrong size onto the points, so its figures alone would hide a size error.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from whiskercal.contour.outline_spec import SpecOutline
from whiskercal.contour.points import PointSet
from whiskercal.contour.pose_fit import FITS, Pose, distances_mm, fit_rigid, fit_similarity
from whiskercal.errors import UsageError

COVERAGE_RADIUS_MM = 2.0
_COVERAGE_STEP_MM = 0.1  # the outline sampled this finely (stated size) for its coverage
PAPER_METRIC = "the paper's metric: the outline's size fitted freely, which hides a size error"
FILES = {"json": "evaluation.json", "png": "evaluation.png"}


@dataclass
class Evaluation:
    """The figures (``summary``, JSON-able), the poses they were measured at, and the points."""

    summary: dict
    poses: dict[str, Pose] = field(default_factory=dict)
    points_mm: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    outline: SpecOutline | None = None


def evaluate(points: PointSet, outline: SpecOutline, fit: str = "rigid",
             pose: Pose | None = None) -> Evaluation:
    """The figures of ``points`` against ``outline`` (module docstring). ``pose``: where the
    outline lies under ``none`` (None: centred at the origin, unturned), a fit's start otherwise.
    Raises ``pose_fit.FitRefusedError`` for a fit that degenerates."""
    if fit not in FITS:
        raise UsageError(f"--fit must be one of {', '.join(FITS)}, not {fit!r}")
    xy = points.xy_mm
    if fit == "none":
        poses = {"none": pose or Pose()}
    else:
        poses = {"rigid": fit_rigid(xy, outline, pose)}
        if fit == "similarity":
            poses["similarity"] = fit_similarity(xy, outline, poses["rigid"])
    summary = {"points": int(len(xy)), "skipped": points.skipped, "source": points.source,
               "outline": outline.describe(), "fit": fit}
    for name, placed in poses.items():
        summary[name] = figures(xy, outline, placed)
    if "similarity" in summary:
        summary["similarity"] = {"metric": PAPER_METRIC, "scale": poses["similarity"].scale,
                                 **summary["similarity"]}
    return Evaluation(summary, poses, xy, outline)


def figures(points_mm: np.ndarray, outline: SpecOutline, pose: Pose) -> dict:
    """The distances' statistics (mm), the coverage and the pose, for one placement."""
    distance = distances_mm(points_mm, outline, pose)
    return {"pose": pose.describe(), "mean_mm": float(np.mean(distance)),
            "std_mm": float(np.std(distance)), "median_mm": float(np.median(distance)),
            "p95_mm": float(np.percentile(distance, 95)), "max_mm": float(np.max(distance)),
            "coverage": coverage(points_mm, outline, pose)}


def coverage(points_mm: np.ndarray, outline: SpecOutline, pose: Pose) -> float:
    """Share of the outline's length (placed at ``pose``) within COVERAGE_RADIUS_MM of a point."""
    import shapely

    along = np.arange(0.0, outline.length_mm, _COVERAGE_STEP_MM) + _COVERAGE_STEP_MM / 2
    samples = shapely.get_coordinates(shapely.line_interpolate_point(outline.geometry, along))
    distance, _ = cKDTree(points_mm).query(pose.to_points(samples), distance_upper_bound=COVERAGE_RADIUS_MM)
    return float(np.mean(np.isfinite(distance)))


def parse_pose(text: str | None) -> Pose | None:
    """``x,y,deg`` (mm, mm, degrees) as a Pose; None stays None."""
    from whiskercal.checks import number

    if text is None:
        return None
    cells = str(text).split(",")
    if len(cells) != 3:
        raise UsageError(f"--pose must be x,y,deg (mm, mm, degrees), not {text!r}")
    x, y = (number(cell, f"--pose {axis}", unit="mm") for axis, cell in zip("xy", cells))
    return Pose(x, y, math.radians(number(cells[2], "--pose deg", low=-360.0, high=360.0)))


def write_evaluation(out_dir: str | Path, evaluation: Evaluation) -> dict[str, Path]:
    """evaluation.json and evaluation.png in ``out_dir`` (created), each written atomically."""
    from whiskercal.atomic import write_text
    from whiskercal.jsontools import jsonable
    from whiskercal.paths import ensure_dir

    ensure_dir(out_dir)
    paths = {key: Path(out_dir) / name for key, name in FILES.items()}
    write_text(paths["json"], json.dumps(evaluation.summary, default=jsonable, indent=2) + "\n")
    plot_evaluation(paths["png"], evaluation)
    return paths


def plot_evaluation(path: Path, evaluation: Evaluation) -> Path:
    """The points and the outline at each placement (the rigid or given one solid, the scaled
    one dashed), to scale."""
    from whiskercal.plotting import pyplot, save_png

    plt = pyplot()
    fig, axes = plt.subplots(figsize=(7, 7))
    points = evaluation.points_mm
    axes.plot(points[:, 0], points[:, 1], ".", ms=1.5, color="tab:red", label="points")
    styles = {"none": "-", "rigid": "-", "similarity": "--"}
    for name, pose in evaluation.poses.items():
        ring = pose.to_points(evaluation.outline.vertices_mm)
        mean = evaluation.summary[name]["mean_mm"]
        label = f"outline, {name}" + (f" (scale {pose.scale:.4g})" if name == "similarity" else "")
        axes.plot(ring[:, 0], ring[:, 1], styles[name], lw=1.0, label=f"{label}: mean {mean:.3g} mm")
    axes.set_aspect("equal", adjustable="datalim")
    axes.set_xlabel("x (mm)")
    axes.set_ylabel("y (mm)")
    axes.set_title(evaluation.summary["outline"]["spec"], fontsize=9)
    axes.legend(loc="best", fontsize=8)
    return save_png(fig, path)
