"""Analytic calibration surfaces with known level sets, and raw grids made from them.

- Rigid whisker: z = g(θ), the whisker turns rigidly about the root; level sets are rays.
- Bent whisker: z = g(θ + κ r), level sets are Archimedean spirals θ = c - κ r (a whisker whose
  direction turns steadily with distance from the root).

g is a cubic in θ, so a polar polynomial of degree >= 3 represents either surface exactly.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq

KAPPA_RAD_PER_MM = 0.004


def g_uT(theta_rad):
    """Deflection of a rigid whisker turned by -θ (µT): monotone over [-1, 0.2] rad."""
    theta = np.asarray(theta_rad, float)
    return 12000.0 * theta + 3000.0 * theta ** 2 + 1500.0 * theta ** 3


def paper_grid_mm(step_mm=3.0, reach=(12.5, 65.0), angle_deg=(-44.5, 0.0)) -> np.ndarray:
    """The paper-like lattice in reach and angle bands (180 points with the defaults)."""
    n = int(np.ceil(reach[1] / step_mm))
    steps = np.arange(-n, n + 1) * step_mm
    x, y = (a.ravel() for a in np.meshgrid(steps, steps))
    r, a = np.hypot(x, y), np.degrees(np.arctan2(y, x))
    keep = (r >= reach[0]) & (r <= reach[1]) & (a >= angle_deg[0]) & (a <= angle_deg[1])
    return np.column_stack([x[keep], y[keep]])


def rigid_z(points_mm):
    p = np.asarray(points_mm, float)
    return g_uT(np.arctan2(p[..., 1], p[..., 0]))


def bent_z(points_mm, kappa=KAPPA_RAD_PER_MM):
    p = np.asarray(points_mm, float)
    return g_uT(np.arctan2(p[..., 1], p[..., 0]) + kappa * np.hypot(p[..., 0], p[..., 1]))


def level_angle_rad(z_uT: float) -> float:
    """θ with g(θ) = z."""
    return brentq(lambda t: float(g_uT(t)) - z_uT, -1.5, 0.5)


def rigid_tip_mm(z_uT: float, length_mm: float) -> np.ndarray:
    """Tip of the rigid whisker: the ray at g⁻¹(z), at the trace length."""
    theta = level_angle_rad(z_uT)
    return length_mm * np.array([np.cos(theta), np.sin(theta)])


def bent_tip_mm(z_uT: float, length_mm: float, entry_radius_mm: float,
                kappa=KAPPA_RAD_PER_MM) -> np.ndarray:
    """Tip for the bent surface under the tracers' root model: a straight segment from the root
    to the spiral at ``entry_radius_mm``, then the spiral for the rest of the arc."""
    c = level_angle_rad(z_uT)
    speed = lambda r: np.sqrt(1.0 + (kappa * r) ** 2)  # ds/dr along θ = c - κ r
    remaining = length_mm - entry_radius_mm
    r_tip = brentq(lambda r: quad(speed, entry_radius_mm, r, epsabs=1e-13)[0] - remaining,
                   entry_radius_mm, entry_radius_mm + remaining)
    theta = c - kappa * r_tip
    return r_tip * np.array([np.cos(theta), np.sin(theta)])
