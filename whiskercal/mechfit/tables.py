"""The runtime's fast paths from a fitted model: z -> tip (1-D) and (Y, Z) -> tip (2-D).

The 1-D table is the model layer's own `TipLookup` (evenly spaced z knots, piecewise
polynomials), so the runtime evaluates it exactly as it evaluates a level-set lookup. The 2-D
table samples the tip over a regular (Y, Z) grid from the family of tip loads tilted from the
tip's normal, and is read by bilinear interpolation.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import LinearNDInterpolator

from whiskercal.errors import UsageError
from whiskercal.mechfit.fit import MechanicsFit
from whiskercal.mechfit.loadgrid import load_grid, past_axis_loads
from whiskercal.mechfit.tipcurve import TipFamily, tip_family
from whiskercal.model.field_table import FieldTipTable
from whiskercal.model.lookup import TipLookup
from whiskercal.twin.truth import first_branch

DEFAULT_SAMPLES = 20
DEFAULT_KIND = "cubic"
# Load tilts of the 2-D family, from the tip's normal toward the root (+) and away (-): friction
# up to mu 0.4 tilts the load by 22°, a plane tilted 40° from the tip's normal by 40°.
DEFAULT_BETAS_DEG = tuple(range(-40, 71, 10))
DEFAULT_SHAPE = (121, 121)
# space-fixed loads are kept where the root's pose stays within this multiple of the grid's
# largest (the pose map is trusted near what the grid showed it)
POSE_ENVELOPE = 1.5


def monotone_z_range(z_uT: np.ndarray) -> tuple[float, float]:
    """The z range (µT) from rest over which z falls strictly along the curve (one-to-one)."""
    branch, _ = first_branch(z_uT, z_uT)
    return float(branch[-1]), float(z_uT[0])


def z_lookup(fit: MechanicsFit, z_range_uT: tuple[float, float], samples: int = DEFAULT_SAMPLES,
             kind: str = DEFAULT_KIND, family: TipFamily | None = None) -> TipLookup:
    """The 1-D lookup z (µT, Y axis) -> tip (mm) for frictionless tip contact.

    Covers ``z_range_uT`` (the grid's range) where the model's z is one-to-one in the tip's
    deflection; raises UsageError where it is not.
    """
    family = family or tip_family(fit.suspension)
    z = fit.pose_map(family.pose)[:, 0]
    low, high = monotone_z_range(z)
    low, high = max(low, z_range_uT[0]), min(high, z_range_uT[1])
    if not low < high:
        raise UsageError("the fitted model's tip curve does not reach the grid's z range.")
    knots = np.linspace(low, high, samples)
    order = np.argsort(z[: _monotone_count(z)])
    zs, tips = z[order], family.tip_mm[order]
    knot_tips = np.column_stack([np.interp(knots, zs, tips[:, k]) for k in range(2)])
    # a denser resampling in slope before interpolating keeps the knots' tips exact enough
    return TipLookup(knots, _refine(fit, family, knots, knot_tips), kind)


def _monotone_count(z: np.ndarray) -> int:
    return len(first_branch(z, z)[0])


def _refine(fit: MechanicsFit, family: TipFamily, knots: np.ndarray, tips: np.ndarray) -> np.ndarray:
    """Tips at the knots by cubic interpolation in the tip slope (z and tip are smooth in it)."""
    from scipy.interpolate import CubicSpline

    n = _monotone_count(fit.pose_map(family.pose)[:, 0])
    slope = family.tip_slope_rad[:n]
    z = fit.pose_map(family.pose[:n])[:, 0]
    z_of_slope = CubicSpline(-slope, z)
    tip_of_slope = CubicSpline(-slope, family.tip_mm[:n], axis=0)
    out = []
    for knot, guess in zip(knots, tips):
        grid = -slope
        k = int(np.clip(np.searchsorted(-z, -knot), 1, len(z) - 1))
        lo, hi = grid[k - 1], grid[k]
        for _ in range(60):  # bisection on the spline: z falls with the slope's magnitude
            mid = 0.5 * (lo + hi)
            if z_of_slope(mid) > knot:
                lo = mid
            else:
                hi = mid
        out.append(tip_of_slope(0.5 * (lo + hi)))
    return np.array(out)


def _family_points(fit: MechanicsFit, betas_deg):
    """(Y, Z) µT and tips mm of the tip-load families tilted from the tip's normal."""
    fields, tips = [], []
    for beta in betas_deg:
        try:
            family = tip_family(fit.suspension, math.radians(beta))
        except UsageError:
            continue
        fields.append(fit.pose_map(family.pose)[:, :2])
        tips.append(family.tip_mm)
    return np.concatenate(fields), np.concatenate(tips)


def _load_grid_points(fit: MechanicsFit):
    """(Y, Z) µT and tips mm of space-fixed tip loads, kept within the grid's pose envelope."""
    grids = (load_grid(fit.suspension), past_axis_loads(fit.suspension))
    pose = np.concatenate([g.pose for g in grids if len(g.pose)])
    tips = np.concatenate([g.tip_mm for g in grids if len(g.pose)])
    limit = POSE_ENVELOPE * np.max(np.abs(fit.poses), axis=0)
    inside = np.all(np.abs(pose) <= limit, axis=1)
    return fit.pose_map(pose[inside])[:, :2], tips[inside]


def field_tip_table(fit: MechanicsFit, y_range_uT: tuple[float, float],
                    betas_deg=DEFAULT_BETAS_DEG, shape: tuple[int, int] = DEFAULT_SHAPE,
                    space_fixed: bool = True) -> FieldTipTable:
    """The (Y, Z) -> tip table from the model's tip loads.

    Loads tilted by each of ``betas_deg`` from the tip's normal and, with ``space_fixed``, the
    space-fixed loads of ``loadgrid.py`` (pushes along and past the wire's axis included) within
    1.5 times the grid's largest pose. The fit must carry the Y and Z axes (in that order). Y
    spans ``y_range_uT``; Z spans what the loads reach there.
    """
    fields, tips = table_load_points(fit, y_range_uT, betas_deg, space_fixed)
    return tabulate(fields, tips, y_range_uT, shape)


def table_load_points(fit: MechanicsFit, y_range_uT: tuple[float, float],
                      betas_deg=DEFAULT_BETAS_DEG, space_fixed: bool = True):
    """The model's tip loads the table is made from: (Y, Z) µT (n, 2) and tips mm (n, 2)."""
    if fit.pose_map.coefficients.shape[1] < 2:
        raise UsageError("a (Y, Z) table needs a fit of both axes.")
    fields, tips = _family_points(fit, betas_deg)
    if space_fixed:
        more = _load_grid_points(fit)
        fields, tips = np.concatenate([fields, more[0]]), np.concatenate([tips, more[1]])
    inside = (fields[:, 0] >= y_range_uT[0] - 0.05 * np.ptp(y_range_uT)) & (fields[:, 0] <= 0.0)
    return fields[inside], tips[inside]


def tabulate(fields: np.ndarray, tips: np.ndarray, y_range_uT: tuple[float, float],
             shape: tuple[int, int] = DEFAULT_SHAPE) -> FieldTipTable:
    """Tips resampled on a regular (Y, Z) grid by linear interpolation between the loads."""
    scale = np.ptp(fields, axis=0)
    interpolant = LinearNDInterpolator(fields / scale, tips)
    y_axis = np.linspace(y_range_uT[0], y_range_uT[1], shape[0])
    z_axis = np.linspace(fields[:, 1].min(), fields[:, 1].max(), shape[1])
    yy, zz = np.meshgrid(y_axis, z_axis, indexing="ij")
    table = interpolant(np.stack([yy, zz], axis=-1) / scale)
    return FieldTipTable(y_axis, z_axis, table)
