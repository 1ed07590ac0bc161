"""Tip loads of the fitted model over a grid of force size and direction fixed in space.

A plane pressed against the tip pushes along its normal, turned by friction within the friction
cone: a direction fixed in space for a given plane and sliding sense. Near-axial pushes (a plane
almost square to the wire) carry the wire past the point where a load along the wire alone would
hold it straight, so their equilibria are not reached by following the tip's slope from rest.
Here they are reached by continuation in the direction instead: each force size is solved at a
safe direction first, then turned step by step toward and past the axis, each solve warm-started
from its neighbour, so every point lies on the branch the tip reaches by being pushed in and then
dragged, as it is on a plane.

Direction ``alpha``: from the undeflected wire's -y normal toward the root (-x); 90° is a push
straight along the wire toward the root. Sizes in EI/L² (``forward.tip_load``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.mechfit.forward import Suspension, tip_load

START_ALPHA_DEG = 45.0
DEFAULT_ALPHAS_DEG = tuple(np.arange(0.0, 115.01, 2.5))
# fine around a few EI/L², where a near-axial push buckles the wire (π²/4 for a clamped wire,
# less on a compliant root) and the tip's place changes fastest with the force
DEFAULT_MAGNITUDES = tuple(np.round(np.concatenate([np.arange(0.05, 1.0, 0.05),
                                                    np.arange(1.0, 4.0, 0.02),
                                                    np.arange(4.0, 10.0, 0.1),
                                                    np.arange(10.0, 30.01, 0.5)]), 3))


@dataclass(frozen=True)
class LoadGrid:
    """Solved tip loads: ``pose`` (n, 3), ``tip_mm`` (n, 2), ``alpha_rad`` (n,), ``magnitude`` (n,)."""

    pose: np.ndarray
    tip_mm: np.ndarray
    alpha_rad: np.ndarray
    magnitude: np.ndarray


def _force(magnitude: float, alpha_deg: float) -> np.ndarray:
    a = math.radians(alpha_deg)
    return magnitude * np.array([-math.sin(a), -math.cos(a)])


def _sweep(suspension, magnitude, alphas, moment, rows):
    """Turn one force size through ``alphas`` from a solved moment; stops where Newton fails."""
    for alpha in alphas:
        solved = tip_load(suspension, _force(magnitude, alpha), moment)
        if solved is None:
            return
        pose, tip, moment = solved
        rows.append((pose, tip, math.radians(alpha), magnitude))


def _start_moments(suspension, magnitudes, alpha_deg):
    """Each size solved at the start direction, by continuation in size from rest."""
    moment, out = 0.0, []
    for magnitude in magnitudes:
        solved = tip_load(suspension, _force(magnitude, alpha_deg), moment)
        if solved is None:
            break
        moment = solved[2]
        out.append((magnitude, solved))
    return out


def load_grid(suspension: Suspension, magnitudes=DEFAULT_MAGNITUDES, alphas_deg=DEFAULT_ALPHAS_DEG,
              start_alpha_deg: float = START_ALPHA_DEG, stop=None) -> LoadGrid:
    """Solve tip loads of every size and direction reachable by continuation.

    ``stop(pose) -> bool``: sizes past the first whose start pose it accepts are not solved (the
    caller's field range is exceeded there).
    """
    alphas = np.asarray(alphas_deg, float)
    up, down = alphas[alphas > start_alpha_deg], alphas[alphas < start_alpha_deg][::-1]
    rows = []
    for magnitude, (pose, tip, moment) in _start_moments(suspension, magnitudes, start_alpha_deg):
        rows.append((pose, tip, math.radians(start_alpha_deg), magnitude))
        _sweep(suspension, magnitude, up, moment, rows)
        _sweep(suspension, magnitude, down, moment, rows)
        if stop is not None and stop(pose):
            break
    return LoadGrid(np.array([r[0] for r in rows]), np.array([r[1] for r in rows]),
                    np.array([r[2] for r in rows]), np.array([r[3] for r in rows]))


# Past the axis a push holds the wire bent toward -y only above a force that grows without
# bound as the bend vanishes, and each (direction, size) has a small and a large bend: neither
# continuation in size nor in slope from rest reaches all of it. Newton from a few root moments
# finds both bends directly; a bend toward +y is the other branch and is left out.
PAST_AXIS_ALPHAS_DEG = tuple(np.arange(85.0, 110.01, 0.5))
PAST_AXIS_MAGNITUDES = tuple(np.round(np.arange(1.5, 6.001, 0.04), 3))
PAST_AXIS_MOMENT_GUESSES = (0.0, -1.0, -2.0)


def past_axis_loads(suspension: Suspension, alphas_deg=PAST_AXIS_ALPHAS_DEG,
                    magnitudes=PAST_AXIS_MAGNITUDES) -> LoadGrid:
    """Tip loads at and past the wire's axis that bend it toward -y, every branch Newton finds
    from :data:`PAST_AXIS_MOMENT_GUESSES` (duplicates dropped)."""
    rows = []
    for alpha in alphas_deg:
        for magnitude in magnitudes:
            found = []
            for guess in PAST_AXIS_MOMENT_GUESSES:
                solved = tip_load(suspension, _force(magnitude, alpha), guess)
                if solved is None or solved[0][0] >= 0.0:
                    continue
                if all(abs(solved[2] - other) > 1e-6 for other in found):
                    found.append(solved[2])
                    rows.append((solved[0], solved[1], math.radians(alpha), magnitude))
    if not rows:
        return LoadGrid(np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(0), np.zeros(0))
    return LoadGrid(np.array([r[0] for r in rows]), np.array([r[1] for r in rows]),
                    np.array([r[2] for r in rows]), np.array([r[3] for r in rows]))
