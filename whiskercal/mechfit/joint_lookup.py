"""The (Y, Z) joint fit's own z lookup, and how far it can be trusted, without the truth.

Y alone leaves the suspension loosely pinned on some builds (a thin 120 mm wire's Y fits sat
7-9 mm from the true tips on two seeds of three); the chip's Z axis sees the root's shift and
turn apart, and the joint fit (``magnetfit``) pins them down: its frictionless tip curve is the
better z lookup wherever it explains the grid (docs/calibration.md). Its error is estimated as
the Y fit's is (``identify``), over all ten outer parameters (the map's strengths follow by
least squares): the larger of

- the local estimate: the misfit's curvature and the tip curve's slope in each parameter, the
  worst tip change at the edge of plausibility (Δχ² = 4), linearized;
- the profile's: the fits with k_θ·L/EI held four times off either way (``ratio_profile``),
  their tip changes scaled to the edge of plausibility, which catches a second minimum the
  linearization cannot see;

with the lookup's interpolation error against its own model's tip curve added in quadrature
(``tables.with_interpolation_error``).

Both assume the model explains the grid with the stage where the fit put it: where its χ² per
degree of freedom lies significantly above 1 (``magnetfit.significant_misfit``), or its stage
offset sits at its bound (``magnetfit.offset_at_bound``: the stage making up for a suspension
in the wrong basin), the estimate is not made (infinite; the tip model then stays the Y
fit's).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.mechfit.fit import MechanicsFit
from whiskercal.mechfit.identify import (ProfilePoint, linearized_tip_change_mm,
                                         profile_estimate, tip_change_mm)
from whiskercal.mechfit.magnetfit import (degrees_of_freedom, fit_at, joint_objective,
                                          offset_at_bound, significant_misfit)
from whiskercal.mechfit.tables import (DEFAULT_KIND, DEFAULT_SAMPLES, with_interpolation_error,
                                      z_lookup)
from whiskercal.model.lookup import TipLookup


@dataclass(frozen=True)
class JointLookup:
    """The joint fit's z (Y, µT) -> tip (mm) lookup and its estimated RMS tip error (mm), with
    the local and the profile's parts."""

    lookup: TipLookup
    estimated_tip_error_mm: float
    local_mm: float
    profile_mm: float

    def metrics(self) -> dict:
        """The estimate and its parts, NaN where not made."""
        return {key: value if math.isfinite(value) else math.nan for key, value in (
            ("estimated_tip_error_mm", self.estimated_tip_error_mm),
            ("local_estimated_tip_error_mm", self.local_mm),
            ("profile_estimated_tip_error_mm", self.profile_mm))}


def joint_z_lookup(fit: MechanicsFit, rod_center_mm, fields_uT, noise_uT, rod_radius_mm: float,
                   trace_length_mm: float, z_range_uT: tuple[float, float], sweep=None,
                   samples: int = DEFAULT_SAMPLES, kind: str = DEFAULT_KIND) -> JointLookup | None:
    """The z lookup of a joint fit (``magnetfit.fit_mechanics_magnet``, on these contacts) over
    ``z_range_uT``, and its estimate (infinite where the fit leaves a significant misfit against
    the noise ``noise_uT``, Y and Z µT); None when its tip curve does not reach the range.

    A fit whose χ²/dof lies above the noise's spread is a local minimum or a model that misses
    something, and the parameters' uncertainty does not bound its error: such a fit can put its
    lookup millimetres from the truth under a far smaller estimate (a case is in
    docs/research/2026-11-29-calibration.md).
    """
    lookup = _lookup(fit, z_range_uT, samples, kind)
    if lookup is None:
        return None
    fields = np.asarray(fields_uT, float)
    joint = joint_objective(np.asarray(rod_center_mm, float), fields,
                            np.broadcast_to(np.asarray(noise_uT, float), (2,)), rod_radius_mm,
                            trace_length_mm, fit.pose_map.orders, sweep)
    params = np.asarray(fit.starts[-1]["params"], float)
    chi2 = float(np.sum(joint(params) ** 2))
    counts = (fields.size, len(fit.pose_map.orders), len(joint.offset_axes))
    if significant_misfit(chi2, *counts) or offset_at_bound(fit.starts[-1]["stage_offset_mm"]):
        return JointLookup(lookup, math.inf, math.inf, math.inf)
    variance = max(chi2 / degrees_of_freedom(*counts), 1.0)

    def lookup_at(step):
        return _lookup(fit_at(joint, step, fit), z_range_uT, samples, kind)

    local = linearized_tip_change_mm(joint, lookup_at, params, lookup, variance)
    profile = _profile_mm(lookup_at, fit, lookup, variance)
    return JointLookup(lookup, with_interpolation_error(max(local, profile), fit, lookup), local,
                       profile)


def _lookup(fit, z_range_uT, samples, kind) -> TipLookup | None:
    try:
        return z_lookup(fit, z_range_uT, samples, kind)
    except UsageError:
        return None


def _profile_mm(lookup_at, fit, lookup, variance) -> float:
    """``identify.profile_estimate`` over the joint fit's held-ratio fits."""
    info = fit.starts[-1]
    points = []
    for row, held in zip(info.get("ratio_profile", []), info.get("ratio_profile_params", [])):
        other = lookup_at(np.asarray(held, float))
        points.append(ProfilePoint(row["stiffness_ratio"], math.nan, other,
                                   delta_chi2=max(row["delta_chi2"], 0.0) / variance,
                                   tip_change_mm=tip_change_mm(lookup, other)))
    return profile_estimate(points)
