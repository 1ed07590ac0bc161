"""How firmly the grid pins the suspension down, and the tip error that implies, without the truth.

A rod grid can fit equally well with different suspensions: the pose map absorbs part of the
root's compliance, and on some builds a k_θ·L/EI anywhere from a few to a million fits to the
noise. The tip curves of such fits differ by millimetres, so the fit alone cannot be trusted.
This module profiles the fit over k_θ·L/EI (each ratio held fixed, the stub and the
translational compliance refitted) and turns the profile into an error estimate:

- every profile point's tip curve is compared with the best fit's (RMS over the lookup's knots);
- its misfit Δχ² (in the residual variance of the best fit, so a model that misses the data by
  a constant factor is not over-trusted) says how plausible it is; a change is scaled to the
  edge of plausibility (Δχ² = 4, two standard errors) as the square root of 4 / Δχ², the
  linear-model relation between a parameter's offset, its misfit and the change it causes;
- the estimate is the largest scaled change, and infinite when a plausible fit's tip curve does
  not even cover the range (the grid does not identify the suspension) or when the best fit
  itself misses the grid by more than twice the noise (the model does not explain it);
- a local, linearized estimate (``local_estimate``) covers all three parameters at once and
  the data that pin them down tighter than the profile's steps (a tip sweep does); the larger
  of the two is reported, with the lookup's interpolation error against the model's own tip
  curve added in quadrature (``tables.with_interpolation_error``).

The profile doubles as a global search: when a profile point fits better than the local fit,
the fit is refined from there before anything is estimated.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from whiskercal.errors import UsageError
from whiskercal.mechfit.fieldmap import DEFAULT_DEGREE, MAX_SHIFT_ORDER, exponents
from whiskercal.mechfit.fit import (MAX_STUB_FRACTION, TRANS_SHARE_START, MechanicsFit, _Objective,
                                   fit_mechanics)
from whiskercal.mechfit.tables import (DEFAULT_KIND, DEFAULT_SAMPLES, monotone_z_range,
                                      with_interpolation_error, z_lookup)
from whiskercal.mechfit.tipcurve import tip_family
from whiskercal.mechfit.workers import run_side_by_side
from whiskercal.model.lookup import TipLookup

PROFILE_RATIOS = (1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0, 10000.0)
PLAUSIBLE_DELTA_CHI2 = 4.0   # two standard errors of one parameter
IGNORED_DELTA_CHI2 = 400.0   # twenty: a fit this far off says nothing about the best one
# A best fit whose residual is more than twice the noise (χ²/dof above 4) leaves something the
# model does not explain (a suspension outside its family, a pose map short of the field, a wrong
# trace length): not estimated.
MAX_CHI2_PER_DOF = 4.0
MIN_COVERAGE = 0.9           # share of the lookup's knots a plausible fit must also answer
PROFILE_EVALUATIONS = 60
COMPARISON_KNOTS = 41
# Step (in the fit's log and logit parameters) of the finite differences of the local estimate:
# large against the solver's tolerance, small against the parameters' own uncertainty.
LOCAL_STEP = 1e-3
LOCAL_MIN_COVERAGE = 0.5
# A χ² per degree of freedom this many of its standard deviations (√(2/dof)) above 1 tries a
# pose map one step richer (``_richer_map``).
RICHER_MAP_SIGMAS = 2.0
# Not beyond 4 (degree 5 was not needed on the family; docs/calibration.md).
MAX_MAP_DEGREE = 4
# At degree 4 the shift's order may rise from 2 to 4 (the whole polynomial): on a build whose
# root carries most of the compliance the root shifts by most of the magnet's gap, and a map
# quadratic in the shift misses its grid and sweep by many times the noise at the true poses.
MAX_MAP_SHIFT_ORDER = 4


@dataclass
class ProfilePoint:
    """One fixed k_θ·L/EI: its misfit relative to the best fit and its tip curve's change (mm)."""

    stiffness_ratio: float
    chi2: float
    lookup: TipLookup | None
    delta_chi2: float = math.nan
    tip_change_mm: float = math.nan
    theta: np.ndarray | None = None

    def row(self) -> dict:
        return {"stiffness_ratio": self.stiffness_ratio, "delta_chi2": self.delta_chi2,
                "tip_change_mm": self.tip_change_mm}


