"""The mechanics and the magnet's pose map fitted jointly to the grid's Y and Z.

The polynomial fit (``fit.py``) identifies the suspension from Y; its pose map cannot be trusted
off the shaft-contact manifold. Here the suspension starts from that fit, the magnet map
(``magnetmap.py``) is fitted to both axes on its poses, and then both are refined together: the
outer least squares runs over the three mechanical parameters, the stage's constant offset (the
rods' places as the grid saw them, ``stage_offset_axes``) and the map's seven geometric ones,
the map's strengths follow by linear least squares at every evaluation (variable projection),
from two starts (a Y fit's suspension as it is, and with the usual translational compliance),
the better kept; a Y fit made here first, then the Y fit given (the z lookup's mechanics), then
the generic starts, until the best has settled: explained the grid (within twice the noise)
with its stage offset inside the bounds (``_start_groups``, ``_settled``). A refinement whose
offset runs into its bound is ended there (``_stop_at_bound``).
With a tip sweep, where the best still leaves more than the noise, one more multipole order is
tried from it and kept when it pays for its term (the builds whose root turns furthest, stiff
wires and stiff roots need it; the cases are in docs/research/2026-11-29-calibration.md).
A group's refinements (and the polish's) are independent, each with its own objective, and run
side by side on the CPUs there are (``workers``), which leaves the result as it was.
The rod contacts are solved only when the mechanics or the offset change (a finite-difference
step in a geometric parameter reuses the last poses), so a refinement costs a few grid solves an
iteration.
"""

from __future__ import annotations

import copy
import time
from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from whiskercal.errors import UsageError
from whiskercal.mechfit.fit import (MAX_STUB_FRACTION, TRANS_SHARE_START, MechanicsFit,
                                    _Objective, _theta_start, fit_mechanics)
from whiskercal.mechfit.magnetmap import (DEFAULT_ORDERS, MagnetPoseMap, _linear_strengths,
                                          fit_magnet_map, relative_basis)
from whiskercal.mechfit.workers import run_side_by_side

JOINT_EVALUATIONS = 300
# residual RMS (in standard errors) above which the fit tries the generic starts too
UNEXPLAINED_RATIO = 2.0
# the identification test: k_θ·L/EI held at these multiples of the best fit's
PROFILE_FACTORS = (0.25, 4.0)
PROFILE_EVALUATIONS = 120
# a χ² per degree of freedom this many of its standard deviations (√(2/dof)) above 1 tries one
# more multipole order (as ``identify.RICHER_MAP_SIGMAS`` does for the polynomial map)
RICHER_ORDER_SIGMAS = 2.0
# the highest multipole order the fit grows to: a soft root's large shifts and turns need the
# sixth (the 45 mm build on k_θ·L/EI 0.98: χ²/dof 1.29 at order 5, 1.06 at 6; docs/calibration.md)
MAX_ORDER = 6
# the largest stage offset (mm, per axis) the joint fit may find: a few belt dead bands. Its
# parameter is the offset in these units, bounded to ±1 in the least squares, so a trial step
# cannot carry a rod millimetres off, onto the rigid stub (which the contact solver refuses)
MAX_STAGE_OFFSET_MM = 0.1
# an offset parameter this close to its bound (in units of MAX_STAGE_OFFSET_MM) is at it
OFFSET_AT_BOUND = 0.99
# a refinement whose offset sits at its bound this many iterations running is ended there
BOUND_PATIENCE = 5
# a chosen fit leaving a significant misfit with a tip sweep is refined again from its own
# mechanics with k_θ·L/EI at these multiples (the ratio a grid pins least), the map fitted
# afresh, while that lowers χ² by more than POLISH_GAIN, at most POLISH_PASSES times, each
# refinement on at most POLISH_EVALUATIONS (enough for a start this near a minimum to reach it)
POLISH_FACTORS = (0.8, 1.25)
POLISH_GAIN = 1.0
POLISH_PASSES = 3
POLISH_EVALUATIONS = 50
# the chosen refinement is started again from where it stopped (the trust region and the
# finite-difference Jacobian afresh) while that lowers χ² by more than RESTART_GAIN, at most
# RESTART_PASSES times: least squares on these solves stalls short of the minimum at a place
# that moves with the BLAS kernel (docs/research/2026-12-02-kernels.md)
RESTART_GAIN = 0.1
RESTART_PASSES = 4
# the mechanics (3) and the map's geometry (7), the stage offset's apart
NONLINEAR_PARAMETERS = 10
# the generic starts' EI/(L·k_θ): the Y fit's decades and 0.3, for soft roots whose minimum has
# a narrow basin (reached from a start near it, not from a decade away, where the fit stops in
# another minimum far above the noise or a sweep contact leaves the rod)
JOINT_ROT_COMPLIANCE_STARTS = (0.01, 0.1, 0.3, 1.0)


