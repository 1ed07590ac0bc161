"""A small adaptive Dormand-Prince 5(4) integrator for planar autonomous fields, in plain floats.

scipy's ``solve_ivp`` costs tens of microseconds of bookkeeping per step, more than the level-set
field itself; tracing a whisker needs only a 2-D state, a fixed end and a stop test, so this
integrator keeps everything in Python floats (one field call per stage, FSAL).
"""

from __future__ import annotations

import math
from typing import Callable

from whiskercal.model.errors import NonConvergenceError

Field = Callable[[float, float], tuple[float, float]]

# Dormand & Prince (1980) tableau; E = 5th-order minus embedded 4th-order weights
_A = ((1 / 5,),
      (3 / 40, 9 / 40),
      (44 / 45, -56 / 15, 32 / 9),
      (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729),
      (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656),
      (35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84))
_E = (71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40)


def _stages(field: Field, x: float, y: float, h: float, k1: tuple[float, float]):
    """One Dormand-Prince step, unrolled: new point, error estimate, and the last stage (FSAL)."""
    (a21,), (a31, a32), (a41, a42, a43), (a51, a52, a53, a54), (a61, a62, a63, a64, a65), \
        (b1, _, b3, b4, b5, b6) = _A
    e1, _, e3, e4, e5, e6, e7 = _E
    p1, q1 = k1
    p2, q2 = field(x + h * a21 * p1, y + h * a21 * q1)
    p3, q3 = field(x + h * (a31 * p1 + a32 * p2), y + h * (a31 * q1 + a32 * q2))
    p4, q4 = field(x + h * (a41 * p1 + a42 * p2 + a43 * p3), y + h * (a41 * q1 + a42 * q2 + a43 * q3))
    p5, q5 = field(x + h * (a51 * p1 + a52 * p2 + a53 * p3 + a54 * p4),
                   y + h * (a51 * q1 + a52 * q2 + a53 * q3 + a54 * q4))
    p6, q6 = field(x + h * (a61 * p1 + a62 * p2 + a63 * p3 + a64 * p4 + a65 * p5),
                   y + h * (a61 * q1 + a62 * q2 + a63 * q3 + a64 * q4 + a65 * q5))
    x_new = x + h * (b1 * p1 + b3 * p3 + b4 * p4 + b5 * p5 + b6 * p6)
    y_new = y + h * (b1 * q1 + b3 * q3 + b4 * q4 + b5 * q5 + b6 * q6)
    p7, q7 = field(x_new, y_new)
    err_x = h * (e1 * p1 + e3 * p3 + e4 * p4 + e5 * p5 + e6 * p6 + e7 * p7)
    err_y = h * (e1 * q1 + e3 * q3 + e4 * q4 + e5 * q5 + e6 * q6 + e7 * q7)
    return x_new, y_new, err_x, err_y, (p7, q7)


def integrate(field: Field, start: tuple[float, float], length: float, *, rtol: float = 1e-9,
              atol: float = 1e-9, first_step: float = 0.5, max_steps: int = 10_000,
              inside: Callable[[float, float], float] | None = None,
              ) -> tuple[float, float, float, int]:
    """Integrate dp/ds = field(p) from ``start`` over s in [0, length].

    ``inside(x, y)`` is a signed distance, positive inside a region: when a step would end
    outside, the step is shortened to end on the boundary (root search on the step length) and
    the integration stops there. Returns the end point, the s reached and the accepted steps.
    """
    x, y = start
    s, h, k1 = 0.0, min(first_step, length), field(x, y)
    for steps in range(1, max_steps + 1):
        h = min(h, length - s)
        x_new, y_new, err_x, err_y, k_last = _stages(field, x, y, h, k1)
        scale_x = atol + rtol * max(abs(x), abs(x_new))
        scale_y = atol + rtol * max(abs(y), abs(y_new))
        error = math.sqrt(((err_x / scale_x) ** 2 + (err_y / scale_y) ** 2) / 2)
        if error <= 1.0:
            if inside is not None and inside(x_new, y_new) < 0:
                theta, x_b, y_b = _boundary_crossing((x, y, k1), (x_new, y_new, k_last), h, inside)
                return x_b, y_b, s + theta * h, steps
            s, x, y, k1 = s + h, x_new, y_new, k_last
            if s >= length * (1 - 1e-15):
                return x, y, length, steps
        h *= min(5.0, max(0.2, 0.9 * (error if error > 0 else 1e-10) ** -0.2))
    raise NonConvergenceError(f"the level-set integration needed more than {max_steps} steps")


def _hermite(start, end, h: float, theta: float) -> tuple[float, float]:
    """Cubic Hermite point at fraction theta of a step from its ends and their derivatives."""
    (x0, y0, (dx0, dy0)), (x1, y1, (dx1, dy1)) = start, end
    t2, t3 = theta * theta, theta * theta * theta
    h00, h10, h01, h11 = 2 * t3 - 3 * t2 + 1, t3 - 2 * t2 + theta, -2 * t3 + 3 * t2, t3 - t2
    return (h00 * x0 + h10 * h * dx0 + h01 * x1 + h11 * h * dx1,
            h00 * y0 + h10 * h * dy0 + h01 * y1 + h11 * h * dy1)


def _boundary_crossing(start, end, h: float, inside) -> tuple[float, float, float]:
    """Fraction of the step, and the point, where the step's Hermite interpolant leaves the region.

    The interpolant is O(h^4) accurate; the caller projects the point back onto its level set,
    which removes the error across the curve and leaves a tiny one along it.
    """
    from scipy.optimize import brentq

    if inside(start[0], start[1]) <= 0:
        return 0.0, start[0], start[1]
    theta = brentq(lambda t: inside(*_hermite(start, end, h, t)), 0.0, 1.0, xtol=1e-12)
    return (theta, *_hermite(start, end, h, theta))
