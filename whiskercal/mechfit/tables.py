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
from whiskercal.mechfit.loadgrid import PAST_AXIS_ALPHAS_DEG, load_grid, past_axis_loads
from whiskercal.mechfit.tipcurve import TipFamily, tip_family
from whiskercal.mechfit.workers import run_calls_side_by_side
from whiskercal.model.field_table import FieldTipTable
from whiskercal.model.lookup import TipLookup
from whiskercal.twin.truth import first_branch

DEFAULT_SAMPLES = 20
DEFAULT_KIND = "cubic"
# Load tilts of the 2-D family, from the tip's normal toward the root (+) and away (-): friction
# up to mu 0.4 tilts the load by 22°, a plane tilted 40° from the tip's normal by 40°.
DEFAULT_BETAS_DEG = tuple(range(-40, 71, 10))
DEFAULT_SHAPE = (121, 121)
# the 2-D table is refined from DEFAULT_SHAPE, one axis at a time, while its cells read the
# model's own loads back further than this (mm, the 90th percentile: a tenth of the tip goal) and
# a refinement brings that at least REFINE_GAIN closer; each axis at most MAX_REFINE times as fine
READ_BACK_MM = 0.025
REFINE_GAIN = 1.5
MAX_REFINE = 8
# the z lookup's knots follow the model's own tip curve this closely (mm), a fifth of the tip
# goal; where they cannot (near a fold) its range ends short (``_followed_low``)
FOLLOW_TOLERANCE_MM = 0.05
NO_CURVE = "the fitted model's tip curve does not reach the grid's z range."
FOLLOW_BISECTIONS = 12
CHECK_POINTS = 2000
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
    deflection and its evenly spaced knots follow the model's tip curve within
    ``FOLLOW_TOLERANCE_MM`` (``_followed_low``); raises UsageError where it is not.
    """
    curve = _TipCurve(fit, family or tip_family(fit.suspension))
    # the one-to-one branch's ends within the grid's range
    low, high = max(curve.z_samples[-1], z_range_uT[0]), min(curve.z_samples[0], z_range_uT[1])
    if not low < high:
        raise UsageError(NO_CURVE)
    lookup = curve.lookup(low, high, samples, kind)
    if curve.lookup_error_mm(lookup) <= FOLLOW_TOLERANCE_MM:
        return lookup
    low = _followed_low(curve, low, high, samples, kind)
    if not low < high:
        raise UsageError("the fitted model's tip curve bends too fast in z for the lookup's knots.")
    return curve.lookup(low, high, samples, kind)


def interpolation_error_mm(fit: MechanicsFit, lookup: TipLookup) -> float:
    """The RMS distance (mm) between a z lookup and the tip curve of the model it was made from,
    over the lookup's range: its knots' interpolation error, which an estimate from the model's
    parameters alone does not see (near a fold it can be the larger part of a lookup's error)."""
    try:
        distances = _TipCurve(fit, tip_family(fit.suspension)).distances_mm(lookup)
    except UsageError:
        return math.nan
    return float(np.sqrt(np.mean(distances ** 2))) if len(distances) else 0.0


def with_interpolation_error(estimate_mm: float, fit: MechanicsFit, lookup: TipLookup) -> float:
    """A lookup's estimate from its model's parameters (mm RMS) with its interpolation error
    (``interpolation_error_mm``) added in quadrature: the two are independent."""
    interpolation = interpolation_error_mm(fit, lookup)
    return math.hypot(estimate_mm, interpolation) if math.isfinite(interpolation) else estimate_mm


class _TipCurve:
    """The model's frictionless tip curve on its one-to-one branch, as cubic splines in the tip
    slope (z and the tip are smooth in it, while the tip is not in z near a fold)."""

    def __init__(self, fit: MechanicsFit, family: TipFamily):
        from scipy.interpolate import CubicSpline

        z = fit.pose_map(family.pose)[:, 0]
        n = len(first_branch(z, z)[0])
        if n < 2:  # z does not fall from rest at all
            raise UsageError(NO_CURVE)
        self.z_samples, self.slope = z[:n], -family.tip_slope_rad[:n]
        self.z_of_slope = CubicSpline(self.slope, self.z_samples)
        self.tip_of_slope = CubicSpline(self.slope, family.tip_mm[:n], axis=0)
        dense = np.linspace(self.slope[0], self.slope[-1], CHECK_POINTS)
        self.dense_z, self.dense_tip = self.z_of_slope(dense), self.tip_of_slope(dense)

    def lookup(self, low: float, high: float, samples: int, kind: str) -> TipLookup:
        knots = np.linspace(low, high, samples)
        return TipLookup(knots, self.tips_at(knots), kind)

    def tips_at(self, z_uT: np.ndarray) -> np.ndarray:
        """The tips (n, 2) mm where the curve's z is each of ``z_uT`` (n,), by bisection in the
        slope (z falls with the slope's magnitude), every z's bracket halved at once: the
        spline is evaluated point by point either way, so each tip is the one a bisection of
        that z alone finds."""
        z_uT = np.asarray(z_uT, float)
        k = np.clip(np.searchsorted(-self.z_samples, -z_uT), 1, len(self.z_samples) - 1)
        lo, hi = self.slope[k - 1].copy(), self.slope[k].copy()
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            above = self.z_of_slope(mid) > z_uT
            lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
        return self.tip_of_slope(0.5 * (lo + hi))

    def distances_mm(self, lookup: TipLookup) -> np.ndarray:
        """Distances (mm) between the lookup and the curve at the dense points in its range."""
        inside = (self.dense_z >= lookup.z_min_uT) & (self.dense_z <= lookup.z_max_uT)
        return np.linalg.norm(lookup(self.dense_z[inside]) - self.dense_tip[inside], axis=1)

    def lookup_error_mm(self, lookup: TipLookup) -> float:
        """The largest distance (mm) between the lookup and the curve over the lookup's range."""
        distances = self.distances_mm(lookup)
        return float(np.max(distances)) if len(distances) else 0.0


def _followed_low(curve: _TipCurve, low: float, high: float, samples: int, kind: str) -> float:
    """The lowest z (µT) down to which evenly spaced knots follow the curve within the
    tolerance: near a fold the tip runs ever faster in z and the knots cut across the bend,
    so a lookup that ends a little short of the fold errs far less than one that reaches it."""
    followed, lost = high, low
    for _ in range(FOLLOW_BISECTIONS):
        mid = 0.5 * (followed + lost)
        if curve.lookup_error_mm(curve.lookup(mid, high, samples, kind)) <= FOLLOW_TOLERANCE_MM:
            followed = mid
        else:
            lost = mid
    return followed


# the past-axis loads, a third of the table's solves, in this many parts by direction: the
# parts and the rest run side by side (``workers``) and come back in order, the same rows
PAST_AXIS_PARTS = 4


def _family_or_none(suspension, beta_deg: float) -> TipFamily | None:
    """The tip-load family tilted ``beta_deg`` from the tip's normal; None where there is none."""
    try:
        return tip_family(suspension, math.radians(beta_deg))
    except UsageError:
        return None


def _solved_loads(suspension, betas_deg, space_fixed: bool):
    """The table's tip loads solved side by side: (the families by tilt, None where there is
    none; the space-fixed load grids, the past-axis loads in ``PAST_AXIS_PARTS`` parts)."""
    calls = [(_family_or_none, (suspension, beta)) for beta in betas_deg]
    if space_fixed:
        calls.append((load_grid, (suspension,)))
        calls += [(past_axis_loads, (suspension, tuple(part)))
                  for part in np.array_split(PAST_AXIS_ALPHAS_DEG, PAST_AXIS_PARTS)]
    solved = run_calls_side_by_side(calls)
    return solved[:len(betas_deg)], solved[len(betas_deg):]


def _family_points(fit: MechanicsFit, families):
    """(Y, Z) µT and tips mm of the tip-load families tilted from the tip's normal."""
    fields, tips = [], []
    for family in families:
        if family is None:
            continue
        fields.append(fit.pose_map(family.pose)[:, :2])
        tips.append(family.tip_mm)
    if not fields:
        raise UsageError("the fitted model has no tip-load family at any tilt from the tip's "
                         "normal, so no (Y, Z) table can be made from it.")
    return np.concatenate(fields), np.concatenate(tips)


def _load_grid_points(fit: MechanicsFit, load_grids):
    """(Y, Z) µT and tips mm of space-fixed tip loads, kept within the grid's pose envelope."""
    grids = [g for g in load_grids if len(g.pose)]
    if not grids:
        return np.zeros((0, 2)), np.zeros((0, 2))
    pose = np.concatenate([g.pose for g in grids])
    tips = np.concatenate([g.tip_mm for g in grids])
    limit = POSE_ENVELOPE * np.max(np.abs(fit.poses), axis=0)
    inside = np.all(np.abs(pose) <= limit, axis=1)
    return fit.pose_map(pose[inside])[:, :2], tips[inside]


def field_tip_table(fit: MechanicsFit, y_range_uT: tuple[float, float],
                    betas_deg=DEFAULT_BETAS_DEG, shape: tuple[int, int] | None = None,
                    space_fixed: bool = True) -> FieldTipTable:
    """The (Y, Z) -> tip table from the model's tip loads.

    Loads tilted by each of ``betas_deg`` from the tip's normal and, with ``space_fixed``, the
    space-fixed loads of ``loadgrid.py`` (pushes along and past the wire's axis included) within
    1.5 times the grid's largest pose. The fit must carry the Y and Z axes (in that order). Y
    spans ``y_range_uT``; Z spans what the loads reach there; ``shape`` as :func:`tabulate`
    takes it.
    """
    fields, tips = table_load_points(fit, y_range_uT, betas_deg, space_fixed)
    return tabulate(fields, tips, y_range_uT, shape)


def table_load_points(fit: MechanicsFit, y_range_uT: tuple[float, float],
                      betas_deg=DEFAULT_BETAS_DEG, space_fixed: bool = True):
    """The model's tip loads the table is made from: (Y, Z) µT (n, 2) and tips mm (n, 2)."""
    if fit.pose_map.coefficients.shape[1] < 2:
        raise UsageError("a (Y, Z) table needs a fit of both axes.")
    families, load_grids = _solved_loads(fit.suspension, betas_deg, space_fixed)
    fields, tips = _family_points(fit, families)
    if space_fixed:
        more = _load_grid_points(fit, load_grids)
        fields, tips = np.concatenate([fields, more[0]]), np.concatenate([tips, more[1]])
    inside = (fields[:, 0] >= y_range_uT[0] - 0.05 * np.ptp(y_range_uT)) & (fields[:, 0] <= 0.0)
    return fields[inside], tips[inside]


def tabulate(fields: np.ndarray, tips: np.ndarray, y_range_uT: tuple[float, float],
             shape: tuple[int, int] | None = None) -> FieldTipTable:
    """Tips resampled on a regular (Y, Z) grid by linear interpolation between the loads.

    ``shape`` (Y, Z cells); None: ``DEFAULT_SHAPE``, refined where its cells read the loads back
    coarsely (``_refined``)."""
    scale = np.ptp(fields, axis=0)
    interpolant = LinearNDInterpolator(fields / scale, tips)
    z_range = (float(fields[:, 1].min()), float(fields[:, 1].max()))

    def resampled(cells: tuple[int, int]) -> FieldTipTable:
        y_axis = np.linspace(y_range_uT[0], y_range_uT[1], cells[0])
        z_axis = np.linspace(z_range[0], z_range[1], cells[1])
        yy, zz = np.meshgrid(y_axis, z_axis, indexing="ij")
        return FieldTipTable(y_axis, z_axis, interpolant(np.stack([yy, zz], axis=-1) / scale))

    if shape is not None:
        return resampled(shape)
    return _refined(resampled, fields, tips)


def _refined(resampled, fields: np.ndarray, tips: np.ndarray) -> FieldTipTable:
    """The table at ``DEFAULT_SHAPE``, its cells halved along one axis at a time while they
    read the loads back further than ``READ_BACK_MM`` and halving them helps (``REFINE_GAIN``).

    A long, soft wire bent nearly square moves its tip by millimetres while Z barely changes,
    so cells sized for the default build read its deepest contacts millimetres off, where its
    model is right; where the loads fold (two tips at one reading) no cell size helps, and the
    estimate's ambiguity says so."""
    shape, table = DEFAULT_SHAPE, resampled(DEFAULT_SHAPE)
    error = read_back_mm(table, fields, tips)
    while error > READ_BACK_MM:
        candidates = []
        for cells in _halved(shape):
            finer = resampled(cells)
            candidates.append((read_back_mm(finer, fields, tips), cells, finer))
        if not candidates:
            break
        best = min(candidates, key=lambda candidate: candidate[0])
        if best[0] * REFINE_GAIN > error:
            break
        error, shape, table = best
    return table


def _halved(shape: tuple[int, int]) -> list[tuple[int, int]]:
    """``shape`` with either axis' cells halved, where that axis stays within ``MAX_REFINE``."""
    out = []
    for axis in (0, 1):
        cells = list(shape)
        cells[axis] = 2 * cells[axis] - 1
        if cells[axis] <= MAX_REFINE * (DEFAULT_SHAPE[axis] - 1) + 1:
            out.append((cells[0], cells[1]))
    return out


def read_back_mm(table: FieldTipTable, fields: np.ndarray, tips: np.ndarray) -> float:
    """How far the table reads the loads it was made from off their tips (mm, the 90th
    percentile of those it answers): the cells' own error, which the loads never show."""
    errors = np.hypot(*(table(fields[:, 0], fields[:, 1]) - tips).T)
    answered = errors[np.isfinite(errors)]
    return float(np.percentile(answered, 90)) if answered.size else math.inf