class _JointObjective:
    """Residuals (standard errors) of (mechanics theta (3), the stage offset (one per axis in
    ``offset_axes``, in units of MAX_STAGE_OFFSET_MM), geometry (7)); poses cached per mechanics
    and offset."""

    def __init__(self, mechanics: _Objective, fields, weights, orders, offset_axes=()):
        self.mechanics, self.fields, self.weights, self.orders = mechanics, fields, weights, orders
        self.offset_axes = tuple(offset_axes)
        self.recorded_centers = mechanics.centers.copy()
        self._key, self._solved = None, None

    @property
    def solved_count(self) -> int:
        """How many of the outer parameters need the contacts solved again: theta's and the
        offset's (the map's geometry reuses the poses)."""
        return 3 + len(self.offset_axes)

    def stage_offset_mm(self, params: np.ndarray) -> np.ndarray:
        """Where the rods sat less where the stage recorded them (x, y) mm, of ``params``."""
        offset = np.zeros(2)
        offset[list(self.offset_axes)] = MAX_STAGE_OFFSET_MM * params[3:self.solved_count]
        return offset

    def bounds(self, count: int) -> tuple[np.ndarray, np.ndarray]:
        """The least squares' bounds on ``count`` outer parameters: the offset's only."""
        high = np.full(count, np.inf)
        high[3:self.solved_count] = 1.0
        return -high, high

    def geometry(self, params: np.ndarray) -> np.ndarray:
        return params[self.solved_count:]

    def poses(self, params: np.ndarray):
        key = params[:self.solved_count]
        if self._key is None or not np.array_equal(key, self._key):
            self.mechanics.centers = self.recorded_centers + self.stage_offset_mm(params)
            self._solved = self.mechanics.solve(params[:3])
            self._key = key.copy()
        return self._solved

    def evaluate(self, params: np.ndarray):
        suspension, poses, in_contact = self.poses(params)
        basis = relative_basis(self.geometry(params), poses, self.orders)
        if not np.all(np.isfinite(basis)):
            return suspension, poses, None, np.full(self.fields.size, 1e6)
        strengths, scaled = _linear_strengths(basis, self.fields, self.weights)
        scaled = scaled.reshape(self.fields.shape)
        scaled[~in_contact] = 1e3
        return suspension, poses, strengths, scaled.ravel()

    def __call__(self, params: np.ndarray) -> np.ndarray:
        return self.evaluate(params)[3]


def _theta_of(fit: MechanicsFit) -> np.ndarray:
    """The outer parameters (logs, logistic stub share) of a fitted suspension."""
    s = fit.suspension
    share = min(max(s.stub_mm / (s.trace_length_mm * MAX_STUB_FRACTION), 1e-3), 1.0 - 1e-3)
    return np.array([np.log(s.rot_compliance), np.log(s.trans_compliance),
                     np.log(share / (1.0 - share))])


def _joint_starts(start: MechanicsFit) -> list[np.ndarray]:
    """The Y fit as it is, and with its translational compliance reset to the usual start: Y
    alone often cannot tell a shift from a turn (it may leave no shift at all), Z can."""
    theta = _theta_of(start)
    reset = theta.copy()
    reset[1] = theta[0] + np.log(TRANS_SHARE_START)
    return [theta, reset]


