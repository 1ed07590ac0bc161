"""A synthetic surface where the contact point is known exactly, and contact paths over it."""

import numpy as np


class AngleSurface:
    """z = -k θ (60 / r): deflection grows with the contact's angle, falls with its reach (µT)."""

    k_uT = 8000.0

    def __call__(self, points):
        points = np.asarray(points, float)
        r = np.hypot(points[..., 0], points[..., 1])
        return -self.k_uT * np.arctan2(points[..., 1], points[..., 0]) * 60.0 / r

    def gradient(self, points):
        points = np.asarray(points, float)
        x, y = points[..., 0], points[..., 1]
        r2 = x * x + y * y
        r = np.sqrt(r2)
        theta = np.arctan2(y, x)
        dtheta = np.stack([-y / r2, x / r2], axis=-1)
        dinv_r = np.stack([-x / r ** 3, -y / r ** 3], axis=-1)
        return -self.k_uT * 60.0 * (dtheta / r[..., None] + theta[..., None] * dinv_r)


def contact_path(start, push_mm=4.0, slide=(-10.0, 0.0), step=0.05):
    """Contact points (n, 2) mm: pushed in along -y from ``start``, then slid by ``slide``."""
    start = np.asarray(start, float)
    push = [start + [0.0, -step * k] for k in range(int(push_mm / step) + 1)]
    direction = np.asarray(slide) / np.hypot(*slide)
    slide_pts = [push[-1] + direction * step * k for k in range(1, int(np.hypot(*slide) / step) + 1)]
    return np.array(push + slide_pts)
