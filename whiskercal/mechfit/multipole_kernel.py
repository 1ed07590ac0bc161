"""The multipole basis (``magnetmap.multipole_basis``) in one compiled loop over the poses.

A joint fit evaluates the basis tens of thousands of times, on a few hundred poses each (every
finite-difference step in the map's geometry, every held fit of the profile); as array
arithmetic each call costs more in NumPy's per-operation overhead than in the arithmetic.
Legendre P_l and P_l' come from their three-term recurrences, which are exact to rounding
for |c| <= 1 (c is a cosine here).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def multipole_fields(geometry, poses, orders, out) -> None:
    """Unit-strength fields in the chip's (Y, Z) axes into ``out`` (n, len(orders), 2) for
    ``poses`` (n, 3) (rotation rad, shift x, y mm) and ``geometry`` (7,) as
    ``magnetmap.MagnetPoseMap`` gives it; ``orders`` int64, each ≥ 1."""
    cx, cy, axis, sx, sy, sw, tilt = (geometry[0], geometry[1], geometry[2], geometry[3],
                                      geometry[4], geometry[5], geometry[6])
    chip_sin, chip_cos = math.sin(tilt), math.cos(tilt)
    top = 0
    for order in orders:
        top = max(top, order)
    p = np.empty(top + 1)
    dp = np.empty(top + 1)
    for i in range(poses.shape[0]):
        rotation = poses[i, 0]
        cos, sin = math.cos(rotation), math.sin(rotation)
        rx = sx - (cx * cos - cy * sin + poses[i, 1])
        ry = sy - (cx * sin + cy * cos + poses[i, 2])
        distance = math.sqrt(rx * rx + ry * ry + sw * sw)
        ex, ey = rx / distance, ry / distance  # the chip's axes lie in the bending plane
        ux, uy = math.cos(rotation + axis), math.sin(rotation + axis)
        c = ex * ux + ey * uy
        p[0], dp[0] = 1.0, 0.0
        for l in range(top):
            p[l + 1] = ((2 * l + 1) * c * p[l] - (l * p[l - 1] if l > 0 else 0.0)) / (l + 1)
            dp[l + 1] = (l + 1) * p[l] + c * dp[l]
        for j in range(orders.size):
            order = orders[j]
            radial, tangential = (order + 1) * p[order], dp[order]
            scale = distance ** -(order + 2)
            fx = (radial * ex - tangential * (ux - c * ex)) * scale
            fy = (radial * ey - tangential * (uy - c * ey)) * scale
            out[i, j, 0] = fx * chip_sin + fy * chip_cos
            out[i, j, 1] = fx * chip_cos - fy * chip_sin