def _start_groups(start, centers, y_uT, noise_y_uT, rod_radius_mm, trace_length_mm, sweep):
    """Suspensions (as outer parameters) to start the joint fit from, in groups tried in turn
    until one explains the grid: a Y fit's made here, ``start``'s (the z lookup's mechanics),
    the generic starts. Neither of the first two serves every build: with a tip sweep, each
    leaves some build far above the noise that another start explains. The Y fit goes first:
    from the z lookup's start the recorded default grid lands in a neighbouring minimum whose
    table biases the contour runs (the cases are in docs/research/2026-11-29-calibration.md)."""
    yield _joint_starts(fit_mechanics(centers, y_uT, rod_radius_mm, trace_length_mm, noise_y_uT,
                                      sweep=sweep))
    if start is not None:
        yield _joint_starts(start)
    yield [_theta_start(trace_length_mm, rot) for rot in JOINT_ROT_COMPLIANCE_STARTS]


def _unexplained(result, n: int) -> bool:
    """More than twice the noise left on average (the residuals are in standard errors)."""
    return 2.0 * result.cost / n > UNEXPLAINED_RATIO ** 2


def _settled(fit, n: int) -> bool:
    """A joint refinement (result, objective) that explains the grid with its stage offset
    inside the bounds: one at a bound is the fit making up with the stage for a suspension in
    the wrong basin (a case is in docs/research/2026-11-29-calibration.md)."""
    return not _unexplained(fit[0], n) and not _fit_at_bound(fit)


def _fit_at_bound(fit) -> bool:
    """Whether a joint refinement's (result, objective) stage offset reached its bound."""
    result, joint = fit
    return offset_at_bound(joint.stage_offset_mm(result.x))


def _swept(sweep) -> bool:
    """Whether the contacts include a tip sweep's."""
    return sweep is not None and bool(np.any(sweep))


def offset_at_bound(offset_mm) -> bool:
    """Whether a fitted stage offset (x, y mm) reached the joint fit's bound on either axis."""
    return bool(np.any(np.abs(offset_mm) >= OFFSET_AT_BOUND * MAX_STAGE_OFFSET_MM))


def stage_offset_axes(sweep) -> tuple[int, ...]:
    """The stage axes (x 0, y 1) whose constant offset the joint fit finds with the rest. The
    rods sit off their recorded places by the drive's backlash (taken up the same way at every
    point, ``collect.plan``) and the error in the whisker origin's stage position; near the root
    a hundredth of a millimetre reads tens of µT, enough to move a stiff root's fit to another
    basin when left out (docs/calibration.md). Across the wire (y) always; along it (x) only with
    a tip sweep, whose contacts push along x too: shaft contacts alone barely see it, and a free
    x fitted to them lands far from the truth."""
    return (0, 1) if _swept(sweep) else (1,)


def degrees_of_freedom(n: int, strengths: int, offsets: int) -> int:
    """A joint fit's degrees of freedom: ``n`` readings less the outer parameters (with
    ``offsets`` stage axes) and the map's ``strengths``."""
    return max(n - NONLINEAR_PARAMETERS - offsets - strengths, 1)


def significant_misfit(chi2: float, n: int, strengths: int, offsets: int) -> bool:
    """χ² (in standard errors) of ``n`` readings per degree of freedom more than
    ``RICHER_ORDER_SIGMAS`` of its standard deviations (√(2/dof)) above 1: the model, or the
    minimum the fit reached, leaves something the noise does not explain."""
    dof = degrees_of_freedom(n, strengths, offsets)
    return chi2 / dof > 1.0 + RICHER_ORDER_SIGMAS * np.sqrt(2.0 / dof)


def _one_order_more(orders) -> tuple[int, ...]:
    return tuple(orders) + (max(orders) + 1,)


def _better_by_akaike(fit, richer):
    """The richer map's fit when it lowers χ² by more than 2 per added strength (Akaike)."""
    extra = len(richer[1].orders) - len(fit[1].orders)
    return richer if 2.0 * richer[0].cost + 2.0 * extra < 2.0 * fit[0].cost else fit


