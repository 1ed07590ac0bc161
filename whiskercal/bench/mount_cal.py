"""The mount calibrated on the twin: how far the nominal mount and the fitted one are from the
true one, and what each does to a contour run's size.

For each seed the twin carries the sensor off the nominal mount by an error drawn within what a
real mount is off by (``ERROR_MM``, ``ERROR_DEG``); ``mount-cal`` presses on the twin's cylinder
and fits the mount with the (Y, Z) table's artifact (the recorded default grid, the level set
as its z lookup, the study's target), and with the z lookup alone (``tip_model`` z-lookup: the
paper's Y-only calibration). Each row: the true error, the fit's error against the true mount
and its stated standard deviation (the fit's error over it: ``sigmas``), and the contour loop
round the cylinder and the octagon driven through the nominal mount and through the fitted one:
the reconstruction's mean error and its size error (the mean signed distance of its points
from the true outline, outside positive), world frame, no alignment.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from whiskercal.mount import Mount

ERROR_MM, ERROR_DEG = 2.0, 3.0
NOMINAL = Mount(0.0, 30.0, 90.0)  # a sensor 30 mm to the flange's left, whisker along its y
SHAPES = ("cylinder", "octagon")


def run(quick: bool = False, progress=None, seeds=None, duration_s: float | None = None) -> dict:
    """Rows per seed and tip model (``quick``: one seed, the table only, 15 s runs)."""
    from whiskercal.bench.contour_target import calibrations_with_target

    seeds = seeds or ((1,) if quick else (1, 2, 3))
    duration_s = duration_s or (15.0 if quick else 30.0)
    rows = []
    with tempfile.TemporaryDirectory(prefix="whiskercal-mount-cal-") as folder:
        artifacts = calibrations_with_target(Path(folder), field_table=True)
        models = {"yz-table": artifacts["yz-table"]}
        if not quick:
            models["z-lookup"] = artifacts["z-lookup"]
        for seed in seeds:
            error = drawn_error(seed)
            for model, artifact in models.items():
                row = {"seed": seed, "tip_model": model, **calibrated(artifact, error, seed),
                       "duration_s": duration_s}
                for shape in SHAPES:
                    row[shape] = contour_sizes(artifact, shape, row, duration_s, seed)
                rows.append(row)
                if progress is not None:
                    progress(row)
    return {"rows": rows, "nominal": NOMINAL.as_dict(), "error_bounds": [ERROR_MM, ERROR_DEG]}


def drawn_error(seed: int) -> tuple[float, float, float]:
    """A mount error (dx mm, dy mm, dyaw deg) within the bounds, seeded."""
    rng = np.random.default_rng([seed, 44])
    dx, dy = rng.uniform(-ERROR_MM, ERROR_MM, 2)
    return float(dx), float(dy), float(rng.uniform(-ERROR_DEG, ERROR_DEG))


def calibrated(artifact, error, seed: int) -> dict:
    """mount-cal on the twin: the fit, its error against the true mount, and its sigmas."""
    from whiskercal.mountcal import Routine, mount_cal

    url = f"sim://cylinder?mount_error={error[0]},{error[1]},{error[2]}&seed={seed}"
    result = mount_cal(artifact, Routine(nominal=NOMINAL), url)
    summary = result.summary()
    fit_error, std = summary["truth"]["fit_error"], summary["mount"]["std"]
    tips = np.array([t.tip_mm - t.true_tip_mm for t in result.touches])
    return {"true_error": dict(zip(("x_mm", "y_mm", "yaw_deg"), error)),
            "fit": result.fit.mount.as_dict(), "fit_error": fit_error, "std": std,
            "sigmas": {key: abs(fit_error[key]) / std[key] for key in std},
            "tip_error_mm": summary["mount"]["tip_error_mm"],
            "touch_tip_rmse_mm": float(np.sqrt(np.mean(np.sum(tips ** 2, axis=1)))),
            "residual_rms_mm": summary["mount"]["residual_rms_mm"],
            "touches": len(result.touches), "kinds": summary["truth"]["kinds"],
            "true_mount": summary["truth"]["true_mount"]}


def contour_sizes(artifact, shape: str, row: dict, duration_s: float, seed: int) -> dict:
    """The loop round ``shape`` through the nominal mount and through the fitted one (the
    twin's sensor at the true mount both times): mean and size error (mm)."""
    from whiskercal.contour import contour_record, summarize

    true = Mount(**row["true_mount"])
    out = {}
    for name, mount in (("nominal", NOMINAL), ("calibrated", Mount(**row["fit"]))):
        offset = (true.x_mm - mount.x_mm, true.y_mm - mount.y_mm, true.yaw_deg - mount.yaw_deg)
        record = contour_record(shape, artifact, duration_s=duration_s, seed=seed,
                                mount=(mount, offset))
        summary = summarize(record)
        out[name] = {"mean_error_mm": summary["mean_error_mm"],
                     "size_error_mm": size_error_mm(record), "coverage": summary["coverage"]}
    return out


def size_error_mm(record) -> float:
    """Mean signed distance of the followed reconstruction from the true outline (mm, outside
    positive): what a mount or frame error shows as an object of the wrong size."""
    import shapely

    from whiskercal.contour.summary import followed
    from whiskercal.twin.outlines import recorded

    points = record.columns["estimate_mm"][followed(record)]
    ring = recorded(record.shape, record.core_mm, record.radius_mm).points()
    polygon = shapely.Polygon(ring)
    distance = shapely.distance(shapely.points(points), polygon.exterior)
    inside = shapely.contains_xy(polygon, points[:, 0], points[:, 1])
    return float(np.mean(np.where(inside, -distance, distance))) if len(points) else float("nan")
