"""Frictionless contact with a rod or circle, anywhere along the shaft or at the tip, and the
shared machinery of every contact solve (parameters, Newton, conversion to `Equilibrium`).

A solve without a usable `previous` follows the obstacle in from where it first touches the
undeflected whisker (moving it toward -side·y), warm-starting each small step: the elastica has
several equilibria for one obstacle pose, and this path picks the one the rig reaches.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.twin.physics import elastica as el
from whiskercal.twin.physics.obstacles import Circle
from whiskercal.twin.physics.whisker import Equilibrium, WhiskerParams

TOLERANCE = 1e-10          # nondimensional residual (L, EI/L², EI/L units)
MAX_ITER = 30
PATH_STEP = 0.08           # largest obstacle move (in L) between warm-started path solves


def check_whisker(whisker) -> WhiskerParams:
    """`whisker` if it is a WhiskerParams, else a UsageError."""
    if not isinstance(whisker, WhiskerParams):
        raise UsageError(f"expected WhiskerParams, got {type(whisker).__name__}.")
    return whisker


def base_params(whisker: WhiskerParams) -> np.ndarray:
    """Parameter vector with the root suspension in nondimensional form (a fresh copy)."""
    return _base_params(whisker).copy()


@functools.lru_cache(maxsize=16)
def _base_params(whisker: WhiskerParams) -> np.ndarray:
    # cached: a path through the world solves thousands of times with one whisker
    p = el.new_params()
    ei, length = whisker.bending_stiffness_n_mm2, whisker.length_mm
    p[el.P_STUB] = whisker.root_offset_mm / length
    p[el.P_CROT] = ei / (length * whisker.root_rotational_stiffness_n_mm_per_rad)
    p[el.P_CTRANS] = ei / (length ** 3 * whisker.root_translational_stiffness_n_per_mm)
    return p


def solve_kind(code: int, z0: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, bool]:
    """Newton on one contact system; returns (unknowns, converged)."""
    z, converged, _ = el.newton(code, np.asarray(z0, dtype=float), p, el.DEFAULT_STEPS,
                                TOLERANCE, MAX_ITER)
    return z, bool(converged and np.all(np.isfinite(z)))


def free(whisker: WhiskerParams, slipped_past: bool = False) -> Equilibrium:
    """The undeflected whisker: no contact, no force (see `Equilibrium.slipped_past`)."""
    check_whisker(whisker)
    nan2 = np.full(2, np.nan)
    return Equilibrium("free", 0.0, np.zeros(2), nan2, math.nan, np.zeros(2),
                       np.array([whisker.reach_mm, 0.0]), whisker, slipped_past=slipped_past)


def make_equilibrium(whisker, kind: str, code: int, z, p, sliding=False,
                     anchor_mm=math.nan, anchor_on=None, slips: int = 0,
                     stuck_step=None) -> Equilibrium:
    """Convert a nondimensional solution into an `Equilibrium` in mm, N, rad.

    `anchor_on`: a `Plane` whose surface coordinate of the tip becomes `anchor_mm`; `slips` and
    `stuck_step` pass through (see `Equilibrium`).
    """
    length, force_scale = whisker.length_mm, whisker.force_scale_n
    moment, fx, fy, arc = el.unpack(code, z, p)
    x, y, _, tip_x, tip_y = el.end_state(code, z, p, el.DEFAULT_STEPS)
    force = np.array([fx, fy])
    tip = np.array([tip_x, tip_y]) * length
    if anchor_on is not None:
        anchor_mm = anchor_on.anchor_of(tip)
    return Equilibrium(
        kind=kind, root_rotation_rad=float(p[el.P_CROT] * moment),
        root_shift_mm=p[el.P_CTRANS] * force * length, contact_mm=np.array([x, y]) * length,
        contact_arc_mm=float(arc * length), force_n=force * force_scale,
        tip_mm=tip, whisker=whisker, sliding=bool(sliding), anchor_mm=float(anchor_mm),
        slips=int(slips), solution=(code, np.array(z, dtype=float), p.copy()),
        stuck_step=stuck_step)


def circle_params(whisker, center_mm, radius_mm: float, side: int) -> np.ndarray:
    """Parameter vector for a circle (nondimensional centre and radius)."""
    p = base_params(whisker)
    p[el.P_CX], p[el.P_CY] = np.asarray(center_mm) / whisker.length_mm
    p[el.P_RADIUS] = radius_mm / whisker.length_mm
    p[el.P_SIDE] = side
    return p


def circle_state_ok(code: int, z, p) -> bool:
    """Is a converged circle contact physical: pushing, on the wire, not cutting into it?"""
    x, y, th, tip_x, tip_y = el.end_state(code, z, p, el.DEFAULT_STEPS)
    force = z[1:3]
    if code == el.SHAFT_CIRCLE:
        normal = p[el.P_SIDE] * np.array([math.sin(th), -math.cos(th)])
        return 0.0 < z[3] <= 1.0 and force @ normal > 0.0
    away = np.array([tip_x - p[el.P_CX], tip_y - p[el.P_CY]])
    tangent = np.array([math.cos(th), math.sin(th)])
    return force @ away > 0.0 and tangent @ away <= 1e-12


def _circle_step(code: int, z, p) -> tuple[int, np.ndarray | None]:
    """Solve one pose of a circle from the state (code, z); switch shaft <-> tip as needed."""
    for _ in range(2):
        z_new, ok = solve_kind(code, z, p)
        if ok and circle_state_ok(code, z_new, p):
            return code, z_new
        if code == el.SHAFT_CIRCLE and ok and z_new[3] > 1.0:
            code, z = el.TIP_CIRCLE, z_new[:3]
        elif code == el.TIP_CIRCLE and ok:
            code, z = el.SHAFT_CIRCLE, np.append(z_new, 0.999)
        else:
            return code, None
    return code, None


def _touch_y(whisker, center_x: float, radius: float, side: int) -> float | None:
    """y of the circle's centre (mm) when it first touches the undeflected wire, or None."""
    reach = whisker.reach_mm
    if center_x <= whisker.root_offset_mm:
        raise UsageError("the obstacle's centre must lie beyond the clamp "
                         f"(x > {whisker.root_offset_mm:g} mm): the root stub is rigid.")
    if center_x <= reach:
        return side * radius
    if center_x - radius >= reach:
        return None
    return side * math.sqrt(radius ** 2 - (center_x - reach) ** 2)