def joint_objective(centers, fields, noise, rod_radius_mm, trace_length_mm, orders,
                    sweep=None) -> _JointObjective:
    """The residuals (standard errors) of the grid's Y and Z as a function of the mechanics'
    three outer parameters, the stage offset's (``stage_offset_axes``) and the map's seven
    geometric ones (the strengths solved inside)."""
    mechanics = _Objective(float(trace_length_mm), centers, float(rod_radius_mm), fields, noise, 1,
                           sweep)
    return _JointObjective(mechanics, fields, 1.0 / noise, tuple(orders),
                           stage_offset_axes(sweep))


def fit_at(joint: _JointObjective, params: np.ndarray, like: MechanicsFit) -> MechanicsFit:
    """``like`` with the suspension and map of outer parameters ``params`` (the map's strengths
    refitted to the grid there): a neighbour of a joint fit, as its error estimate needs."""
    suspension, poses, strengths, _ = joint.evaluate(params)
    return replace(like, suspension=suspension, poses=poses,
                   pose_map=MagnetPoseMap(joint.geometry(params).copy(), strengths,
                                          joint.orders, 2))


def _joint_fit(start, centers, fields, noise, rod_radius_mm, trace_length_mm, orders,
               sweep=None, evaluations=JOINT_EVALUATIONS):
    """One joint refinement from mechanics ``start`` (theta, then the stage offset's
    parameters where given; none at first), on at most ``evaluations`` of the objective:
    (least-squares result, objective)."""
    joint = joint_objective(centers, fields, noise, rod_radius_mm, trace_length_mm, orders, sweep)
    solved = np.zeros(joint.solved_count)
    solved[:len(start)] = start
    first_map, _ = fit_magnet_map(joint.poses(solved)[1], fields, 1.0 / noise, orders)
    params = np.concatenate([solved, first_map.geometry])
    return _refined(joint, params, evaluations), joint


def _refined(joint: _JointObjective, params: np.ndarray, evaluations: int):
    """The least-squares refinement of ``joint`` from ``params`` on at most ``evaluations``."""
    return least_squares(joint, params, bounds=joint.bounds(params.size), diff_step=1e-5,
                         x_scale=0.1, xtol=1e-10, ftol=1e-10, max_nfev=evaluations,
                         callback=_stop_at_bound(joint))


def _restarted(fit):
    """A joint refinement (result, objective) started again from where it stopped while that
    lowers χ² by more than ``RESTART_GAIN``, at most ``RESTART_PASSES`` times: the finite
    differences of iterative solves leave the least squares stalled short of its minimum, where
    it stops by the arithmetic's last digits, so the first stop is not reproducible."""
    result, joint = fit
    for _ in range(RESTART_PASSES):
        again = _refined(joint, result.x, JOINT_EVALUATIONS)
        if 2.0 * (result.cost - again.cost) <= RESTART_GAIN or _fit_at_bound((again, joint)):
            break
        result = again
    return result, joint


def _stop_at_bound(joint: _JointObjective):
    """A least-squares callback ending a refinement whose stage offset has sat at its bound for
    ``BOUND_PATIENCE`` iterations running: it is making up with the stage for a suspension in
    the wrong basin, will not be ``_settled``, and would run to its evaluation limit (five of
    the stiff root's fourteen refinements with its sweep, 40 s each)."""
    streak = [0]

    def callback(intermediate_result) -> None:
        at_bound = offset_at_bound(joint.stage_offset_mm(intermediate_result.x))
        streak[0] = streak[0] + 1 if at_bound else 0
        if streak[0] >= BOUND_PATIENCE:
            raise StopIteration  # least_squares ends there and returns the iterate
    return callback