@dataclass
class MechanicsCalibration:
    """A mechanics-informed tip model with its own error estimate.

    Attributes
    ----------
    fit : MechanicsFit
    lookup : TipLookup
        z (µT) -> tip (mm) over the grid's z range where the model's z is one-to-one.
    one_to_one_z_uT : (float, float)
        The model's one-to-one z range from rest (µT), before the grid's range cuts it.
    chi2_per_dof : float
        Misfit of the best fit in the grid's standard errors (about 1 when the model and the
        noise explain the grid).
    estimated_tip_error_mm : float
        The larger of the profile's estimate and the local one, with the lookup's interpolation
        error in quadrature (mm); inf when the grid does not identify the suspension.
    profile : list of ProfilePoint
    local_tip_error_mm : float
        The linearized estimate alone (``local_estimate``), mm.
    sweep_points : int
        How many of the contacts fitted were the tip sweep's.
    """

    fit: MechanicsFit
    lookup: TipLookup
    one_to_one_z_uT: tuple[float, float]
    chi2_per_dof: float
    estimated_tip_error_mm: float
    profile: list[ProfilePoint] = field(default_factory=list)
    local_tip_error_mm: float = math.nan
    sweep_points: int = 0

    @property
    def stiffness_ratio(self) -> float:
        """The fitted k_θ·L/EI."""
        return 1.0 / self.fit.suspension.rot_compliance

    def plausible_ratios(self) -> tuple[float, float]:
        """The lowest and highest profiled k_θ·L/EI within two standard errors of the best."""
        ratios = [p.stiffness_ratio for p in self.profile
                  if p.delta_chi2 <= PLAUSIBLE_DELTA_CHI2] + [self.stiffness_ratio]
        return min(ratios), max(ratios)


def _theta_of(fit: MechanicsFit) -> np.ndarray:
    s = fit.suspension
    # the logistic's ends are reached in floating point: keep its inverse finite
    share = min(max(s.stub_mm / (s.trace_length_mm * MAX_STUB_FRACTION), 1e-12), 1.0 - 1e-12)
    return np.array([math.log(s.rot_compliance), math.log(s.trans_compliance),
                     math.log(share / (1.0 - share))])


class _Problem:
    """The grid and the weights every fit of one calibration shares."""

    def __init__(self, rod_center_mm, z_uT, rod_radius_mm, trace_length_mm, noise_uT, z_range,
                 sweep=None, degree=DEFAULT_DEGREE, shift_order=MAX_SHIFT_ORDER):
        self.degree, self.shift_order = degree, shift_order
        self.centers = np.asarray(rod_center_mm, float)
        self.sweep = np.zeros(len(self.centers), bool) if sweep is None else np.asarray(sweep, bool)
        self.fields = np.asarray(z_uT, float).reshape(-1, 1)
        self.radius, self.trace_mm = float(rod_radius_mm), float(trace_length_mm)
        self.noise = np.atleast_1d(float(noise_uT))
        self.z_range = z_range

    def objective(self) -> _Objective:
        return _Objective(self.trace_mm, self.centers, self.radius, self.fields, self.noise,
                          self.degree, self.sweep, self.shift_order)

    def terms(self) -> int:
        """The pose map's number of monomials."""
        return len(exponents(self.degree, self.shift_order))

    def dof(self) -> int:
        return max(len(self.centers) - 3 - self.terms(), 1)

    def richer(self) -> _Problem | None:
        """The same problem with the next richer pose map: one degree more up to
        :data:`MAX_MAP_DEGREE`, then the shift's order one more up to
        :data:`MAX_MAP_SHIFT_ORDER`; None past both."""
        richer = copy.copy(self)
        if self.degree < MAX_MAP_DEGREE:
            richer.degree = self.degree + 1
        elif self.shift_order < min(self.degree, MAX_MAP_SHIFT_ORDER):
            richer.shift_order = self.shift_order + 1
        else:
            return None
        return richer

    def as_fit(self, objective: _Objective, theta: np.ndarray) -> tuple[MechanicsFit, float]:
        """The fit at ``theta`` and its χ² (standard errors; a lost contact counts heavily)."""
        suspension, poses, pose_map, residual, scaled = objective.evaluate(theta)
        chi2 = float(np.sum(scaled ** 2))
        fit = MechanicsFit(suspension, pose_map, poses, residual,
                           np.sqrt(np.mean(residual ** 2, axis=0)), (0,), 0.0,
                           objective.evaluations)
        return fit, chi2

    def lookup(self, fit: MechanicsFit, samples: int = DEFAULT_SAMPLES,
               kind: str = DEFAULT_KIND) -> TipLookup | None:
        try:
            return z_lookup(fit, self.z_range, samples, kind)
        except UsageError:
            return None


