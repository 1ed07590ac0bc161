"""The shaft localizer's own measurement surface: z over contact points, from the root to the tip.

The tip model's surface (``model.calibrate``) is a degree-5 polynomial over the part of the grid
the level set is traced in: its ripple bounds a shaft contact's error at some radii, and it is
extrapolated wherever the grid does not reach (the default grid leaves the trace's first fifth
and its last millimetres uncovered). The shaft
localizer needs z at every point a contact can slide over, so it gets a surface of its own, in
three radial patches (:class:`~whiskercal.model.patched_surface.PatchedSurface`):

- the middle: a degree-8 polynomial over every contact of the grid (rod-corrected, near-root
  points included), at the noise on the default grid;
- toward the root and toward the tip, where the grid is sparse or absent: polynomials fitted to
  the grid's contacts there plus the mechanics-informed model (``mechfit``, fitted to every
  contact by ``fit``'s tip model) solved for rod contacts on columns reaching from 15 % of the
  trace to its end. The mechanics extrapolates as a whisker does, a polynomial does not.

Without an identified mechanics model (none fitted, or its χ² per degree of freedom over
``mechfit.identify.MAX_CHI2_PER_DOF``) the middle patch stands alone and the surface is
extrapolated past the grid by its polynomial. docs/shaft.md has the candidates and their measured
accuracy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from whiskercal.mechfit.forward import pose_of, rod_equilibria
from whiskercal.mechfit.identify import MAX_CHI2_PER_DOF
from whiskercal.model.errors import ModelError
from whiskercal.model.calibrate import contact_mask
from whiskercal.model.grid_contacts import SHAFT_DEGREE, degree_for, grid_contacts
from whiskercal.model.patched_surface import PatchedSurface
from whiskercal.model.surface import fit_fixed

MIDDLE_DEGREE = SHAFT_DEGREE
ROOT_DEGREE = 8
TIP_DEGREE = 5
BLEND_MM = 4.0
# patch edges and extents, mm from the grid's nearest and farthest contact (chosen on the default
# sensor, docs/shaft.md): the middle patch holds from 2 mm inside the grid's near end to 4 mm
# inside its far end; the root patch is fitted up to 7 mm inside the grid, the tip patch from
# 12 mm inside it, so each overlaps the grid by more than the blend.
ROOT_EDGE_INSIDE_MM, ROOT_FIT_INSIDE_MM = 2.0, 7.0
TIP_EDGE_INSIDE_MM, TIP_FIT_INSIDE_MM = 4.0, 12.0
# the mechanics is solved on rod columns every 1.5 mm from 15 % of the trace to 1 mm past it, each
# pushed in (0.25 mm steps at first, then 1 mm) to 60 % of its x (31°) or the grid's largest |z|
COLUMN_STEP_MM, PUSH_STEP_MM, ROOT_START_FRACTION = 1.5, 1.0, 0.15
# a rod column closer to the centre of rotation than the fitted clamp cannot bend the wire
CLAMP_CLEARANCE_MM = 0.5
FIRST_PUSHES_MM = np.array([0.25, 0.5, 0.75, 1.0, 1.5])


@dataclass
class ShaftSurfaceFit:
    """The shaft surface and its evidence: RMS misfit on the grid's contacts (µT), what the
    patches came from (``"grid+mechanics"`` or ``"grid"``), and the points behind each."""

    surface: PatchedSurface
    rmse_uT: float
    source: str
    mechanics_points: int
    cv_rmse_uT: float = float("nan")


def mechanics_contacts(fit, trace_length_mm: float, rod_radius_mm: float, z_limit_uT: float,
                       bands_mm: list[tuple[float, float]]) -> tuple[np.ndarray, np.ndarray]:
    """Contact points (mm) and z (µT) of the fitted mechanics (``mechfit`` ``MechanicsFit``)
    under the rod on columns whose x lies in one of ``bands_mm``: shaft contacts only, |z| up to
    ``z_limit_uT``."""
    xs = np.arange(ROOT_START_FRACTION * trace_length_mm, trace_length_mm + 1.0, COLUMN_STEP_MM)
    xs = xs[[any(lo - 2.0 <= x <= hi + 2.0 for lo, hi in bands_mm) for x in xs]]
    xs = xs[xs > fit.suspension.stub_mm + CLAMP_CLEARANCE_MM]  # the stub is rigid: no contact
    # the first millimetre of each push in finer steps: z changes fastest there near the root
    pushes = np.concatenate([FIRST_PUSHES_MM, np.arange(2.0, 0.6 * xs.max() + rod_radius_mm,
                                                        PUSH_STEP_MM)]) if xs.size else []
    centers = np.array([[x, rod_radius_mm - push] for x in xs for push in pushes
                        if rod_radius_mm - push > -0.6 * x])
    if centers.size == 0:
        return np.zeros((0, 2)), np.zeros(0)
    equilibria = rod_equilibria(fit.suspension, centers, rod_radius_mm)
    shaft = np.array([e.in_contact and e.kind == "shaft" for e in equilibria])
    poses = np.array([pose_of(e) for e in equilibria])
    z = fit.pose_map(poses)[:, 0]
    points = np.array([e.contact_mm for e in equilibria])
    keep = shaft & (np.abs(z) <= z_limit_uT) & np.all(np.isfinite(points), axis=1)
    # where a contact begins, on the undeflected whisker, z is its reading at rest: 0
    touch = np.column_stack([xs, np.zeros_like(xs)])
    return np.vstack([points[keep], touch]), np.concatenate([z[keep], np.zeros(len(xs))])


def _patch(points, z, extra_points, extra_z, low_mm, high_mm, degree):
    radial, extra_radial = np.hypot(*points.T), np.hypot(*extra_points.T)
    inside, extra_inside = (radial >= low_mm) & (radial <= high_mm), \
        (extra_radial >= low_mm) & (extra_radial <= high_mm)
    band_z = np.concatenate([z[inside], extra_z[extra_inside]])
    surface, _ = fit_fixed(np.vstack([points[inside], extra_points[extra_inside]]), band_z,
                           degree_for(len(band_z), degree))
    return surface


def shaft_surface_for(raw, trace_length_mm: float, mechanics=None) -> ShaftSurfaceFit | None:
    """:func:`fit_shaft_surface` of a raw grid (``artifacts.raw_grid.RawGrid``), or None when
    the grid has too few contacts for any surface (the localizer then uses the tip model's)."""
    try:
        return fit_shaft_surface(raw.rod_center_mm, raw.z_uT, raw.z_sem_uT, raw.rod_radius_mm,
                                 trace_length_mm, mechanics)
    except (ModelError, ValueError, np.linalg.LinAlgError):
        return None


def fit_shaft_surface(rod_center_mm, z_uT, z_sem_uT, rod_radius_mm: float,
                      trace_length_mm: float, mechanics=None) -> ShaftSurfaceFit:
    """The shaft localizer's surface for a raw grid's contacts (module docstring).

    ``mechanics``: the ``mechfit.identify.MechanicsCalibration`` fitted to the same grid, or
    None (then the grid's own polynomial alone).
    """
    points, z = grid_contacts(rod_center_mm, z_uT, z_sem_uT, rod_radius_mm)
    used = contact_mask(np.asarray(z_uT, float), z_sem_uT)
    columns = np.round(np.asarray(rod_center_mm, float)[used][:, 0], 1)
    usable = mechanics is not None and mechanics.chi2_per_dof <= MAX_CHI2_PER_DOF
    if not usable:
        build = _grid_only
    else:
        radial = np.hypot(*points.T)
        near, far = float(radial.min()), float(radial.max())
        root_band = (ROOT_START_FRACTION * trace_length_mm, near + ROOT_FIT_INSIDE_MM)
        tip_band = (far - TIP_FIT_INSIDE_MM, trace_length_mm + 2.0)
        extra = mechanics_contacts(mechanics.fit, trace_length_mm, rod_radius_mm,
                                   float(np.max(np.abs(z))), [root_band, tip_band])

        def build(points_, z_):
            return _patched(points_, z_, extra, root_band, tip_band, (near, far))
    surface = build(points, z)
    source, count = ("grid+mechanics", len(extra[1])) if usable else ("grid", 0)
    return ShaftSurfaceFit(surface, _rms(surface, points, z), source, count,
                           _column_cv_rmse(build, points, z, columns))


def _grid_only(points: np.ndarray, z: np.ndarray) -> PatchedSurface:
    middle, _ = fit_fixed(points, z, degree_for(len(z), MIDDLE_DEGREE))
    return PatchedSurface([middle], np.zeros(0), BLEND_MM)


def _patched(points, z, extra, root_band, tip_band, grid_span) -> PatchedSurface:
    middle, _ = fit_fixed(points, z, degree_for(len(z), MIDDLE_DEGREE))
    root = _patch(points, z, *extra, *root_band, ROOT_DEGREE)
    tip = _patch(points, z, *extra, *tip_band, TIP_DEGREE)
    near, far = grid_span
    return PatchedSurface([root, middle, tip],
                          [near + ROOT_EDGE_INSIDE_MM, far - TIP_EDGE_INSIDE_MM], BLEND_MM)


def _column_cv_rmse(build, points: np.ndarray, z: np.ndarray, columns: np.ndarray) -> float:
    """The surface's misfit between the grid's columns (µT): each inner column left out in turn,
    the surface refitted without it and judged on it. The misfit on the grid's own contacts
    understates the error a sliding contact meets between and beyond them; a contact slides
    over the surface between the columns. The end columns are left in (leaving one out would
    measure extrapolation, which the mechanics patches, not the grid, decide there)."""
    inner = np.unique(columns)[1:-1]
    squares = []
    for column in inner:
        out = columns == column
        try:
            surface = build(points[~out], z[~out])
        except (ModelError, ValueError, np.linalg.LinAlgError):
            continue
        squares.append((surface(points[out]) - z[out]) ** 2)
    return float(np.sqrt(np.mean(np.concatenate(squares)))) if squares else float("nan")


def _rms(surface, points: np.ndarray, z: np.ndarray) -> float:
    return float(np.sqrt(np.mean((surface(points) - z) ** 2)))
