"""Fit the suspension (stub, rotational and translational compliance) and the pose map to a grid.

Variable projection: for trial mechanics every rod contact of the grid is solved for its root
pose (warm-started from the last trial), the pose map is then linear in its coefficients and
comes from least squares, and what it leaves is the residual the outer least squares (over the
three mechanical parameters, in logs) drives down. The tip sweep's points (the rod at the tip,
``collect.sweep``) are solved from the free whisker along the rod's approach at every
evaluation instead (see ``_Objective``). The start depends on the trace length only:
a stub of 4 % of it, and a few rotational compliances spanning the family (k_θ·L/EI from about
1 to 100), the best of which is kept.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares
from scipy.special import expit

from whiskercal.errors import UsageError
from whiskercal.mechfit.fieldmap import DEFAULT_DEGREE, MAX_SHIFT_ORDER, PoseMap, fit_pose_map
from whiskercal.mechfit.forward import Suspension, rod_poses
from whiskercal.mechfit.workers import run_side_by_side

STUB_FRACTION_START = 0.04
ROT_COMPLIANCE_STARTS = (0.01, 0.1, 1.0)
# translational compliance as a share of the rotational one at the start: k_θ/(L²·k_t) of a
# suspension whose shift under the push is small against its turn
TRANS_SHARE_START = 0.01
MAX_STUB_FRACTION = 0.2
# evaluations of each start's scouting fit with the linear pose map
SCOUT_EVALUATIONS = 40
# how many fits ``fit_mechanics`` keeps for repeated calls with the same arguments
RECENT_FITS = 4
_RECENT_FITS: dict = {}
# compliances within e^±40 of 1 (EI/L·k_θ and EI/L³·k_t): far past any build, short of overflow
LOG_LIMIT = 40.0


@dataclass
class MechanicsFit:
    """The fitted model and its evidence.

    ``residual_uT`` per grid point and axis; ``rms_uT`` per axis; ``fit_time_s`` wall time.
    """

    suspension: Suspension
    pose_map: PoseMap
    poses: np.ndarray
    residual_uT: np.ndarray
    rms_uT: np.ndarray
    axes: tuple[int, ...]
    fit_time_s: float
    evaluations: int = 0
    starts: list[dict] = field(default_factory=list)


class _Objective:
    """Residuals (in standard errors) of trial mechanics; keeps the last equilibria as warm starts."""

    def __init__(self, trace_mm, rod_center_mm, rod_radius_mm, fields_uT, noise_uT, degree,
                 fresh=None, shift_order=MAX_SHIFT_ORDER):
        self.trace_mm, self.centers, self.radius = trace_mm, rod_center_mm, rod_radius_mm
        self.fields, self.weights, self.degree = fields_uT, 1.0 / noise_uT, degree
        self.shift_order = shift_order
        # points solved along the rod's approach every time, never from a nearby suspension's
        # solution: near the tip a warm start can land on another equilibrium than the rig's
        self.fresh = np.zeros(len(rod_center_mm), bool) if fresh is None else np.asarray(fresh)
        self.warm = None
        self.evaluations = 0

    def suspension(self, theta: np.ndarray) -> Suspension:
        # a profile's least squares may try any logit or log: keep them representable
        stub = self.trace_mm * MAX_STUB_FRACTION * float(expit(theta[2]))
        rot, trans = np.exp(np.clip(theta[:2], -LOG_LIMIT, LOG_LIMIT))
        return Suspension(self.trace_mm, stub, float(rot), float(trans))

    def solve(self, theta: np.ndarray):
        suspension = self.suspension(theta)
        solved = rod_poses(suspension, self.centers, self.radius, self.warm)
        if solved.in_contact.all():
            self.warm = solved.warm_starts(self.fresh)
        self.evaluations += 1
        return suspension, solved.poses, solved.in_contact

    def evaluate(self, theta: np.ndarray):
        """One solve: (suspension, poses, pose map, residual µT, residual in standard errors)."""
        suspension, poses, in_contact = self.solve(theta)
        pose_map, residual = fit_pose_map(poses, self.fields, self.degree,
                                          max_shift_order=self.shift_order)
        scaled = residual * self.weights
        scaled[~in_contact] = 1e3  # a trial that loses a contact the grid had is far off
        return suspension, poses, pose_map, residual, scaled

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        return self.evaluate(theta)[4].ravel()


def _theta_start(trace_mm: float, rot_compliance: float) -> np.ndarray:
    share = STUB_FRACTION_START / MAX_STUB_FRACTION
    return np.array([math.log(rot_compliance), math.log(rot_compliance * TRANS_SHARE_START),
                     math.log(share / (1.0 - share))])


def fit_mechanics(rod_center_mm: np.ndarray, fields_uT: np.ndarray, rod_radius_mm: float,
                  trace_length_mm: float, noise_uT, degree: int = DEFAULT_DEGREE,
                  starts=ROT_COMPLIANCE_STARTS, sweep=None) -> MechanicsFit:
    """Fit the suspension and the pose map to a rod grid.

    Parameters
    ----------
    rod_center_mm : ndarray (n, 2)
        Rod centres in the whisker frame (contacts only: drop the no-contact points first),
        ordered in columns as the stage visits them.
    fields_uT : ndarray (n,) or (n, m)
        Field axes minus their static readings (Y first; Z optionally), µT.
    rod_radius_mm, trace_length_mm : float
    noise_uT : float or ndarray (m,)
        Standard error of each axis' point means, µT (weights the axes against each other).
    sweep : ndarray (n,) of bool, optional
        The tip sweep's points (the rod at the tip, ``collect.sweep``): each is solved along the
        rod's approach from the free whisker, as the rig reaches it, at every evaluation.

    The fit is deterministic: the last :data:`RECENT_FITS` are kept, and a call with the same
    arguments returns the same ``MechanicsFit`` (``fit_time_s`` that of the fit itself). A
    calibration asks twice: the z lookup's mechanics and the (Y, Z) joint fit's first start.
    """
    fields = np.atleast_2d(np.asarray(fields_uT, float).T).T
    noise = np.broadcast_to(np.asarray(noise_uT, float), (fields.shape[1],))
    centers = np.asarray(rod_center_mm, float)
    if len(centers) != len(fields):
        raise UsageError("rod centres and fields must have one row per grid point.")
    fresh = np.zeros(len(centers), bool) if sweep is None else np.asarray(sweep, bool)
    key = (centers.tobytes(), fields.tobytes(), fields.shape, noise.tobytes(), fresh.tobytes(),
           float(rod_radius_mm), float(trace_length_mm), int(degree), tuple(starts))
    if key not in _RECENT_FITS:
        if len(_RECENT_FITS) >= RECENT_FITS:
            _RECENT_FITS.pop(next(iter(_RECENT_FITS)))
        _RECENT_FITS[key] = _fit(centers, fields, noise, float(rod_radius_mm),
                                 float(trace_length_mm), degree, starts, fresh)
    return _RECENT_FITS[key]


def _scout(centers, fields, noise, rod_radius_mm, trace_length_mm, rot, sweep):
    """One scouting start at rotational compliance ``rot`` with a rigid (linear) pose map,
    which leaves the mechanics less to hide: (cost, rot, theta, evaluations)."""
    objective = _Objective(float(trace_length_mm), centers, float(rod_radius_mm), fields,
                           noise, 1, sweep)
    result = least_squares(objective, _theta_start(trace_length_mm, rot), diff_step=1e-4,
                           max_nfev=SCOUT_EVALUATIONS)
    return float(result.cost), rot, result.x, objective.evaluations


def _fit(centers, fields, noise, rod_radius_mm, trace_length_mm, degree, starts, sweep
         ) -> MechanicsFit:
    """``fit_mechanics`` on checked arrays."""
    started = time.perf_counter()
    # each start its own objective and warm starts: side by side, the same results
    tried = run_side_by_side(_scout, [(centers, fields, noise, rod_radius_mm, trace_length_mm,
                                       rot, sweep) for rot in starts])
    _, _, theta, _ = min(tried, key=lambda t: t[0])
    objective = _Objective(float(trace_length_mm), centers, float(rod_radius_mm), fields, noise,
                           degree, sweep)
    result = least_squares(objective, theta, diff_step=1e-4, xtol=1e-10, ftol=1e-10,
                           max_nfev=200)
    suspension, poses, pose_map, residual, _ = objective.evaluate(result.x)
    return MechanicsFit(suspension, pose_map, poses, residual,
                        np.sqrt(np.mean(residual ** 2, axis=0)), tuple(range(fields.shape[1])),
                        time.perf_counter() - started, objective.evaluations + sum(t[3] for t in tried),
                        [{"rot_compliance_start": t[1], "linear_map_cost": t[0]} for t in tried])
