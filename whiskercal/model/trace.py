"""Tip extraction: trace the level set f(x, y) = z from the root for the whisker's arc length.

The root is singular: every level set meets there, and the grid starts well away from it (the
rod cannot touch the shaft next to the suspension), so the polynomial near the root is pure
extrapolation. Both tracers therefore share how they start and end:

1. the **entry point**: on the circle of radius ``entry_radius_mm`` about the root, the point
   where f = z (a bracketed root search over the circle's arc inside the calibrated domain; the
   circle grows in 1 mm steps when that arc misses the level set);
2. the **root segment**: a straight line from the root to the entry point, its length counted in
   full. Near the root the whisker is a rigid stub on a rotating suspension, and rod contacts
   there mostly translate the suspension, so the level sets say little about the shaft;
3. the **traced part**: from the entry point along f = z, outward;
4. the **extension**: where the grid stops short of the tip (it must, or the rod slips off the
   tip), the trace stops on the circle ``extension_radius_mm`` (or a far-facing hull edge) and
   continues straight along the level set's chord for the rest of the arc, at most
   ``tip_extension_mm``.

The trace must otherwise stay inside the calibrated domain (the grid's convex hull grown by a
margin), |grad f| must not vanish, and z must lie in the calibrated range; each failure raises
its own :class:`TraceError` subclass. :func:`trace_paper` is the paper's fixed step (tangent plus
Gauss-Newton pull-back); :func:`trace_fast` integrates the unit tangent field with an adaptive
Dormand-Prince 5(4) and projects the end onto f = z by Newton steps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq
from scipy.spatial import ConvexHull

from whiskercal.model.errors import (DomainExitError, ModelError, NonConvergenceError,
                                     TraceDriftError, VanishingGradientError, ZOutOfRangeError)
from whiskercal.model.ode import integrate
from whiskercal.model.surface import Surface

PAPER_STEP_MM = 1e-3
EXTENSION_CHORD_MM = 5.0  # chord length that sets the tip-side extension's direction
# A fixed-step trace may lie at most this fraction of its step off the level set (a turn of the
# tangent of about 2 x 0.03 rad = 3.4 degrees per step): on the twin every trace under it erred
# by well under the model error, and traces well above it by much more (docs/research, the
# stability map).
DRIFT_FRACTION_OF_STEP = 0.03
DRIFT_FLOOR_MM = 1e-9


@dataclass(frozen=True)
class Domain:
    """The calibrated domain: convex hull of the grid points grown by ``margin_mm``."""

    equations: np.ndarray  # (m, 3): unit outward normal (a, b) and offset c, a·p + c <= 0 inside
    vertices_mm: np.ndarray  # (m, 2) hull vertices
    margin_mm: float

    @classmethod
    def from_points(cls, points_mm: np.ndarray, margin_mm: float) -> "Domain":
        """Domain of grid points (n, 2) mm."""
        hull = ConvexHull(np.asarray(points_mm, float))
        return cls(hull.equations.copy(), hull.points[hull.vertices].copy(), float(margin_mm))

    def distance_inside_mm(self, points_mm: np.ndarray) -> np.ndarray:
        """Signed distance (mm) to the grown hull's boundary, positive inside, vectorized."""
        p = np.asarray(points_mm, float)
        return self.margin_mm - np.max(p @ self.equations[:, :2].T + self.equations[:, 2], axis=-1)

    def contains(self, points_mm: np.ndarray) -> np.ndarray:
        """True where points (..., 2) lie in the grown hull."""
        return self.distance_inside_mm(points_mm) >= 0.0

    def angle_range_rad(self, center_mm) -> tuple[float, float]:
        """Angles (rad) spanned by the hull as seen from a point outside it (no wrap-around)."""
        offsets = self.vertices_mm - np.asarray(center_mm, float)
        mean_direction = math.atan2(offsets[:, 1].mean(), offsets[:, 0].mean())
        relative = np.arctan2(offsets[:, 1], offsets[:, 0]) - mean_direction
        relative = (relative + math.pi) % (2 * math.pi) - math.pi
        return mean_direction + float(relative.min()), mean_direction + float(relative.max())


