"""Tip contacts of the fitted model: the z -> tip curve and the 2-D family of load directions.

A frictionless tip contact pushes perpendicular to the wire at its tip; the curve is followed
by the wire's slope at the tip, as the twin's truth does, each sample a tip-load solve whose
force magnitude is found so that the tip has that slope. A load tilted by ``beta`` from that
perpendicular (friction, a slanted surface) gives the second dimension of the family.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.mechfit.forward import Suspension, tip_load_and_angle

MAX_TIP_SLOPE_RAD = 1.9
SLOPE_STEP_RAD = 0.0125
_SECANT_TOL = 1e-10
_SECANT_ITER = 40


@dataclass(frozen=True)
class TipFamily:
    """Tip-load equilibria by tip slope (rad) for one load tilt ``beta_rad``.

    ``pose`` (n, 3): root rotation rad, shift mm; ``tip_mm`` (n, 2); ``force`` (n, 2) in EI/L²;
    ``moment`` (n,): the solve's root moment (nondimensional), a warm start for neighbours.
    """

    beta_rad: float
    tip_slope_rad: np.ndarray
    pose: np.ndarray
    tip_mm: np.ndarray
    force: np.ndarray
    moment: np.ndarray | None = None


def _direction(slope: float, beta: float, world: bool = False) -> np.ndarray:
    """Unit load: the tip's -y normal (sin s, -cos s) turned by beta toward the root; with
    ``world`` the undeflected wire's -y normal instead (a direction fixed in space)."""
    angle = (0.0 if world else slope) - 0.5 * math.pi - beta
    return np.array([math.cos(angle), math.sin(angle)])


def _slope_error(suspension, slope, beta, magnitude, moment, world=False):
    force = magnitude * _direction(slope, beta, world)
    solved = tip_load_and_angle(suspension, force, moment)
    if solved is None:
        return None
    pose, tip, moment, angle = solved
    return angle - slope, pose, tip, moment


def _solve_slope(suspension, slope, beta, magnitude, moment, world=False):
    """Force magnitude (EI/L²) giving tip slope ``slope``, by the secant method from a guess."""
    a, b = magnitude, magnitude * 1.01 + 1e-4
    fa = _slope_error(suspension, slope, beta, a, moment, world)
    fb = _slope_error(suspension, slope, beta, b, moment, world)
    for _ in range(_SECANT_ITER):
        if fa is None or fb is None:
            return None
        if abs(fb[0]) < _SECANT_TOL:
            return b, fb
        if fb[0] == fa[0]:
            return None
        a, b, fa = b, b - fb[0] * (b - a) / (fb[0] - fa[0]), fb
        fb = _slope_error(suspension, slope, beta, b, fb[3], world)
    return None


def tip_family(suspension: Suspension, beta_rad: float = 0.0,
               max_slope_rad: float = MAX_TIP_SLOPE_RAD, step_rad: float = SLOPE_STEP_RAD,
               world: bool = False) -> TipFamily:
    """Follow tip loads tilted ``beta_rad`` from the tip normal, from rest to ``max_slope_rad``.

    ``world``: tilted from the undeflected wire's normal instead, a load direction fixed in
    space as a plane's normal (with its friction) is. Stops early (shorter arrays) where the
    solve loses the branch.
    """
    slopes = -np.arange(0.0, max_slope_rad + 0.5 * step_rad, step_rad)
    poses, tips, forces = [np.zeros(3)], [np.array([suspension.trace_length_mm, 0.0])], [np.zeros(2)]
    moments = [0.0]
    magnitude, moment = 0.0, 0.0
    kept = 1
    for slope in slopes[1:]:
        found = _solve_slope(suspension, slope, beta_rad, magnitude, moment, world)
        if found is None:
            break
        magnitude, (_, pose, tip, moment) = found
        poses.append(pose), tips.append(tip), forces.append(magnitude * _direction(slope, beta_rad, world))
        moments.append(moment)
        kept += 1
    if kept < 4:
        raise UsageError(f"no tip-load branch for a load tilted {math.degrees(beta_rad):.0f}°.")
    return TipFamily(float(beta_rad), slopes[:kept], np.array(poses), np.array(tips),
                     np.array(forces), np.array(moments))