def _profile_point(problem: _Problem, best: np.ndarray, ratio: float) -> ProfilePoint:
    objective = problem.objective()
    fixed = math.log(1.0 / ratio)

    def residual(free):
        return objective(np.array([fixed, *free]))

    start = np.array([best[1] + fixed - best[0], best[2]])
    result = least_squares(residual, start, diff_step=1e-4, max_nfev=PROFILE_EVALUATIONS)
    theta = np.array([fixed, *result.x])
    fit, chi2 = problem.as_fit(objective, theta)
    return ProfilePoint(ratio, chi2, problem.lookup(fit), theta=theta)


def _richer_map(problem: _Problem, fit: MechanicsFit, chi2: float, theta: np.ndarray):
    """With a tip sweep, the next richer pose map (``_Problem.richer``: a degree higher, then
    a higher order in the shift), while the fit leaves more than the noise and the richer map
    explains enough more to pay for its terms (Akaike: Δχ² > 2 per term).

    A degree-3 map misses the twin's field over a grid and a tip sweep (which takes the pose
    off the shaft contacts' path) by a fair share of the noise's variance, enough to bias the
    suspension, and degree 4 removes it (docs/calibration.md).
    (problem, fit, χ², theta), changed or not.
    """
    # only a tip sweep takes the pose off the shaft contacts' path, where the map falls short;
    # on a grid alone a misfit comes from elsewhere (the stage's position error on recorded
    # data), and a richer map absorbs it into the suspension (docs/calibration.md)
    while problem.sweep.any() and (richer := problem.richer()) is not None:
        dof = problem.dof()
        if chi2 / dof <= 1.0 + RICHER_MAP_SIGMAS * math.sqrt(2.0 / dof):
            break
        new_fit, new_chi2, new_theta = _refine(richer, theta)
        extra = richer.terms() - problem.terms()
        if not new_chi2 + 2.0 * extra < chi2:
            break
        problem, fit, chi2, theta = richer, new_fit, new_chi2, new_theta
    return problem, fit, chi2, theta


def _revive_collapsed_shift(problem: _Problem, fit: MechanicsFit, chi2: float,
                            theta: np.ndarray):
    """When the fit drove the translational compliance far below its start (a hundredth of
    the start's share of the rotational one), refine once more from that start; keep the
    result when it fits better. (fit, χ², theta), changed or not.

    As the compliance nears zero the shift, and the gradient of its log, vanish, and the
    optimizer cannot come back from there even when a lower minimum lies at a finite shift (the
    default sensor's simulated grid shows one: ``tests/mechfit``).
    """
    start_log_share = math.log(TRANS_SHARE_START)
    if theta[1] - theta[0] > start_log_share - math.log(100.0):
        return fit, chi2, theta
    start = theta.copy()
    start[1] = theta[0] + start_log_share
    revived, revived_chi2, revived_theta = _refine(problem, start)
    if revived_chi2 < chi2:
        return revived, revived_chi2, revived_theta
    return fit, chi2, theta


