"""Frictionless contact with a convex polygon: a corner on the shaft, the tip on an edge, or the
tip on a corner (the force anywhere inside the corner's cone of normals).

Each pose is solved by following the contact the last pose had; when that state stops being
physical (the wire would cut into the polygon, the force would pull, the tip would leave its
edge) the other candidates are tried from the same starting state and the physical one is kept.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import replace

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.twin.physics import elastica as el
from whiskercal.twin.physics.contacts import (PATH_STEP, base_params, check_whisker, circle_params,
                                      free, make_equilibrium, solve_kind)
from whiskercal.twin.physics.obstacles import Polygon
from whiskercal.twin.physics.whisker import Equilibrium

SHAPE_NODES = 64
DEPTH_TOL_L = 1e-6      # how far (in L) the wire may cut into the polygon: round-off
# How far (in L) the tip may move between two poses and still count as the same contact
# continued: a period moves the base by hundredths of a millimetre, a path step by PATH_STEP.
JUMP_L = 0.1
# A candidate is (code, index): a corner on the shaft, the tip on an edge, the tip on a corner.


def polygon_params(whisker, polygon: Polygon, code: int, index: int) -> np.ndarray:
    vertices = polygon.vertices_mm
    if code == el.SHAFT_CIRCLE:
        return circle_params(whisker, vertices[index], 0.0, polygon.side)
    p = base_params(whisker)
    if code == el.TIP_LINE:
        normal = polygon.outward_normals[index]
        p[el.P_NX], p[el.P_NY] = normal
        p[el.P_OFFSET] = normal @ vertices[index] / whisker.length_mm
    else:
        p[el.P_AX], p[el.P_AY] = vertices[index] / whisker.length_mm
    return p


def _candidates(polygon: Polygon, near: int):
    """Every candidate contact, those at and around corner/edge `near` first."""
    k = len(polygon.vertices_mm)
    for distance in range(k // 2 + 1):
        for index in sorted({(near + distance) % k, (near - distance) % k}):
            yield el.SHAFT_CIRCLE, index
            yield el.TIP_LINE, index
            yield el.TIP_POINT, index


def physical_state(whisker, polygon: Polygon, code: int, index: int, z, p) -> bool:
    """Pushing force, contact where it claims to be, and no part of the wire inside."""
    moment, fx, fy, arc = el.unpack(code, z, p)
    force = np.array([fx, fy])
    normals = polygon.outward_normals
    _, _, th, tip_x, tip_y = el.end_state(code, z, p, el.DEFAULT_STEPS)
    if code == el.SHAFT_CIRCLE:
        across = polygon.side * np.array([math.sin(th), -math.cos(th)])
        if not (0.0 < arc <= 1.0 and force @ across > 0.0):
            return False
    elif code == el.TIP_LINE:
        tip = np.array([tip_x, tip_y]) * whisker.length_mm
        vertices = polygon.vertices_mm
        start, end = vertices[index], vertices[(index + 1) % len(vertices)]
        along = (tip - start) @ (end - start) / ((end - start) @ (end - start))
        if not (force @ normals[index] > 0.0 and 0.0 <= along <= 1.0):
            return False
    else:
        pair = np.column_stack([normals[index - 1], normals[index]])
        weights = np.linalg.solve(pair, force)
        if np.any(weights < 0.0) or not np.any(weights > 0.0):
            return False
    points = el.shape(code, z, p, el.DEFAULT_STEPS, SHAPE_NODES)[1:] * whisker.length_mm
    return not polygon.crosses_polyline(points, DEPTH_TOL_L * whisker.length_mm)


def _tip_of(code: int, z, p) -> np.ndarray:
    """The tip (in L) of a solved state."""
    return np.array(el.end_state(code, z, p, el.DEFAULT_STEPS)[3:5])


def _solve_pose(whisker, polygon: Polygon, state):
    """From state (code, index, z): the physical state at this pose, or None.

    The last pose's contact when it still holds; else the first other physical candidate whose
    tip lies within :data:`JUMP_L` of the last one's, and only when none does, the first
    physical one (the contact slipped off: the wire snaps elsewhere). Newton warm-started from
    the last state can land on a distant equilibrium that is physical too (the wire bent the
    other way round a corner the tip was sliding past) while the continuation lies on the next
    edge, later in the order.
    """
    code, index, z = state
    last_tip = None
    # lazily: the contact the last pose had usually still holds, and listing every other
    # candidate of a many-edged polygon would cost more than solving it
    order = itertools.chain([(code, index)], (c for c in _candidates(polygon, index) if c != (code, index)))
    distant = None
    for cand_code, cand_index in order:
        p = polygon_params(whisker, polygon, cand_code, cand_index)
        start = np.append(z[:3], z[3] if len(z) > 3 else 0.999) \
            if cand_code == el.SHAFT_CIRCLE else z[:3]
        z_new, ok = solve_kind(cand_code, start, p)
        if ok and physical_state(whisker, polygon, cand_code, cand_index, z_new, p):
            found = (cand_code, cand_index, z_new)
            if (cand_code, cand_index) == (code, index):
                return found  # the same contact, followed from its own last solution
            if last_tip is None:
                last_tip = _tip_of(code, z, polygon_params(whisker, polygon, code, index))
            if np.linalg.norm(_tip_of(cand_code, z_new, p) - last_tip) <= JUMP_L:
                return found
            distant = distant or found
    return distant


def _first_touch(whisker, polygon: Polygon):
    """Shift (mm, along side·y) at which the polygon first touches the undeflected wire, and
    the starting state there; None when the polygon does not overlap the wire."""
    side, clamp, reach = polygon.side, whisker.root_offset_mm, whisker.reach_mm
    vertices = polygon.vertices_mm
    depth_on_axis = polygon.depth_mm(np.column_stack([np.linspace(clamp, reach, 400),
                                                      np.zeros(400)]))
    if np.all(depth_on_axis <= 0.0):
        return None
    inside = (vertices[:, 0] > clamp) & (vertices[:, 0] < reach)
    lowest = np.where(inside, side * vertices[:, 1], np.inf)
    # of corners equally low (a flat face), the one nearest the root keeps the contact as
    # the whisker turns away
    tied = np.flatnonzero(lowest <= np.min(lowest) + 1e-9)
    index = int(tied[np.argmin(vertices[tied, 0])])
    edge_y = _edge_heights_at(vertices, reach)
    tip_low = min((side * y for y in edge_y), default=np.inf)
    if tip_low < lowest[index]:
        edge = int(np.argmin([abs(side * y - tip_low) for y in edge_y]))
        return -tip_low, (el.TIP_LINE, _edge_index_at(vertices, reach)[edge], np.zeros(3))
    if not np.isfinite(lowest[index]):
        raise UsageError("the polygon meets the whisker only at its rigid root stub.")
    arc = (vertices[index, 0] - clamp) / whisker.length_mm
    return -lowest[index], (el.SHAFT_CIRCLE, index, np.array([0.0, 0.0, 0.0, arc]))


def entry_side(whisker, polygon: Polygon) -> int:
    """The side (+1: the whisker's +y side, pushing it toward -y; -1 the other) from which
    ``polygon`` reaches the undeflected wire least deep: the shift along y that clears the wire
    is smaller from it. A piece that comes newly into the wire's way (the next wall ahead of the
    tip in a concave corner, an edge the wire has swung past) has come from that side."""
    vertices = polygon.vertices_mm
    low, high = whisker.root_offset_mm, whisker.reach_mm
    following = np.roll(vertices, -1, axis=0)
    heights = list(vertices[(vertices[:, 0] >= low) & (vertices[:, 0] <= high), 1])
    for x in (low, high):  # where the polygon's edges cross the ends of the wire's span
        crossing = (vertices[:, 0] - x) * (following[:, 0] - x) < 0.0
        share = (x - vertices[crossing, 0]) / (following[crossing, 0] - vertices[crossing, 0])
        heights.extend(vertices[crossing, 1] + share * (following[crossing, 1] - vertices[crossing, 1]))
    if not heights:
        return 1
    return 1 if -min(heights) <= max(heights) else -1


def solve_at_vertex(whisker, polygon: Polygon, index: int, previous: Equilibrium | None = None
                    ) -> Equilibrium:
    """The whisker's tip held on vertex ``index`` (the force anywhere in the vertex's cone of
    normals), warm-started from ``previous`` (held there, or the tip on a wall reaching it: the
    moment and force are the same unknowns); free when no such
    state is physical. For a piece whose vertex stands for a concave corner of a larger solid,
    where a tip that reaches the corner is held between its two walls (the piece's own
    edges are inside the solid, so this is its only contact the solid can have)."""
    check_whisker(whisker)
    start = np.zeros(3)
    if previous is not None and len(previous.solution) >= 2:  # a held tip, or the tip on a wall
        start = np.asarray(previous.solution[1][:3], float)   # of it: the same three unknowns
    p = polygon_params(whisker, polygon, el.TIP_POINT, index)
    z, ok = solve_kind(el.TIP_POINT, start, p)
    if not (ok and physical_state(whisker, polygon, el.TIP_POINT, index, z, p)):
        return free(whisker)
    eq = make_equilibrium(whisker, "tip", el.TIP_POINT, z, p)
    return replace(eq, solution=eq.solution + (int(index),))


def _edge_index_at(vertices, x):
    following = np.roll(vertices, -1, axis=0)
    return [i for i in range(len(vertices))
            if (vertices[i, 0] - x) * (following[i, 0] - x) < 0.0]


def _edge_heights_at(vertices, x):
    following = np.roll(vertices, -1, axis=0)
    heights = []
    for i in _edge_index_at(vertices, x):
        t = (x - vertices[i, 0]) / (following[i, 0] - vertices[i, 0])
        heights.append(vertices[i, 1] + t * (following[i, 1] - vertices[i, 1]))
    return heights


def _shifted(polygon: Polygon, shift_mm: float) -> Polygon:
    return replace(polygon, vertices_mm=polygon.vertices_mm + np.array([0.0, polygon.side * shift_mm]))


def _advance(whisker, polygon: Polygon, state, shift_from: float, shift_to: float,
             halvings: int = 5):
    """Move the polygon from one shift to the next, halving the move where no physical state
    is found; the new state, or None when the contact is lost even over the smallest move."""
    found = _solve_pose(whisker, _shifted(polygon, shift_to), state)
    if found is not None or halvings == 0:
        return found
    middle = 0.5 * (shift_from + shift_to)
    half = _advance(whisker, polygon, state, shift_from, middle, halvings - 1)
    return None if half is None else _advance(whisker, polygon, half, middle, shift_to,
                                              halvings - 1)


def _path(whisker, polygon: Polygon):
    touch = _first_touch(whisker, polygon)
    if touch is None:
        return None
    shift, state = touch
    n_steps = max(2, int(math.ceil(shift / whisker.length_mm / PATH_STEP)))
    shifts = np.linspace(shift, 0.0, n_steps + 1)
    for shift_from, shift_to in zip(shifts[:-1], shifts[1:]):
        state = _advance(whisker, polygon, state, shift_from, shift_to)
        if state is None:
            return None
    return state


@functools.lru_cache(maxsize=8)
def undeflected_polyline(whisker) -> np.ndarray:
    """The straight whisker's segment from its clamp to its tip (mm), per build (read-only)."""
    line = free(whisker).shape_mm(2)[1:]
    line.setflags(write=False)
    return line


def solve_polygon(whisker, polygon: Polygon, previous: Equilibrium | None = None
                  ) -> Equilibrium:
    """Equilibrium against a frictionless convex polygon (see the module's docstring).

    Without a usable `previous` the polygon is brought in along -side·y from where it first
    touches the undeflected whisker. Returns kind "shaft", "tip" or "free".
    """
    check_whisker(whisker)
    if not polygon.crosses_polyline(undeflected_polyline(whisker), 0.0):
        return free(whisker)  # frictionless: with nothing in the way the wire springs back
    if previous is not None and previous.slipped_past:
        return previous
    state = None
    if previous is not None and previous.solution and len(previous.solution) > 3:
        code, z, _, index = previous.solution
        state = _solve_pose(whisker, polygon, (code, index, z))
    if state is None:
        state = _path(whisker, polygon)
    if state is None:
        return free(whisker, slipped_past=True)
    code, index, z = state
    p = polygon_params(whisker, polygon, code, index)
    eq = make_equilibrium(whisker, "shaft" if code == el.SHAFT_CIRCLE else "tip", code, z, p)
    return replace(eq, solution=eq.solution + (index,))  # the corner/edge, for warm starts
