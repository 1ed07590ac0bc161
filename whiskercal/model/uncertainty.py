"""How far the grid's scatter can move the traced tips: a parametric bootstrap of the surface.

The fit's residuals (measurement noise plus what the polynomial cannot follow) are drawn anew
around the fitted surface, the surface is refitted and a few tips are traced again; the RMS
distance of those tips from the calibration's own is the tip uncertainty the data leave. It
catches what no residual check can: a surface that fits noisy data as well as the data allow
(CV RMSE near the noise) yet places the tips millimetres off, because a small error in the
level set's direction near the root grows along the whole arc.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from whiskercal.model.errors import ModelError, TraceError
from whiskercal.model.surface import fit_fixed
from whiskercal.model.trace import LevelSetProblem, trace_fast

BOOTSTRAP_SURFACES = 12
Z_PROBES = 5
# Warn above this tip spread (mm): the tip-error goal, so a spread the size of what a calibration
# may err by is reported. The stability map's noise probe (``bench --only stability``) shows the
# spread growing with the grid's noise and staying under it at the sensor's own.
TIP_SPREAD_WARN_MM = 0.25


def tip_spread_mm(problem: LevelSetProblem, points_mm: np.ndarray, scatter_uT: float,
                  z_range_uT: tuple[float, float], seed: int = 0) -> float:
    """RMS distance (mm) between the calibration's tips and those of refitted surfaces.

    Parameters
    ----------
    problem : LevelSetProblem
        The calibration's level-set problem (its surface is the one refitted).
    points_mm : ndarray (n, 2)
        The contact points the surface was fitted to, mm.
    scatter_uT : float
        RMS scatter of the points about the surface (the fit's RMSE), µT.
    z_range_uT : (float, float)
        The lookup's z range; the tips are probed inside it.
    seed : int
        Seed of the redrawn scatter (the result is deterministic).
    """
    surface = problem.surface
    rng = np.random.default_rng(seed)
    z_probes, nominal = _nominal_tips(problem, np.linspace(*z_range_uT, Z_PROBES + 2)[1:-1])
    fitted = surface(points_mm)
    squared = []
    for _ in range(BOOTSTRAP_SURFACES):
        redrawn = fitted + rng.normal(0.0, scatter_uT, len(fitted))
        refit, _ = fit_fixed(points_mm, redrawn, surface.degree, surface.coordinates, surface.scaling)
        perturbed = replace(problem, surface=refit)
        for z, tip in zip(z_probes, nominal):
            squared.append(_squared_move(perturbed, z, tip, problem.trace_length_mm))
    return float(np.sqrt(np.mean(squared)))


def _nominal_tips(problem: LevelSetProblem, z_uT: np.ndarray) -> tuple[np.ndarray, list]:
    """The probes that trace on the calibration's own surface, and their tips (mm): a level the
    lookup bridged (``lookup.bridge_untraced``) has no nominal tip to move."""
    kept, tips = [], []
    for z in z_uT:
        try:
            tips.append(trace_fast(problem, float(z)).tip_mm)
        except TraceError:
            continue
        kept.append(z)
    return np.asarray(kept), tips


def _squared_move(problem: LevelSetProblem, z_uT: float, tip_mm: np.ndarray, length_mm: float) -> float:
    """Squared distance the tip moved; a trace that fails counts as a whole arc length off."""
    try:
        return float(np.sum((trace_fast(problem, z_uT).tip_mm - tip_mm) ** 2))
    except ModelError:
        return length_mm ** 2


def scatter_warning(spread_mm: float, scatter_uT: float,
                    limit_mm: float = TIP_SPREAD_WARN_MM) -> str | None:
    """A sentence when the tip spread exceeds ``limit_mm``, else None."""
    if not spread_mm > limit_mm:
        return None
    return (f"the grid's scatter ({scatter_uT:.1f} µT RMS about the surface) moves the traced tips "
            f"by {spread_mm:.2f} mm RMS (more than {limit_mm:g} mm): average more samples per "
            "point, check the sensor's noise, or take a denser grid")