def _best_joint_fit(start, centers, fields, noise, rod_radius_mm, trace_length_mm, orders,
                    sweep):
    """The best joint refinement over the start groups (``_start_groups``), with more multipole
    orders, one at a time up to ``MAX_ORDER``, while each pays (Akaike) and a significant misfit
    is left, then polished where, with a sweep, a significant misfit is still left
    (``_polished``): (least-squares result, objective, every fit tried)."""
    args = (centers, fields, noise, rod_radius_mm, trace_length_mm)
    # the groups' starts once: the Y fit that makes the first takes seconds
    groups = list(_start_groups(start, centers, fields[:, 0], noise[0], rod_radius_mm,
                                trace_length_mm, sweep))
    best, fits = _best_from_starts(groups, *args, orders, sweep)
    # as for the polynomial map (``identify._richer_map``), only with a tip sweep: on a grid
    # alone a misfit may come from the stage's position error, which a richer map absorbs into
    # the suspension (on the recorded default grid a fifth order would bias the contour runs)
    while _swept(sweep) and max(best[1].orders) < MAX_ORDER and _misfit_left(best, fields.size):
        richer = _one_order_more(best[1].orders)
        more = [_joint_fit(best[0].x[:best[1].solved_count], *args, richer, sweep)]
        if _unexplained(best[0], fields.size):
            # no start's minimum explained the grid: the truncated map may have chosen the
            # basin (a soft root's turns need the richer map), so every start goes again too
            more += _best_from_starts(groups, *args, richer, sweep)[1]
        candidate = _best_of(more)
        fits += more
        if _better_by_akaike(best, candidate) is best:
            break
        best = candidate
    # with a tip sweep only, as a richer order: on a grid alone the misfit left is the stage's
    # position error along the wire (not fitted there), which no refinement removes: polishing
    # it costs time and barely moves the suspension
    if _swept(sweep) and _misfit_left(best, fields.size):
        best, polished = _polished(best, args, sweep)
        fits += polished
    best = _restarted(best)
    return best[0], best[1], fits


def _misfit_left(fit, n: int) -> bool:
    """Does a joint refinement (result, objective) on ``n`` readings leave a significant
    misfit (``significant_misfit``)?"""
    result, joint = fit
    return significant_misfit(2.0 * result.cost, n, len(joint.orders), len(joint.offset_axes))


def _polished(best, args, sweep):
    """``best`` (result, objective) refined again from its mechanics with k_θ·L/EI at
    ``POLISH_FACTORS`` times its own, while one of those lowers χ² by more than ``POLISH_GAIN``
    with its offset inside the bounds: (the best, every fit tried). A start group's minimum
    may be a stall of the least squares on a noisy Jacobian, which a start at a nearby ratio gets
    past to the minimum a start at the twin's own suspension lands in (a case is in
    docs/research/2026-11-29-calibration.md)."""
    fits = []
    for _ in range(POLISH_PASSES):
        result, joint = best
        starts = []
        for factor in POLISH_FACTORS:
            start = result.x[:joint.solved_count].copy()
            start[0] -= np.log(factor)  # log rotational compliance = -log k_θ·L/EI
            starts.append(start)
        tries = run_side_by_side(_joint_fit, [(start, *args, joint.orders, sweep,
                                               POLISH_EVALUATIONS) for start in starts])
        fits += tries
        kept = [f for f in tries if not _fit_at_bound(f)]
        candidate = min(kept, key=lambda f: f[0].cost, default=None)
        if candidate is None or 2.0 * (result.cost - candidate[0].cost) <= POLISH_GAIN:
            break
        best = candidate
    return best, fits


def _best_from_starts(groups, centers, fields, noise, rod_radius_mm, trace_length_mm, orders,
                      sweep):
    """The best joint refinement at ``orders`` over the start ``groups``, tried in turn until
    one explains the grid: (the best (result, objective), every fit tried)."""
    fits = []
    for thetas in groups:
        fits += run_side_by_side(_joint_fit, [(theta, centers, fields, noise, rod_radius_mm,
                                               trace_length_mm, orders, sweep)
                                              for theta in thetas])
        if _settled(_best_of(fits), fields.size):
            break
    return _best_of(fits), fits


def _best_of(fits):
    """The lowest-cost joint refinement (result, objective) whose stage offset stayed inside
    its bounds, else the lowest of all. One at a bound makes up with the stage for a suspension
    in the wrong basin (``_settled``), so a lower χ² there is no better fit, and the
    parameters' spread does not bound its error: which start stops lower moves with the BLAS
    kernel (docs/research/2026-12-02-kernels.md)."""
    inside = [f for f in fits if not _fit_at_bound(f)]
    return min(inside or fits, key=lambda f: f[0].cost)