def swept_into_wire(whisker, circle: Circle) -> bool:
    """Has the circle, coming from its side, passed the height where it first touches the
    undeflected wire?"""
    x, y = circle.center_mm
    if circle.side * y >= circle.radius_mm:
        return False
    touch = _touch_y(whisker, x, circle.radius_mm, circle.side)
    return touch is not None and circle.side * (y - touch) < 0.0


def _circle_path(whisker, circle: Circle) -> tuple[int, np.ndarray, np.ndarray] | None:
    """Bring the circle in along -side·y from first touch; the final (code, z, p) or None."""
    center, radius, side = circle.center_mm, circle.radius_mm, circle.side
    touch = _touch_y(whisker, center[0], radius, side)
    if touch is None or side * (center[1] - touch) >= 0.0:
        return None
    travel = abs(center[1] - touch) / whisker.length_mm
    n_steps = max(2, int(math.ceil(travel / PATH_STEP)))
    if center[0] <= whisker.reach_mm:
        code, z = el.SHAFT_CIRCLE, np.array([0.0, 0.0, 0.0,
                                             (center[0] - whisker.root_offset_mm)
                                             / whisker.length_mm])
    else:
        code, z = el.TIP_CIRCLE, np.zeros(3)
    y_now = touch
    for y in np.linspace(touch, center[1], n_steps + 1)[1:]:
        found = _circle_advance(whisker, circle, code, z, y_now, y)
        if found is None:
            return None  # slipped past the circle: the whisker springs back
        code, z, p = found
        y_now = y
    return code, z, p


def _circle_advance(whisker, circle: Circle, code: int, z, y_from: float, y_to: float,
                    halvings: int = 4):
    """Move the circle's centre from y_from to y_to, halving the move where Newton fails; the
    new (code, z, p), or None when no contact survives even the smallest move."""
    p = circle_params(whisker, (circle.center_mm[0], y_to), circle.radius_mm, circle.side)
    new_code, new_z = _circle_step(code, z, p)
    if new_z is not None:
        return new_code, new_z, p
    if halvings == 0:
        return None
    middle = 0.5 * (y_from + y_to)
    half = _circle_advance(whisker, circle, code, z, y_from, middle, halvings - 1)
    if half is None:
        return None
    return _circle_advance(whisker, circle, half[0], half[1], middle, y_to, halvings - 1)


def solve_circle(whisker: WhiskerParams, circle: Circle, previous: Equilibrium | None = None
                 ) -> Equilibrium:
    """Equilibrium against a frictionless circle (point contact on the shaft or at the tip).

    Parameters
    ----------
    whisker : WhiskerParams
    circle : Circle
        Centre, radius (mm) and the side it comes from.
    previous : Equilibrium, optional
        A nearby solution (the last pose along a path) to warm-start from.

    Returns
    -------
    Equilibrium
        Kind "shaft", "tip", or "free" when the circle does not reach the wire or the wire has
        slipped past it.
    """
    check_whisker(whisker)
    if not isinstance(circle, Circle):
        raise UsageError(f"expected a Circle, got {type(circle).__name__}.")
    if not swept_into_wire(whisker, circle):
        return free(whisker)  # frictionless: with nothing in the way the wire springs back
    if previous is not None and previous.slipped_past:
        return previous
    if previous is not None and previous.solution and previous.solution[0] in (
            el.SHAFT_CIRCLE, el.TIP_CIRCLE):
        p = circle_params(whisker, circle.center_mm, circle.radius_mm, circle.side)
        code, z = _circle_step(previous.solution[0], previous.solution[1], p)
        if z is not None:
            return make_equilibrium(whisker, _kind_name(code), code, z, p)
    found = _circle_path(whisker, circle)
    if found is None:
        return free(whisker, slipped_past=True)
    code, z, p = found
    return make_equilibrium(whisker, _kind_name(code), code, z, p)


def _kind_name(code: int) -> str:
    return "shaft" if code == el.SHAFT_CIRCLE else "tip"


def solve_rod(whisker: WhiskerParams, rod_center_mm, rod_radius_mm: float,
              previous: Equilibrium | None = None, side: int = 1) -> Equilibrium:
    """Equilibrium against the calibration's touch rod (a frictionless circle).

    The rod comes from the whisker's +y side (``side=+1``) and pushes toward -y; see
    `solve_circle` for the rest.
    """
    return solve_circle(whisker, Circle(rod_center_mm, rod_radius_mm, side), previous)