def _refine(problem: _Problem, theta: np.ndarray) -> tuple[MechanicsFit, float, np.ndarray]:
    objective = problem.objective()
    result = least_squares(objective, theta, diff_step=1e-4, xtol=1e-10, ftol=1e-10, max_nfev=200)
    return (*problem.as_fit(objective, result.x), result.x)


def tip_change_mm(base: TipLookup, other: TipLookup | None) -> float:
    """RMS distance (mm) between two lookups' tips over the base's range; inf when ``other``
    answers less than :data:`MIN_COVERAGE` of it."""
    knots = np.linspace(base.z_min_uT, base.z_max_uT, COMPARISON_KNOTS)
    if other is None:
        return math.inf
    inside = (knots >= other.z_min_uT) & (knots <= other.z_max_uT)
    if inside.mean() < MIN_COVERAGE:
        return math.inf
    change = base(knots[inside]) - other(knots[inside])
    return float(np.sqrt(np.mean(np.sum(change ** 2, axis=1))))


def knot_tips(lookup: TipLookup, knots: np.ndarray) -> np.ndarray:
    inside = (knots >= lookup.z_min_uT) & (knots <= lookup.z_max_uT)
    tips = np.full((len(knots), 2), np.nan)
    tips[inside] = lookup(knots[inside])
    return tips


def local_estimate(problem: _Problem, theta: np.ndarray, lookup: TipLookup, chi2: float,
                   samples: int = DEFAULT_SAMPLES, kind: str = DEFAULT_KIND) -> float:
    """The largest RMS tip change (mm) within two standard errors of the best fit, linearized.

    The profile steps k_θ·L/EI by factors of three; a grid and sweep that pin the suspension
    down far tighter than that leave every profile point implausible and say nothing. Here the
    misfit's curvature (JᵀJ of the residual in standard errors, the pose map refitted at each
    step) and the tip curve's slope D in all three parameters give the tip change at the edge
    of plausibility (Δχ² = 4 in the best fit's residual variance) in the worst direction:
    √(4 σ² λ_max(JᵀJ⁻¹ DᵀD) / K) over the K knots. Infinite when a step loses the tip curve.
    """
    objective = problem.objective()

    def lookup_at(step):
        return problem.lookup(problem.as_fit(objective, step)[0], samples, kind)

    return linearized_tip_change_mm(objective, lookup_at, theta, lookup,
                                    max(chi2 / problem.dof(), 1.0))


def linearized_tip_change_mm(residual, lookup_at, params: np.ndarray, lookup: TipLookup,
                             variance: float) -> float:
    """The largest RMS tip change (mm) of ``lookup`` at the edge of plausibility (Δχ² = 4, in
    units of the best fit's residual ``variance``), linearized by a step of each parameter:
    ``residual(params)`` in standard errors, ``lookup_at(params)`` the lookup there (None where
    there is none). Infinite when a step loses the tip curve, when under half the knots are
    answered throughout, or when the misfit has no curvature in some direction."""
    base = residual(params)
    knots = np.linspace(lookup.z_min_uT, lookup.z_max_uT, COMPARISON_KNOTS)
    tips = knot_tips(lookup, knots)
    jac, slopes = [], []
    for k in range(len(params)):
        step = params.copy()
        step[k] += LOCAL_STEP
        other = lookup_at(step)  # before the residual: the same warm starts as always
        if other is None:
            return math.inf
        jac.append((residual(step) - base) / LOCAL_STEP)
        slopes.append((knot_tips(other, knots) - tips) / LOCAL_STEP)
    # a step may move the end of the one-to-one range (a fold of z) past the last knots: the
    # change is taken where both answer, unless that is less than half the range
    known = np.all(np.isfinite(np.stack(slopes)), axis=(0, 2))
    if known.mean() < LOCAL_MIN_COVERAGE:
        return math.inf
    d = np.stack([s[known].ravel() for s in slopes], axis=1)
    curvature = np.stack(jac, axis=1)
    curvature = curvature.T @ curvature
    try:
        worst = np.max(np.real(np.linalg.eigvals(np.linalg.solve(curvature, d.T @ d))))
    except np.linalg.LinAlgError:
        return math.inf
    return float(math.sqrt(max(worst, 0.0) * PLAUSIBLE_DELTA_CHI2 * variance / known.sum()))


