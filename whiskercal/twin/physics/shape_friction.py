"""Stick-slip at the tip against a contour scene's object (a `Circle` or convex `Polygon`).

The plane's model (`physics.coulomb`) on a surface the sensor moves past: the tip sticks to its
point of the object's surface (`Stick.anchor_mm`, in the obstacle's frame of this pose; the scene
carries it from pose to pose) while the force it needs stays inside the static cone about the
surface's normal there, |F_t| <= mu_s·F_n. Past the cone's edge it slides along the surface (the
polygon's edge, the circle) with the friction ratio `coulomb.slips_within_step` gives, sticks
again where it comes to rest, and the step's slip events are counted. The contact's other states
(shaft on a corner or on the circle, coming free, first touch) are the frictionless solves of
`physics.polygon` and `physics.contacts`: only the tip feels friction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from whiskercal.twin.physics import elastica as el
from whiskercal.twin.physics.contacts import (base_params, circle_params, circle_state_ok,
                                              make_equilibrium, solve_circle, solve_kind,
                                              swept_into_wire)
from whiskercal.twin.physics.coulomb import Coulomb, slips_within_step
from whiskercal.twin.physics.obstacles import Circle, Polygon
from whiskercal.twin.physics.polygon import (DEPTH_TOL_L, SHAPE_NODES, physical_state,
                                             polygon_params, solve_polygon,
                                             undeflected_polyline)
from whiskercal.twin.physics.whisker import Equilibrium


@dataclass(frozen=True)
class Stick:
    """Where the tip sticks (mm, the obstacle's frame) and its friction ratio F_t/F_n there
    (signed along the surface's normal turned +90°): the state a step carries to the next."""

    anchor_mm: np.ndarray
    ratio: float


def surface_normal(obstacle, point_mm) -> np.ndarray:
    """Outward unit normal of the obstacle's surface at (or nearest to) ``point_mm``: the
    circle's radius through it, or the normal of the polygon's nearest edge."""
    point = np.asarray(point_mm, float)
    if isinstance(obstacle, Circle):
        away = point - obstacle.center_mm
        return away / np.hypot(*away)
    return obstacle.outward_normals[nearest_edge(obstacle, point)]


def nearest_edge(polygon: Polygon, point_mm: np.ndarray) -> int:
    """Index of the polygon's edge (from vertex i to i + 1) nearest to ``point_mm``."""
    return int(np.argmin(polygon.edge_distances_mm(point_mm)))


def friction_ratio(force, normal) -> tuple[float, float]:
    """(F_n, signed F_t/F_n) of a force (any units) against a surface's outward ``normal``; the
    ratio is 0 for a force that does not push."""
    normal_force = float(force @ normal)
    tangential = float(force[1] * normal[0] - force[0] * normal[1])
    return normal_force, (tangential / normal_force if normal_force > 0.0 else 0.0)


def solve_shape_sticking(whisker, obstacle, friction: Coulomb, previous: Equilibrium | None = None,
                         stick: Stick | None = None) -> tuple[Equilibrium, Stick | None]:
    """Equilibrium against ``obstacle`` with stick-slip at the tip (see the module's docstring).

    Parameters
    ----------
    whisker : WhiskerParams
    obstacle : Circle or Polygon
        In the whisker frame (mm) of this pose.
    friction : Coulomb
    previous : Equilibrium, optional
        The state at the previous pose (a warm start).
    stick : Stick, optional
        Where the tip stuck at the previous pose, in this pose's frame; None when it was not a
        tip contact.

    Returns
    -------
    (Equilibrium, Stick or None)
        The equilibrium (kind "tip" sticking, or re-stuck after ``slips`` slip events; "shaft";
        "free") and, for a tip contact, where it sticks now.
    """
    if not _reaches(whisker, obstacle):
        return _frictionless(whisker, obstacle, None), None  # the wire springs back
    if stick is None or previous is None or previous.kind != "tip" or not previous.solution:
        return _landed(whisker, obstacle, _frictionless(whisker, obstacle, previous))
    found = _stick_or_slip(whisker, obstacle, friction, previous, stick)
    if found is not None:
        return found
    # the stuck tip would pull, or the wire would cut into the object: not a tip contact here
    return _landed(whisker, obstacle, _frictionless(whisker, obstacle, _as_sliding(previous)))


def _reaches(whisker, obstacle) -> bool:
    """Does the object still stand where the undeflected wire would be? (Else the wire is free,
    as in the frictionless solves.)"""
    if isinstance(obstacle, Circle):
        return swept_into_wire(whisker, obstacle)
    return obstacle.crosses_polyline(undeflected_polyline(whisker), 0.0)


def _frictionless(whisker, obstacle, previous):
    if isinstance(obstacle, Circle):
        return solve_circle(whisker, obstacle, previous)
    return solve_polygon(whisker, obstacle, previous)


def _landed(whisker, obstacle, equilibrium: Equilibrium):
    """A frictionless state and, for a tip contact, the stick it starts from (where it lies)."""
    if equilibrium.kind != "tip":
        return equilibrium, None
    _, ratio = friction_ratio(equilibrium.force_n, surface_normal(obstacle, equilibrium.tip_mm))
    return equilibrium, Stick(equilibrium.tip_mm.copy(), ratio)


def _as_sliding(previous: Equilibrium) -> Equilibrium:
    """``previous`` as the frictionless solves' warm start: a stuck tip as a tip on its edge (a
    polygon) or on the circle, not a tip held at a corner."""
    code = previous.solution[0]
    if len(previous.solution) > 3:
        _, z, p, index = previous.solution
        return replace(previous, solution=(el.TIP_LINE if code == el.TIP_POINT else code, z, p, index))
    _, z, p = previous.solution
    return replace(previous, solution=(el.TIP_CIRCLE if code == el.TIP_POINT else code, z, p))


def _stick_or_slip(whisker, obstacle, friction: Coulomb, previous: Equilibrium, stick: Stick):
    """The tip held at its anchor if the static cone allows, else slid along the surface; None
    when the held tip does not push on the surface or the wire would cut into the object."""
    p = base_params(whisker)
    p[el.P_AX], p[el.P_AY] = stick.anchor_mm / whisker.length_mm
    z, ok = solve_kind(el.TIP_POINT, previous.solution[1][:3], p)
    if not ok:
        return None
    normal = surface_normal(obstacle, stick.anchor_mm)
    normal_force, ratio = friction_ratio(z[1:3], normal)
    if normal_force <= 0.0 or not _outside(whisker, obstacle, el.TIP_POINT, z, p):
        return None
    index = nearest_edge(obstacle, stick.anchor_mm) if isinstance(obstacle, Polygon) else None
    if abs(ratio) <= friction.mu_static:
        return _reported(whisker, el.TIP_POINT, z, p, index, stick.anchor_mm, ratio, 0, False)
    if friction.sticks:
        slid_ratio, slips = slips_within_step(stick.ratio, ratio, friction)
    else:  # steady sliding on the kinetic edge: no stick, so no slip events either
        slid_ratio, slips = math.copysign(friction.mu_kinetic, ratio), 0
    slid = _slide(whisker, obstacle, z, slid_ratio, index)
    if slid is None:
        return None
    code, z_new, p_new, index = slid
    tip = np.asarray(el.end_state(code, z_new, p_new, el.DEFAULT_STEPS)[3:]) * whisker.length_mm
    if code == el.TIP_POINT:  # stopped on a corner: its force is wherever the corner holds it
        slid_ratio = friction_ratio(z_new[1:3], surface_normal(obstacle, tip))[1]
    return _reported(whisker, code, z_new, p_new, index, tip, slid_ratio, slips, not friction.sticks)


def _outside(whisker, obstacle, code: int, z, p) -> bool:
    """Is the wire of a tip state outside the object (touching it at the tip only)?"""
    if isinstance(obstacle, Circle):
        circle = circle_params(whisker, obstacle.center_mm, obstacle.radius_mm, obstacle.side)
        return circle_state_ok(el.TIP_CIRCLE, z, circle)
    points = el.shape(code, z, p, el.DEFAULT_STEPS, SHAPE_NODES)[1:] * whisker.length_mm
    return not obstacle.crosses_polyline(points, DEPTH_TOL_L * whisker.length_mm)


def _slide(whisker, obstacle, z, ratio: float, index):
    """The tip slid along the surface to where F_t/F_n = ``ratio``: (code, z, p, index) or None.
    On a polygon, the anchor's edge first, then its neighbours, then their corners (a tip that
    slides off an edge's end onto the next, or stops on the corner between)."""
    if isinstance(obstacle, Circle):
        p = circle_params(whisker, obstacle.center_mm, obstacle.radius_mm, obstacle.side)
        p[el.P_MU] = ratio
        z_new, ok = solve_kind(el.TIP_CIRCLE, z, p)
        return (el.TIP_CIRCLE, z_new, p, None) if ok and circle_state_ok(el.TIP_CIRCLE, z_new, p) \
            else None
    count = len(obstacle.vertices_mm)
    candidates = [(el.TIP_LINE, index), (el.TIP_LINE, (index + 1) % count),
                  (el.TIP_LINE, (index - 1) % count), (el.TIP_POINT, (index + 1) % count),
                  (el.TIP_POINT, index)]
    for code, edge in candidates:
        p = polygon_params(whisker, obstacle, code, edge)
        if code == el.TIP_LINE:
            p[el.P_MU] = ratio
        z_new, ok = solve_kind(code, z, p)
        if ok and physical_state(whisker, obstacle, code, edge, z_new, p):
            return code, z_new, p, edge
    return None


def _reported(whisker, code: int, z, p, index, anchor_mm, ratio: float, slips: int,
              sliding: bool) -> tuple[Equilibrium, Stick]:
    """The tip state as an `Equilibrium` (with the polygon's edge for warm starts) and its stick."""
    equilibrium = make_equilibrium(whisker, "tip", code, z, p, sliding, slips=slips)
    if index is not None:
        equilibrium = replace(equilibrium, solution=equilibrium.solution + (index,))
    return equilibrium, Stick(np.asarray(anchor_mm, float).copy(), float(ratio))
