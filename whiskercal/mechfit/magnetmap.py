"""A physically shaped pose map: the field of a magnet that rides on the suspension.

The polynomial pose map (``fieldmap.py``) fits the shaft-contact grid well but extrapolates badly
to poses the grid never shows (a tip load with friction turns and shifts the root in other
proportions: 130-700 µT off on plane contacts). This map has the shape of the physics instead: an
axially symmetric source (a multipole expansion about a centre, dipole first) fixed in the
suspension's frame, turned by the root rotation about the centre of rotation and moved by the
root shift, seen at a fixed sensing point through two chip axes tilted in the bending plane.

Nonlinear parameters (``geometry``, mm and rad): the source's centre (x, y) in the suspension
frame at rest, its axis angle, the sensing point (x, y, w) and the chip's tilt. Linear
parameters: one strength per multipole order (µT·mm^(l+2)), from least squares for a given
geometry. The map returns each axis minus its value at rest, as the grid's fields are measured.
Nothing here knows the twin's magnet: only its form (a magnet on the suspension) is assumed.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.optimize import least_squares

from whiskercal.errors import UsageError
from whiskercal.mechfit.multipole_kernel import multipole_fields

DEFAULT_ORDERS = (1, 2, 3, 4)
# generic starts (mm): a magnet a few mm under the pivot, the chip a few mm below it on the axis
START_CENTERS_MM = (-3.0, -6.0)
START_GAP_MM = 2.5
START_OUT_OF_PLANE_MM = 0.05  # |w| enters squared: start off the symmetric point


def multipole_basis(geometry: np.ndarray, pose: np.ndarray, orders=DEFAULT_ORDERS) -> np.ndarray:
    """Unit-strength fields (..., len(orders), 2) in the chip's (Y, Z) axes at poses (..., 3).

    Axial multipole of order l with potential P_l(u·r̂)/r^(l+1): B = r^-(l+2)·((l+1)P_l r̂ −
    P_l'(u − (u·r̂) r̂)), r from the source's centre to the sensing point.
    """
    pose = np.asarray(pose, float)
    flat = np.ascontiguousarray(pose.reshape(-1, 3))
    out = np.empty((len(flat), len(orders), 2))
    multipole_fields(np.ascontiguousarray(geometry, dtype=float), flat,
                     np.asarray(orders, np.int64), out)
    return out.reshape(pose.shape[:-1] + out.shape[1:])


def relative_basis(geometry: np.ndarray, pose: np.ndarray, orders=DEFAULT_ORDERS) -> np.ndarray:
    """The basis less its value at rest (pose 0)."""
    geometry = np.asarray(geometry, float)
    return multipole_basis(geometry, pose, orders) - _rest_basis(geometry.tobytes(), tuple(orders))


@lru_cache(maxsize=16)
def _rest_basis(geometry: bytes, orders: tuple[int, ...]) -> np.ndarray:
    """``multipole_basis`` at rest for a geometry (as bytes), kept for the last few: a joint
    fit's finite-difference steps in the mechanics and the stage offset leave the geometry."""
    basis = multipole_basis(np.frombuffer(geometry), np.zeros(3), orders)
    basis.flags.writeable = False
    return basis


@dataclass(frozen=True)
class MagnetPoseMap:
    """Field axes (µT, from rest; Y then Z) of a fitted multipole source at root poses.

    ``geometry`` (7,): source centre x, y (mm), axis angle (rad), sensing point x, y, w (mm),
    chip tilt (rad); ``strengths`` (len(orders),) µT·mm^(l+2); ``axes``: how many of (Y, Z).
    """

    geometry: np.ndarray
    strengths: np.ndarray
    orders: tuple[int, ...] = DEFAULT_ORDERS
    axes: int = 2

    def __call__(self, pose: np.ndarray) -> np.ndarray:
        """Field axes (..., axes) µT at poses (..., 3)."""
        basis = relative_basis(self.geometry, pose, self.orders)
        return np.einsum("...lk,l->...k", basis, self.strengths)[..., :self.axes]

    @property
    def coefficients(self) -> np.ndarray:
        """Shape (k, axes) like the polynomial map's, so callers can ask how many axes it has."""
        return np.zeros((len(self.strengths), self.axes))

    def as_dict(self) -> dict:
        return {"kind": "multipole", "geometry": self.geometry.tolist(),
                "strengths": self.strengths.tolist(), "orders": list(self.orders),
                "axes": self.axes}


def _linear_strengths(basis: np.ndarray, fields: np.ndarray, weights: np.ndarray):
    """Strengths by weighted least squares; basis (n, l, 2), fields (n, m)."""
    m = fields.shape[1]
    design = (basis[..., :m] * weights).transpose(0, 2, 1).reshape(-1, basis.shape[1])
    target = (fields * weights).reshape(-1)
    strengths, *_ = np.linalg.lstsq(design, target, rcond=None)
    return strengths, design @ strengths - target


class _GeometryResidual:
    def __init__(self, poses, fields, weights, orders):
        self.poses, self.fields, self.weights, self.orders = poses, fields, weights, orders

    def __call__(self, geometry):
        basis = relative_basis(geometry, self.poses, self.orders)
        if not np.all(np.isfinite(basis)):
            return np.full(self.fields.size, 1e6)
        return _linear_strengths(basis, self.fields, self.weights)[1]


def start_geometries() -> list[np.ndarray]:
    """Generic starts: the source on the axis under the pivot, the chip below it."""
    return [np.array([c, 0.0, 0.0, c - START_GAP_MM, 0.0, START_OUT_OF_PLANE_MM, 0.0])
            for c in START_CENTERS_MM]


def fit_magnet_map(poses: np.ndarray, fields_uT: np.ndarray, weights=None,
                   orders=DEFAULT_ORDERS, starts=None, max_evaluations: int = 400
                   ) -> tuple[MagnetPoseMap, np.ndarray]:
    """Fit the geometry (nonlinear) and strengths (linear) to poses (n, 3) and fields (n, m) µT.

    Returns the map and the residuals (n, m) in standard errors when ``weights`` (1/noise per
    axis) is given, else µT. ``starts``: geometries to start from (the best result is kept).
    """
    poses = np.asarray(poses, float)
    fields = np.atleast_2d(np.asarray(fields_uT, float).T).T
    if fields.shape[1] > 2:
        raise UsageError("the magnet map answers the Y and Z axes only.")
    w = np.ones(fields.shape[1]) if weights is None else np.asarray(weights, float)
    residual = _GeometryResidual(poses, fields, w, orders)
    best = None
    for start in (starts if starts is not None else start_geometries()):
        result = least_squares(residual, np.asarray(start, float), x_scale=0.1,
                               max_nfev=max_evaluations, xtol=1e-12, ftol=1e-12)
        if best is None or result.cost < best.cost:
            best = result
    geometry = best.x
    strengths, scaled = _linear_strengths(relative_basis(geometry, poses, orders), fields, w)
    out = scaled.reshape(len(poses), fields.shape[1])
    return MagnetPoseMap(geometry, strengths, tuple(orders), fields.shape[1]), out