@dataclass(frozen=True)
class LevelSetProblem:
    """Everything a tracer needs besides z.

    Attributes
    ----------
    surface : Surface
        z = f(x, y), µT over mm (contact coordinates).
    domain : Domain
        Where f is trusted.
    trace_length_mm : float
        Arc length from the root to the tip (rigid stub + wire).
    z_range_uT : (float, float)
        Calibrated deflection range, low to high.
    entry_radius_mm : float
        Radius about the root at which the trace enters the data.
    root_mm : ndarray (2,)
        Root position at z = 0.
    root_shift_mm_per_uT : ndarray (2,)
        Linear displacement of the root with z (the suspension translates); zero for the paper's
        fixed p_r.
    min_gradient_uT_per_mm : float
        Below this |grad f| the level set has no trustworthy direction.
    extension_radius_mm : float or None
        The grid stops short of the tip (so that the rod cannot slip off it): a trace reaching this
        radius about the root inside the domain continues straight for the rest of its arc (past
        the last contact the shaft carries no moment). A circle rather than the hull's polygon,
        so the tip moves smoothly with z. None: the whole arc must lie inside the domain.
    tip_extension_mm : float
        Longest straight extension allowed (mm); a longer one is a domain exit.
    """

    surface: Surface
    domain: Domain
    trace_length_mm: float
    z_range_uT: tuple[float, float]
    entry_radius_mm: float
    root_mm: np.ndarray = field(default_factory=lambda: np.zeros(2))
    root_shift_mm_per_uT: np.ndarray = field(default_factory=lambda: np.zeros(2))
    min_gradient_uT_per_mm: float = 1e-3
    extension_radius_mm: float | None = None
    tip_extension_mm: float = 0.0

    def root_at(self, z_uT: float) -> np.ndarray:
        """Root position (mm) at deflection z."""
        return np.asarray(self.root_mm, float) + z_uT * np.asarray(self.root_shift_mm_per_uT, float)


@dataclass(frozen=True)
class TraceResult:
    """A successful trace: the tip and how it was reached."""

    tip_mm: np.ndarray
    entry_mm: np.ndarray
    root_mm: np.ndarray
    evaluations: int
    extension_mm: float = 0.0
    path_mm: np.ndarray | None = None


def _check_z(problem: LevelSetProblem, z_uT: float) -> None:
    low, high = problem.z_range_uT
    if not (np.isfinite(z_uT) and low <= z_uT <= high):
        raise ZOutOfRangeError(f"z = {z_uT:.1f} µT is outside the calibrated range "
                               f"[{low:.1f}, {high:.1f}] µT")


def find_entry(problem: LevelSetProblem, z_uT: float, n_angles: int = 121,
               radius_step_mm: float = 1.0) -> np.ndarray:
    """The point where the trace enters the data: f = z on a circle about the root (mm).

    The circle of radius ``entry_radius_mm`` is tried first. When its arc inside the domain
    misses f = z (steep deflections on a rectangular grid), the first circle, in
    ``radius_step_mm`` steps up to half the trace length, that crosses it is found, and the
    radius between the two is bisected to where the level set enters the domain: the entry then
    moves continuously with z, and so does the tip. The crossing is refined by a bracketed root
    search on the circle.
    """
    root = problem.root_at(z_uT)
    radii = np.arange(problem.entry_radius_mm, problem.trace_length_mm / 2, radius_step_mm)
    entry = _first_entry(problem, z_uT, root, radii[:1], n_angles)  # the usual case, cheaply
    if entry is not None:
        return entry
    entry = _first_entry(problem, z_uT, root, radii[1:], n_angles)
    if entry is None:
        raise ZOutOfRangeError(f"z = {z_uT:.1f} µT has no level set entering the calibrated domain "
                               f"within {problem.trace_length_mm / 2:.1f} mm of the root")
    outside, inside = float(np.hypot(*(entry - root))) - radius_step_mm, entry
    for _ in range(30):  # 1 mm / 2^30: far below the tracers' accuracy
        middle = (outside + float(np.hypot(*(inside - root)))) / 2
        found = _first_entry(problem, z_uT, root, np.array([middle]), n_angles)
        if found is None:
            outside = middle
        else:
            inside = found
    return inside


def _first_entry(problem: LevelSetProblem, z_uT: float, root: np.ndarray, radii: np.ndarray,
                 n_angles: int) -> np.ndarray | None:
    low, high = problem.domain.angle_range_rad(root)
    pad = (high - low) * 0.05  # the grown margin widens the hull slightly
    angles = np.linspace(low - pad, high + pad, n_angles)
    circles = root + radii[:, None, None] * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    residual = problem.surface(circles) - z_uT
    inside = problem.domain.contains(circles)
    crossing = (inside[:, :-1] & inside[:, 1:]
                & (np.sign(residual[:, :-1]) != np.sign(residual[:, 1:])))
    rows = np.flatnonzero(crossing.any(axis=1))
    if rows.size == 0:
        return None
    radius, k = radii[rows[0]], int(np.flatnonzero(crossing[rows[0]])[0])

    def on_circle(angle: float) -> float:
        x, y = root[0] + radius * math.cos(angle), root[1] + radius * math.sin(angle)
        return problem.surface.value_and_gradient(x, y)[0] - z_uT

    low_residual, high_residual = on_circle(angles[k]), on_circle(angles[k + 1])
    if low_residual * high_residual < 0:
        angle = brentq(on_circle, angles[k], angles[k + 1], xtol=1e-14)
    else:
        # the scalar and the vectorized surface differ in the last bits: at a crossing this
        # close to a sample angle, that sample is the entry
        angle = angles[k] if abs(low_residual) <= abs(high_residual) else angles[k + 1]
    return root + radius * np.array([math.cos(angle), math.sin(angle)])


