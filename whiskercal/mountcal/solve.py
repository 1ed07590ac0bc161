"""The mount from the touches: least squares on each pressed tip's distance from the surface.

Touch k: the end effector at E_k (the robot's pose), the runtime's tip p_k in the base frame.
The mount m = (x, y, yaw) puts that tip at w_k = E_k ∘ m ∘ p_k in the world, where it lies on
the cylinder; the residual is its signed distance from the surface. Levenberg-Marquardt
(scipy's least_squares) from the nominal mount.

The covariance has two parts. The scatter: the residuals' variance (their sum of squares over
n - 3) times (JᵀJ)⁻¹. The calibration: a tip the artifact reads off by its estimated tip error
σ (the fit's own estimate, no truth), the same for every press that repeats a contact's
geometry in the sensor's frame (its tilt and depth: the lookup's error depends on where the tip
is and how it is pushed, not on where the robot stands), independent between geometries; such
an error repeats at every station, where the scatter cannot see it, and moves the fit as
A C Aᵀ σ² with A = (JᵀJ)⁻¹Jᵀ and C_kl = 1 for touches of one geometry. A bias common to every
touch that is no tip error (the cylinder's radius off) is in neither.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.mount import Mount
from whiskercal.mountcal.plan import Cylinder

MIN_TOUCHES = 6
"""Fewer touches than this leave too few degrees of freedom for the residual to say anything
about the uncertainty of three unknowns."""
MAX_CONDITION = 1e5
"""The touches' Jacobian (columns mm per mm, mm per 100 mm·rad) conditioned worse than this
does not tell the three apart: degenerate geometry."""


@dataclass(frozen=True)
class MountFit:
    """The fitted mount, its covariance ((x mm, y mm, yaw deg)²: the scatter's and the
    calibration's, module docstring), the residuals (mm) and the tip error assumed (mm)."""

    mount: Mount
    scatter: np.ndarray
    calibration: np.ndarray
    residuals_mm: np.ndarray
    condition: float
    tip_error_mm: float = 0.0

    @property
    def covariance(self) -> np.ndarray:
        """Both parts together."""
        return self.scatter + self.calibration

    @property
    def std(self) -> tuple[float, float, float]:
        """One standard deviation of x (mm), y (mm), yaw (deg)."""
        return _std(self.covariance)

    def summary(self) -> dict:
        """JSON-able."""
        keys = ("x_mm", "y_mm", "yaw_deg")
        return {**self.mount.as_dict(), "std": dict(zip(keys, self.std)),
                "std_scatter": dict(zip(keys, _std(self.scatter))),
                "std_calibration": dict(zip(keys, _std(self.calibration))),
                "tip_error_mm": self.tip_error_mm,
                "residual_rms_mm": float(np.sqrt(np.mean(self.residuals_mm ** 2))),
                "residual_max_mm": float(np.max(np.abs(self.residuals_mm))),
                "touches": int(len(self.residuals_mm)), "condition": self.condition}


def _std(covariance: np.ndarray) -> tuple[float, float, float]:
    return tuple(float(math.sqrt(max(value, 0.0))) for value in np.diag(covariance))


def _residuals(params, effector, tips, cylinder: Cylinder) -> np.ndarray:
    mount = Mount(params[0], params[1], math.degrees(params[2]))
    return cylinder.distance_mm(mount.to_world(effector, tips))


def solve_mount(effector_poses, tips_mm, cylinder: Cylinder, start: Mount = Mount(),
                tip_error_mm: float = 0.0, geometries=None) -> MountFit:
    """The mount that puts every tip on the cylinder (module docstring); ``tip_error_mm``: the
    artifact's estimated tip error, shared by the touches of one of ``geometries`` (a label
    per touch; None: each its own). UsageError for too few touches or touches that do not
    identify x, y and yaw."""
    from scipy.optimize import least_squares

    effector = np.asarray(effector_poses, float).reshape(-1, 3)
    tips = np.asarray(tips_mm, float).reshape(-1, 2)
    if len(tips) < MIN_TOUCHES:
        raise UsageError(f"{len(tips)} touches cannot fit a mount with its uncertainty: "
                         f"at least {MIN_TOUCHES} are needed")
    start_params = np.array([start.x_mm, start.y_mm, math.radians(start.yaw_deg)])
    found = least_squares(_residuals, start_params, args=(effector, tips, cylinder), method="lm")
    jacobian = found.jac
    scaled = jacobian * np.array([1.0, 1.0, 0.01])  # yaw per 0.01 rad: ~1 mm at 100 mm
    condition = float(np.linalg.cond(scaled))
    if not np.isfinite(condition) or condition > MAX_CONDITION:
        raise UsageError("the touches do not tell the mount's x, y and yaw apart (degenerate "
                         "geometry): press at several tilts and depths, from more than one side")
    inverse = np.linalg.inv(jacobian.T @ jacobian)
    scatter = float(found.fun @ found.fun) / (len(tips) - 3) * inverse
    labels = np.arange(len(tips)) if geometries is None else np.asarray(geometries)
    shared = (labels[:, None] == labels[None, :]).astype(float)
    lever = inverse @ jacobian.T
    calibration = tip_error_mm ** 2 * lever @ shared @ lever.T
    to_deg = np.diag([1.0, 1.0, math.degrees(1.0)])
    x, y, yaw = found.x
    return MountFit(Mount(float(x), float(y), math.degrees(float(yaw))), to_deg @ scatter @ to_deg,
                    to_deg @ calibration @ to_deg, np.asarray(found.fun), condition,
                    float(tip_error_mm))