def profile_estimate(profile: list[ProfilePoint]) -> float:
    """The largest tip change scaled to the edge of plausibility (mm); see the module's text."""
    scaled = [0.0]
    for point in profile:
        if point.delta_chi2 > IGNORED_DELTA_CHI2:
            continue
        factor = math.sqrt(PLAUSIBLE_DELTA_CHI2 / max(point.delta_chi2, PLAUSIBLE_DELTA_CHI2))
        scaled.append(point.tip_change_mm * factor)
    return max(scaled)


def calibrate_mechanics(rod_center_mm, z_uT, rod_radius_mm: float, trace_length_mm: float,
                        noise_uT: float, samples: int = DEFAULT_SAMPLES,
                        kind: str = DEFAULT_KIND, sweep=None,
                        degree: int = DEFAULT_DEGREE) -> MechanicsCalibration:
    """Fit the mechanics to a rod grid's contacts, profile it, and build its z -> tip lookup.

    Parameters
    ----------
    rod_center_mm : ndarray (n, 2)
        Rod centres of the contacts, whisker frame, in the stage's visiting order.
    z_uT : ndarray (n,)
        Y minus the static reading, µT.
    rod_radius_mm, trace_length_mm : float
    noise_uT : float
        Typical standard error of a point's mean z, µT.
    sweep : ndarray (n,) of bool, optional
        Which contacts are the tip sweep's (the rod at the tip); none by default.

    Raises
    ------
    UsageError
        Too few contacts for the pose map, or no tip curve over the grid's z range.
    """
    z = np.asarray(z_uT, float)
    on_grid = z if sweep is None else z[~np.asarray(sweep, bool)]  # the range calibrated
    problem = _Problem(rod_center_mm, z, rod_radius_mm, trace_length_mm, noise_uT,
                       (float(on_grid.min()), float(on_grid.max())), sweep, degree)
    theta = _theta_of(fit_mechanics(problem.centers, z, problem.radius, problem.trace_mm,
                                     problem.noise, degree, sweep=problem.sweep))
    fit, chi2 = problem.as_fit(problem.objective(), theta)
    fit, chi2, theta = _revive_collapsed_shift(problem, fit, chi2, theta)
    problem, fit, chi2, theta = _richer_map(problem, fit, chi2, theta)
    # each point its own objective and warm starts: side by side, the same points
    profile = run_side_by_side(_profile_point, [(problem, theta, ratio)
                                                for ratio in PROFILE_RATIOS])
    best_profile = min(profile, key=lambda p: p.chi2)
    if best_profile.chi2 < chi2:
        start = best_profile.theta.copy()  # its own stub and translational compliance too
        refined, refined_chi2, refined_theta = _refine(problem, start)
        if refined_chi2 < chi2:
            fit, chi2, theta = refined, refined_chi2, refined_theta
    lookup = problem.lookup(fit, samples, kind)
    if lookup is None:
        raise UsageError("the fitted mechanics' tip curve does not reach the grid's z range.")
    variance = max(chi2 / problem.dof(), 1.0)
    for point in profile:
        point.delta_chi2 = max(point.chi2 - chi2, 0.0) / variance
        point.tip_change_mm = tip_change_mm(lookup, point.lookup)
    family_z = fit.pose_map(tip_family(fit.suspension).pose)[:, 0]
    chi2_per_dof = chi2 / problem.dof()
    local = local_estimate(problem, theta, lookup, chi2, samples, kind)
    estimate = with_interpolation_error(max(profile_estimate(profile), local), fit, lookup) \
        if chi2_per_dof <= MAX_CHI2_PER_DOF else math.inf
    return MechanicsCalibration(fit, lookup, monotone_z_range(family_z), chi2_per_dof, estimate,
                                profile, local, int(problem.sweep.sum()))