def _orientation(problem: LevelSetProblem, entry: np.ndarray, root: np.ndarray) -> float:
    """+1 or -1: which of the two level-set tangents points away from the root."""
    _, fx, fy = problem.surface.value_and_gradient(*entry)
    return 1.0 if (fy * (entry[0] - root[0]) - fx * (entry[1] - root[1])) >= 0 else -1.0


def _gradient_floor_error(problem: LevelSetProblem, point) -> VanishingGradientError:
    return VanishingGradientError(
        f"|grad f| fell below {problem.min_gradient_uT_per_mm:g} µT/mm at "
        f"({point[0]:.2f}, {point[1]:.2f}) mm: the level set has no direction there")


def _start(problem: LevelSetProblem, z_uT: float) -> tuple[np.ndarray, np.ndarray, float, float]:
    _check_z(problem, z_uT)
    root = problem.root_at(z_uT)
    entry = find_entry(problem, z_uT)
    remaining = problem.trace_length_mm - float(np.linalg.norm(entry - root))
    if remaining <= 0:
        raise ZOutOfRangeError("the trace length is shorter than the entry radius")
    return root, entry, remaining, _orientation(problem, entry, root)


FAR_FACING_COSINE = 0.7  # an edge whose normal is within ~45° of radial faces away from the root


def far_edge_radius(points_mm: np.ndarray, root_mm=(0.0, 0.0), quantile: float = 0.95) -> float:
    """Radius (mm) about the root where tracing hands over to the straight extension.

    The 95th percentile of the grid's radii: inside the grid's far side for a grid laid out in
    reach and angle bands (the trace then stops on a circle, and the tip moves smoothly with z);
    on other grids a far-facing hull edge may come first, which :func:`_check_stop` also accepts.
    """
    radius = np.linalg.norm(np.asarray(points_mm, float) - np.asarray(root_mm, float), axis=1)
    return float(np.quantile(radius, quantile))


def _region(problem: LevelSetProblem, root: np.ndarray):
    """Signed distance (mm, positive inside) to where tracing stops: domain edge or extension circle."""
    hull = problem.domain.distance_inside_mm
    radius, rx, ry = problem.extension_radius_mm, float(root[0]), float(root[1])
    if radius is None:
        return lambda x, y: float(hull(np.array([x, y])))
    return lambda x, y: min(float(hull(np.array([x, y]))), radius - math.hypot(x - rx, y - ry))


def _check_stop(problem: LevelSetProblem, root: np.ndarray, x: float, y: float,
                remaining_mm: float) -> None:
    """A trace that stopped short must have reached the grid's far side: the extension circle,
    or a hull edge that faces away from the root (not a side edge along which level sets run,
    where the exit point would jump from edge to edge as z changes)."""
    if remaining_mm <= 1e-12:
        return
    radius = problem.extension_radius_mm
    offset = np.array([x, y]) - root
    distance = float(np.hypot(*offset))
    if radius is not None and distance >= radius - 1e-6:
        return
    equations = problem.domain.equations
    facet = equations[int(np.argmax(equations[:, :2] @ [x, y] + equations[:, 2]))]
    if radius is None or facet[:2] @ offset < FAR_FACING_COSINE * distance:
        raise DomainExitError(f"the trace left the calibrated domain at ({x:.2f}, {y:.2f}) mm "
                              f"with {remaining_mm:.1f} mm of arc to go: z needs a larger grid")


