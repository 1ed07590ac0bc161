"""A low-order polynomial from the root's pose (rotation, shift x, shift y) to one field axis.

The magnet rides on the suspension, so each field axis is a smooth function of the root's pose
alone. The map is fitted, not modelled: monomials of the scaled pose up to total degree
``degree``, with the shift (which stays within a few tenths of a millimetre on most builds) up to
second order by default, and no constant, because every axis is measured from its reading at
rest (pose 0). Where most of the compliance is in the root the shift reaches a large share of
the magnet's gap and the field is no longer
quadratic in it; ``mechfit.identify`` then raises the shift's order when the misfit asks.

A grid's poses form a two-parameter family (the rod's position) inside the three-dimensional
pose space, so some combinations of monomials nearly vanish on every grid point (singular values
a billionth of the largest). A plain least squares gives those combinations enormous
coefficients, and the residual then moves with the last digits of the poses: the suspension fit
built on it stopped in a different place from every start and on every CPU. A small ridge
(:data:`RIDGE_RELATIVE` of the largest singular value) leaves those combinations out smoothly;
every start then reaches one minimum (docs/calibration.md).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from whiskercal.errors import UsageError

DEFAULT_DEGREE = 3
MAX_SHIFT_ORDER = 2
# Tikhonov damping relative to the design's largest singular value: enough that the starts of a
# recorded grid's fit reach one minimum instead of stopping each in its own place, little enough
# that the default grid's fit is not biased (a tenfold larger ridge is).
RIDGE_RELATIVE = 3e-7


def exponents(degree: int = DEFAULT_DEGREE, max_shift_order: int = MAX_SHIFT_ORDER) -> np.ndarray:
    """Exponents (k, 3) of (rotation, shift x, shift y) of the map's monomials."""
    rows = [e for e in itertools.product(range(degree + 1), repeat=3)
            if 0 < sum(e) <= degree and e[1] + e[2] <= max_shift_order]
    return np.array(sorted(rows, key=lambda e: (sum(e), e[::-1])), dtype=int)


@dataclass(frozen=True)
class PoseMap:
    """Field axes (µT, from rest) as polynomials of the scaled pose.

    Attributes
    ----------
    exponents : ndarray (k, 3)
    scale : ndarray (3,)
        Rotation (rad) and shifts (mm) that map the fitted poses to about [-1, 1].
    coefficients : ndarray (k, m)
        One column per field axis, µT.
    """

    exponents: np.ndarray
    scale: np.ndarray
    coefficients: np.ndarray

    def __call__(self, pose: np.ndarray) -> np.ndarray:
        """Field axes (..., m) µT at poses (..., 3)."""
        return design(np.asarray(pose, float), self.exponents, self.scale) @ self.coefficients


def pose_scale(poses: np.ndarray) -> np.ndarray:
    """Largest |value| of each pose component (rotation rad, shifts mm), never zero."""
    return np.maximum(np.max(np.abs(poses), axis=0), 1e-9)


def design(poses: np.ndarray, exps: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Monomials (..., k) of the scaled poses (..., 3)."""
    scaled = poses / scale
    return np.prod(scaled[..., None, :] ** exps, axis=-1)


def fit_pose_map(poses: np.ndarray, fields_uT: np.ndarray, degree: int = DEFAULT_DEGREE,
                 weights: np.ndarray | None = None, max_shift_order: int = MAX_SHIFT_ORDER
                 ) -> tuple[PoseMap, np.ndarray]:
    """Least-squares map from poses (n, 3) to fields (n, m) µT; returns it and the residuals.

    ``weights`` (m,): 1/noise of each axis, so the residuals come out in standard errors.
    ``max_shift_order``: the highest power of the shift in a monomial (see :func:`exponents`).
    """
    poses, fields = np.asarray(poses, float), np.atleast_2d(np.asarray(fields_uT, float).T).T
    exps = exponents(degree, max_shift_order)
    if len(poses) <= len(exps):
        raise UsageError(f"a degree-{degree} pose map needs more than {len(exps)} points, "
                         f"got {len(poses)}.")
    scale = pose_scale(poses)
    matrix = design(poses, exps, scale)
    coefficients = _ridge_solve(matrix, fields)
    residual = matrix @ coefficients - fields
    if weights is not None:
        residual = residual * np.asarray(weights, float)
    return PoseMap(exps, scale, coefficients), residual


def _ridge_solve(matrix: np.ndarray, fields: np.ndarray) -> np.ndarray:
    """argmin ‖A·c − f‖² + (λ‖c‖)² with λ = :data:`RIDGE_RELATIVE` · σ_max(A), by the SVD."""
    u, singular, vt = np.linalg.svd(matrix, full_matrices=False)
    if not singular[0] > 0:  # every pose at rest: nothing to fit
        return np.zeros((matrix.shape[1], fields.shape[1]))
    damping = RIDGE_RELATIVE * singular[0]
    return vt.T @ ((singular / (singular ** 2 + damping ** 2))[:, None] * (u.T @ fields))