def fit_mechanics_magnet(rod_center_mm: np.ndarray, fields_uT: np.ndarray, rod_radius_mm: float,
                         trace_length_mm: float, noise_uT, orders=DEFAULT_ORDERS,
                         start: MechanicsFit | None = None,
                         profile_factors=PROFILE_FACTORS, sweep=None) -> MechanicsFit:
    """Fit the suspension and a magnet pose map to a rod grid's Y and Z (n, 2) µT from rest.

    ``start``: a fit on Y (``MechanicsFit``, the z lookup's mechanics) to start from where the
    Y fit made here first leaves the grid unexplained (``_start_groups``).
    ``sweep``: which contacts are the tip sweep's (solved along the rod's approach, as in
    :func:`whiskercal.mechfit.fit.fit_mechanics`); none by default.
    ``profile_factors``: k_θ·L/EI multiples at which :func:`ratio_profile` tests the fit's
    identification (in ``starts[-1]["ratio_profile"]``; none when empty). Same arguments
    otherwise as :func:`whiskercal.mechfit.fit.fit_mechanics`.
    """
    started = time.perf_counter()
    fields = np.asarray(fields_uT, float)
    if fields.ndim != 2 or fields.shape[1] != 2:
        raise UsageError("the magnet fit needs the Y and Z axes, (n, 2) µT.")
    noise = np.broadcast_to(np.asarray(noise_uT, float), (2,))
    centers = np.asarray(rod_center_mm, float)
    result, joint, fits = _best_joint_fit(start, centers, fields, noise, rod_radius_mm,
                                          trace_length_mm, orders, sweep)
    evaluations = sum(f[1].mechanics.evaluations for f in fits)
    suspension, poses, strengths, scaled = joint.evaluate(result.x)
    pose_map = MagnetPoseMap(joint.geometry(result.x).copy(), strengths, joint.orders, 2)
    residual = scaled.reshape(fields.shape) / (1.0 / noise)
    profile = ratio_profile(result, joint) if profile_factors else []
    return MechanicsFit(suspension, pose_map, poses, residual,
                        np.sqrt(np.mean(residual ** 2, axis=0)), (0, 1),
                        time.perf_counter() - started, evaluations,
                        [{"joint_fits": len(fits), "joint_magnet_cost": float(result.cost),
                          "params": result.x.copy(),
                          "stage_offset_mm": joint.stage_offset_mm(result.x).tolist(),
                          "ratio_profile": [{k: v for k, v in p.items() if k != "params"}
                                            for p in profile],
                          "ratio_profile_params": [p["params"] for p in profile]}])


def ratio_profile(result, joint: _JointObjective, factors=PROFILE_FACTORS) -> list[dict]:
    """How much worse the grid is fitted with k_θ·L/EI held at ``factors`` times the best's.

    Each point refits everything else (stub, translational compliance, the map's geometry);
    ``delta_chi2`` is twice the cost increase (residuals in standard errors): below about 9 the
    grid cannot tell that ratio from the best one; ``params``, the held fit's outer parameters.
    """
    # each held fit warm-started from the best fit's poses (its own copy of the objective), so
    # they run side by side (``workers``) and give the same in a process that runs them in turn
    return run_side_by_side(_held_fit, [(result.x, result.cost, joint, factor)
                                        for factor in factors])


def _held_fit(best_x: np.ndarray, best_cost: float, joint: _JointObjective, factor: float
              ) -> dict:
    """One point of :func:`ratio_profile`: k_θ·L/EI held at ``factor`` times the best's."""
    fixed = best_x[0] - np.log(factor)  # log rotational compliance = -log ratio
    joint = copy.deepcopy(joint)

    def residual(rest):
        return joint(np.insert(rest, 0, fixed))

    low, high = joint.bounds(best_x.size)
    held = least_squares(residual, np.delete(best_x, 0),
                         bounds=(np.delete(low, 0), np.delete(high, 0)), diff_step=1e-5,
                         x_scale=0.1, xtol=1e-8, ftol=1e-8, max_nfev=PROFILE_EVALUATIONS)
    return {"stiffness_ratio": float(np.exp(-fixed)),
            "delta_chi2": float(2.0 * (held.cost - best_cost)),
            "params": np.insert(held.x, 0, fixed)}