def _extend(problem: LevelSetProblem, edge: tuple[float, float], back: tuple[float, float],
            remaining_mm: float) -> tuple[np.ndarray, float]:
    """Continue straight from the domain's edge for the remaining arc.

    The direction is the chord from ``back`` (a point ``EXTENSION_CHORD_MM`` back along the
    level set) to ``edge``: a polynomial's gradient is least accurate at the edge of its data,
    and the chord averages it out.
    """
    if remaining_mm <= 1e-12:
        return np.array(edge), 0.0
    if remaining_mm > problem.tip_extension_mm:
        raise DomainExitError(
            f"the trace reached the grid's far edge at ({edge[0]:.2f}, {edge[1]:.2f}) mm with "
            f"{remaining_mm:.1f} mm of arc to go (at most {problem.tip_extension_mm:.1f} mm may be "
            f"extrapolated)")
    chord = np.subtract(edge, back)
    return np.asarray(edge) + remaining_mm * chord / np.linalg.norm(chord), remaining_mm


def _paper_walk(problem: LevelSetProblem, start: tuple[float, float], z_uT: float, sign: float,
                length_mm: float, step_mm: float, path: list | None = None,
                region=None) -> tuple[float, float, float, float]:
    """Fixed steps from ``start`` for ``length_mm`` or until the domain's edge.

    Returns (x, y, travelled, drift): drift is the largest distance (mm) off the level set,
    |f - z| / |grad f|, seen at the start of a step (that is, after the previous step's tangent
    advance and before its pull-back). The domain is tested whenever the distance to its boundary
    could have been used up, so the edge is found to within one step.
    """
    vg, floor2 = problem.surface.value_and_gradient, problem.min_gradient_uT_per_mm ** 2
    x, y = start
    n_full = int(length_mm // step_mm)
    next_check = 0 if region is not None else n_full + 1
    drift = 0.0
    for k in range(n_full + 1):
        if k >= next_check:
            margin = region(x, y)
            if margin < 0:
                return x, y, k * step_mm, drift
            next_check = k + max(1, int(0.5 * margin / step_mm))
        h = step_mm if k < n_full else length_mm - n_full * step_mm
        f, fx, fy = vg(x, y)
        g2 = fx * fx + fy * fy
        if g2 < floor2:
            raise _gradient_floor_error(problem, (x, y))
        inv, pull = 1.0 / math.sqrt(g2), (f - z_uT) / g2
        off = abs(f - z_uT) * inv
        if off > drift:  # not max(): this loop runs 50,000 times a trace at the paper's step
            drift = off
        x += sign * h * fy * inv - pull * fx
        y -= sign * h * fx * inv + pull * fy
        if path is not None:
            path.append((x, y))
    if region is not None and region(x, y) < 0:
        return x, y, n_full * step_mm, drift
    return x, y, length_mm, drift


def _distance_off(problem: LevelSetProblem, point, z_uT: float) -> float:
    """|f - z| / |grad f| at a point (mm): how far it lies off the level set, to first order."""
    f, fx, fy = problem.surface.value_and_gradient(float(point[0]), float(point[1]))
    return abs(f - z_uT) / max(math.hypot(fx, fy), problem.min_gradient_uT_per_mm)


def drift_tolerance_mm(step_mm: float) -> float:
    """Largest distance (mm) off the level set a fixed-step trace may show at ``step_mm``.

    After a tangent step of length h along a level set of curvature κ the point lies about
    κh²/2 off it, so drift / h is half the tangent's turn per step. ``DRIFT_FRACTION_OF_STEP``
    caps that turn; the absolute floor keeps round-off at tiny steps from counting as drift.
    """
    return max(DRIFT_FRACTION_OF_STEP * step_mm, DRIFT_FLOOR_MM)


def _check_drift(z_uT: float, step_mm: float, drift_mm: float) -> None:
    tolerance = drift_tolerance_mm(step_mm)
    if not drift_mm <= tolerance:
        raise TraceDriftError(
            f"the fixed-step trace at z = {z_uT:.1f} µT with a {step_mm:g} mm step drifted "
            f"{drift_mm:.3g} mm off the level set (tolerance {tolerance:.3g} mm, "
            f"{DRIFT_FRACTION_OF_STEP:g} of the step): use a smaller step")


def trace_paper(problem: LevelSetProblem, z_uT: float, step_mm: float = PAPER_STEP_MM,
                keep_path: bool = False) -> TraceResult:
    """The paper's tracer: fixed steps along the tangent plus a pull-back onto f = z.

    Each step moves ``step_mm`` along the unit tangent and adds the Gauss-Newton step of
    (f - z)²/2, -(f - z) grad f / |grad f|², which pulls the point back onto the level set; the
    arc length counts the tangent advances. The pull-back hides a step that is too coarse for
    the level set's curvature (the trace cuts corners, yet every step starts near f = z), so the
    distance off the level set is watched at every step and at the end: beyond
    :func:`drift_tolerance_mm` the trace raises :class:`TraceDriftError`.
    """
    root, entry, remaining, sign = _start(problem, z_uT)
    path = [tuple(entry)] if keep_path else None
    x, y, travelled, drift = _paper_walk(problem, (float(entry[0]), float(entry[1])), z_uT, sign,
                                         remaining, step_mm, path, _region(problem, root))
    _check_drift(z_uT, step_mm, max(drift, _distance_off(problem, (x, y), z_uT)))
    _check_stop(problem, root, x, y, remaining - travelled)
    back = (x, y)
    if remaining - travelled > 1e-12:
        bx, by, _, back_drift = _paper_walk(problem, (x, y), z_uT, -sign,
                                            min(EXTENSION_CHORD_MM, travelled), step_mm)
        _check_drift(z_uT, step_mm, back_drift)
        back = (bx, by)
    tip, extension = _extend(problem, (x, y), back, remaining - travelled)
    evaluations = int(round((travelled + (remaining - travelled > 0) * EXTENSION_CHORD_MM) / step_mm))
    return TraceResult(tip, entry, root, evaluations, extension,
                       np.array(path) if keep_path else None)


def _project(problem: LevelSetProblem, point: np.ndarray, z_uT: float,
             tolerance_uT: float = 1e-9, max_iterations: int = 20) -> np.ndarray:
    """Newton along the gradient onto f = z."""
    x, y = float(point[0]), float(point[1])
    for _ in range(max_iterations):
        f, fx, fy = problem.surface.value_and_gradient(x, y)
        g2 = fx * fx + fy * fy
        if g2 < problem.min_gradient_uT_per_mm ** 2:
            raise _gradient_floor_error(problem, (x, y))
        if abs(f - z_uT) <= tolerance_uT * max(1.0, abs(z_uT)):
            return np.array([x, y])
        x, y = x - (f - z_uT) * fx / g2, y - (f - z_uT) * fy / g2
    raise NonConvergenceError(f"projection onto f = {z_uT:.1f} µT did not converge")


def trace_fast(problem: LevelSetProblem, z_uT: float, rtol: float = 1e-10, atol_mm: float = 1e-10,
               pull_per_mm: float = 0.0) -> TraceResult:
    """Adaptive tracer: Dormand-Prince 5(4) on the unit tangent field of f, then a Newton projection.

    dp/ds = sign * t(p) - pull_per_mm * (f - z) grad f / |grad f|², with t the unit tangent.
    The tangent field's integral curves are the level sets themselves, so without the pull term
    (the default) the error is only the integrator's, removed across the level set by the final
    projection; a positive pull makes f = z attracting but costs steps. A step that would leave the domain is shortened to end on its boundary.
    """
    root, entry, remaining, sign = _start(problem, z_uT)
    vg, floor2 = problem.surface.value_and_gradient, problem.min_gradient_uT_per_mm ** 2
    counter = [0]

    def field(x: float, y: float) -> tuple[float, float]:
        counter[0] += 1
        f, fx, fy = vg(x, y)
        g2 = fx * fx + fy * fy
        if g2 < floor2:
            raise _gradient_floor_error(problem, (x, y))
        inv, pull = 1.0 / math.sqrt(g2), pull_per_mm * (f - z_uT) / g2
        return sign * fy * inv - pull * fx, -sign * fx * inv - pull * fy

    x, y, travelled, _ = integrate(field, (float(entry[0]), float(entry[1])), remaining,
                                   rtol=rtol, atol=atol_mm, inside=_region(problem, root))
    _check_stop(problem, root, x, y, remaining - travelled)
    edge = tuple(_project(problem, np.array([x, y]), z_uT))
    back = edge
    if remaining - travelled > 1e-12:
        sign = -sign  # walk back along the level set for the extension's chord
        back = integrate(field, edge, min(EXTENSION_CHORD_MM, travelled), rtol=rtol, atol=atol_mm)[:2]
    tip, extension = _extend(problem, edge, back, remaining - travelled)
    return TraceResult(tip, entry, root, counter[0], extension)


TRACERS = {"fast": trace_fast, "paper": trace_paper}


def get_tracer(name: str):
    """The tracer called ``name`` (a key of :data:`TRACERS`), or one clear error."""
    try:
        return TRACERS[name]
    except KeyError:
        raise ModelError(f"unknown tracer {name!r}; choose one of {', '.join(TRACERS)}") from None


def trace_many(problem: LevelSetProblem, z_uT: np.ndarray, tracer: str = "fast") -> np.ndarray:
    """Tips (n, 2) mm for several z with one tracer; raises on the first failure."""
    trace = get_tracer(tracer)
    return np.array([trace(problem, float(z)).tip_mm for z in np.atleast_1d(z_uT)])
