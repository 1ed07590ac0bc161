"""The classical check of the elastica: a rigid-root cantilever under a perpendicular tip load."""

from __future__ import annotations

import math

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.twin.physics import elastica as el

ALPHA_MAX = 50.0
ALPHA_STEP = 1.0   # load increments of the continuation: the large-load branch needs it


def cantilever_tip(alpha: float, steps: int = el.DEFAULT_STEPS) -> tuple[float, float]:
    """Tip of a cantilever (rigid root) under a tip load P perpendicular to its undeformed axis.

    Parameters
    ----------
    alpha : float
        P·L²/EI, in [0, 50].
    steps : int
        RK4 steps along the wire.

    Returns
    -------
    (x, y) : tuple of float
        The tip as fractions of L: along the undeformed axis and in the load's direction.
    """
    try:
        alpha = float(alpha)
    except (TypeError, ValueError):
        raise UsageError(f"alpha must be a number, got {alpha!r}.") from None
    if not (0.0 <= alpha <= ALPHA_MAX):
        raise UsageError(f"alpha must be in [0, {ALPHA_MAX:g}], got {alpha!r}.")
    p = el.new_params()  # stub 0, compliances 0: a rigid root at the origin
    z = before = np.zeros(1)
    for load in np.linspace(0.0, alpha, max(1, math.ceil(alpha / ALPHA_STEP)) + 1)[1:]:
        p[el.P_FY] = load
        # start from the trend of the last two loads: from the last solution alone, Newton
        # jumps to another branch of the elastica beyond alpha ~ 33
        start = 2.0 * z - before
        before = z
        z, converged, _ = el.newton(el.CANTILEVER, start, p, steps, 1e-12, 50)
        if not converged:
            raise UsageError(f"the cantilever solve did not converge at alpha = {load:g}.")
    _, _, _, tip_x, tip_y = el.end_state(el.CANTILEVER, z, p, steps)
    return float(tip_x), float(tip_y)
