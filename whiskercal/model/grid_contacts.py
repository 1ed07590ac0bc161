"""A raw grid's contacts as contact points on the shaft, for surfaces over every contact.

The tip model's surface (``model.calibrate``) keeps only the part of the grid the level set is
traced in; the shaft localizer's surfaces (``fit.shaft_surface``, ``shaftstudy.static_yz``) keep
every contact, the near-root ones included, at a degree the points can carry.
"""

from __future__ import annotations

import numpy as np

from whiskercal.model.calibrate import contact_mask, correct_for_rod
from whiskercal.model.surface import fit_fixed

SHAFT_DEGREE = 8
"""Degree of a surface over every contact of the grid: the lowest whose residual on the default
grid reaches the noise of an averaged reading (docs/shaft.md)."""


def degree_for(points: int, wanted: int) -> int:
    """The highest degree up to ``wanted`` with at least two points per coefficient."""
    degree = wanted
    while degree > 1 and points < (degree + 1) * (degree + 2):
        degree -= 1
    return degree


def grid_contacts(rod_center_mm, z_uT, z_sem_uT, rod_radius_mm) -> tuple[np.ndarray, np.ndarray]:
    """Every contact of the grid as a contact point (rod-corrected, mm) and its z (µT)."""
    used = contact_mask(np.asarray(z_uT, float), z_sem_uT)
    centers, z = np.asarray(rod_center_mm, float)[used], np.asarray(z_uT, float)[used]
    first, _ = fit_fixed(centers, z, degree_for(len(z), SHAFT_DEGREE))
    return correct_for_rod(centers, z, rod_radius_mm, first), z
