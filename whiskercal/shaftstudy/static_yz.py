"""A static shaft contact from the 3-axis field: Y and Z together, no motion, against the filter.

A contact on the shaft turns and shifts the suspension; the magnet's Y and Z axes see the two in
different proportions (on the default sensor Z/Y falls from about 0.7 near the root to 0.1 near
the tip), so one sample's (Y, Z) pair may name the contact point without any motion. Here both
axes of the raw grid are fitted over its contact points (degree 8, the shaft surface's middle
patch; only inside the grid), and each sample of a shaft study is localized on its own by
solving (Y, Z) = (f_Y(p), f_Z(p)) for p: the best point of a 0.5 mm grid of candidates, then
Gauss-Newton. Errors are against the twin's true contact point, beside the motion-based
localizer's (``runtime_shaft``) on the same samples. docs/shaft.md has the measurements.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.artifacts.shaft_study import read_shaft_study
from whiskercal.model.calibrate import contact_mask
from whiskercal.model.grid_contacts import SHAFT_DEGREE, degree_for, grid_contacts
from whiskercal.model.surface import fit_fixed
from whiskercal.rig.overload import SENSOR_AXIS_Y
from whiskercal.runtime_shaft import SAMPLE_NOISE_UT
from whiskercal.shaftstudy.report import track_trial

SENSOR_AXIS_Z = 2
SAMPLE_NOISE_Z_UT = 9.5
"""One sample's Z noise, µT (the grid's per-point standard deviation of Z: 8.5-11 µT)."""
MIN_Y_UT = 300.0
"""|Y - static| (µT) from which a sample is localized: below, both axes are mostly noise."""
REST_SAMPLES = 30  # samples at a trial's start, before contact, that give Z's reading at rest


@dataclass
class StaticRow:
    """One trial: median and 90th-percentile error (mm) of the static (Y, Z) solution and the
    motion-based localizer's median on the same samples (those with an estimate)."""

    name: str
    radial_mm: float
    approach_deg: float
    samples: int
    static_median_mm: float
    static_p90_mm: float
    motion_median_mm: float

    def as_dict(self) -> dict:
        """The JSON form."""
        return asdict(self)


class StaticLocalizer:
    """(Y, Z) -> contact point on two surfaces of the grid (mm, whisker frame)."""

    def __init__(self, raw, trace_length_mm: float) -> None:
        field = raw.field_mean_uT - raw.baseline_before_uT
        used = contact_mask(field[:, SENSOR_AXIS_Y], raw.z_sem_uT)
        points, y = grid_contacts(raw.rod_center_mm, field[:, SENSOR_AXIS_Y], raw.z_sem_uT,
                                  raw.rod_radius_mm)
        z = field[used, SENSOR_AXIS_Z]
        degree = degree_for(len(y), SHAFT_DEGREE)
        self.f_y, self.f_z = fit_fixed(points, y, degree)[0], fit_fixed(points, z, degree)[0]
        misfit_y = float(np.sqrt(np.mean((self.f_y(points) - y) ** 2)))
        misfit_z = float(np.sqrt(np.mean((self.f_z(points) - z) ** 2)))
        self.sd = np.array([np.hypot(SAMPLE_NOISE_UT, misfit_y),
                            np.hypot(SAMPLE_NOISE_Z_UT, misfit_z)])
        radial = np.hypot(*points.T)
        x, across = np.meshgrid(np.arange(0.5 * radial.min(), trace_length_mm, 0.5),
                                np.arange(0.5, -0.6 * trace_length_mm, -0.5))
        candidates = np.column_stack([x.ravel(), across.ravel()])
        reach = np.hypot(*candidates.T)
        self.candidates = candidates[(reach > radial.min() - 1.0) & (reach < radial.max() + 1.0)]
        self.table = np.column_stack([self.f_y(self.candidates), self.f_z(self.candidates)])

    def locate(self, y_uT: float, z_uT: float) -> np.ndarray:
        """The contact point (mm) whose (Y, Z) is closest to one sample's, in noise units."""
        measured = np.array([y_uT, z_uT])
        cost = np.sum(((self.table - measured) / self.sd) ** 2, axis=1)
        point = self.candidates[int(np.argmin(cost))].copy()
        for _ in range(4):
            residual = (measured - [float(self.f_y(point)), float(self.f_z(point))]) / self.sd
            jacobian = np.vstack([self.f_y.gradient(point), self.f_z.gradient(point)]) \
                / self.sd[:, None]
            try:
                point = point + np.linalg.solve(jacobian.T @ jacobian + 1e-9 * np.eye(2),
                                                jacobian.T @ residual)
            except np.linalg.LinAlgError:
                break
        return point


def static_trial(localizer: StaticLocalizer, trial, calibration) -> StaticRow:
    """The static (Y, Z) solution and the motion-based localizer on one trial's samples."""
    field = np.asarray(trial.stream["field_uT"], float)
    y = np.asarray(trial.stream["z_uT"], float)
    z = field[:, SENSOR_AXIS_Z] - float(np.mean(field[:REST_SAMPLES, SENSOR_AXIS_Z]))
    true = np.asarray(trial.truth["contact_mm"], float)
    chosen = np.flatnonzero((np.abs(y) > MIN_Y_UT) & np.isfinite(true[:, 0]))
    static = np.array([localizer.locate(y[i], z[i]) for i in chosen]).reshape(-1, 2)
    static_error = np.hypot(*(static - true[chosen]).T)
    motion_error = track_trial(calibration, trial).error_mm[chosen]
    finite = np.isfinite(motion_error)
    return StaticRow(trial.name, float(trial.radial_mm),
                     float(trial.attrs.get("approach_deg", np.nan)), int(chosen.size),
                     float(np.median(static_error)) if chosen.size else np.nan,
                     float(np.percentile(static_error, 90)) if chosen.size else np.nan,
                     float(np.median(motion_error[finite])) if finite.any() else np.nan)


def static_study(raw_grid_path, study_path, calibration) -> list[StaticRow]:
    """Every trial of a shaft study, static (Y, Z) against motion (twin runs only)."""
    localizer = StaticLocalizer(read_raw_grid(raw_grid_path),
                                float(calibration.data.trace_length_mm))
    return [static_trial(localizer, trial, calibration)
            for trial in read_shaft_study(study_path).trials if trial.truth is not None]


def static_figure(rows: list[StaticRow], path):
    """Median error (mm, log) against radial distance: static (Y, Z) and motion-based."""
    from whiskercal.plotting import pyplot, save_png

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for approach, marker in ((0.0, "o"), (30.0, "s")):
        mine = [r for r in rows if r.approach_deg == approach]
        radial = [r.radial_mm for r in mine]
        ax.plot(radial, [r.static_median_mm for r in mine], marker, color="C3",
                label=f"static, Y and Z ({approach:g}°)")
        ax.plot(radial, [r.static_p90_mm for r in mine], marker, color="C3", alpha=0.3,
                label=f"static, 90th percentile ({approach:g}°)")
        ax.plot(radial, [r.motion_median_mm for r in mine], marker, color="C0",
                label=f"motion, z alone ({approach:g}°)")
    ax.axhline(0.5, color="k", ls=":", lw=1)
    ax.set_yscale("log")
    ax.set_xlabel("radial distance of the contact from the root (mm)")
    ax.set_ylabel("contact point error (mm)")
    ax.set_title("a static shaft contact from Y and Z against the motion-based localizer")
    ax.legend(fontsize=7, ncol=2)
    return save_png(fig, path)
