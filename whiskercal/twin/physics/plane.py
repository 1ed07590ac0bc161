"""The sliding plane: Coulomb friction at the tip, quasi-static stick-slip, tangential contact.

The friction model (parameters, slip rule) is `physics.coulomb`'s, shared with the contour
scenes' objects. Displacement-controlled continuation: each call moves the plane to its new pose
and starts from `previous`. A sticking tip stays glued to its point of the moving surface (`anchor_mm`) while
the needed tangential force stays inside the static cone |F_t| <= mu_s·F_n; when it would leave,
the tip slides with |F_t| = mu_k·F_n opposing the slip and sticks again at the new point. When
the bent shaft reaches the surface before the tip does, the contact becomes tangential (the
shaft meets the surface at s_c < L and lies along it to the tip); it turns back into a tip
contact when s_c returns to L, and the whisker comes free when the normal force vanishes.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.twin.physics import elastica as el
from whiskercal.twin.physics.coulomb import slips_within_step
from whiskercal.twin.physics.contacts import (PATH_STEP, base_params, check_whisker, free,
                                      make_equilibrium, solve_kind)
from whiskercal.twin.physics.obstacles import Plane
from whiskercal.twin.physics.whisker import Equilibrium

PENETRATION_TOL = 1e-9   # in L: how far a node may sit behind the surface before it counts
SHAPE_NODES = 48


def plane_params(whisker, plane: Plane, mu_signed: float = 0.0, anchor_mm=None) -> np.ndarray:
    """Parameter vector for the surface line (and the stuck point, when given)."""
    p = base_params(whisker)
    p[el.P_NX], p[el.P_NY] = plane.normal
    p[el.P_OFFSET] = plane.offset_mm / whisker.length_mm
    p[el.P_MU] = mu_signed
    if anchor_mm is not None:
        p[el.P_AX], p[el.P_AY] = plane.material_point_mm(anchor_mm) / whisker.length_mm
    return p


def _forces(z, plane: Plane) -> tuple[float, float]:
    """(normal, tangential) components of the nondimensional force z[1:3]."""
    nx, ny = plane.normal
    fx, fy = float(z[1]), float(z[2])
    return fx * nx + fy * ny, fy * nx - fx * ny  # the tangent is the normal turned by +90°


def _penetration(code: int, z, p) -> tuple[float, float]:
    """Deepest reach of the wire behind the surface (in L, > 0 means inside) and its arc."""
    return el.deepest_behind_line(code, z, p, el.DEFAULT_STEPS, SHAPE_NODES)


def _tangential_from(z, p, arc_guess: float):
    """Solve tangential contact starting from a tip state (z) and a guess of s_c."""
    for guess in (arc_guess, 0.95, 0.85, 0.7):
        z_t, ok = solve_kind(el.TANGENT_LINE, np.append(z[:3], guess), p)
        if ok and 0.0 < z_t[3] < 1.0:
            return z_t
    return None


def _settle(whisker, plane, code: int, z, p):
    """Check a tip/tangential state for penetration, loss of contact and the way back.

    Returns (code, z, p) of the state to report, or None when the whisker comes free.
    """
    normal, _ = _forces(z, plane)
    if code == el.TANGENT_LINE:
        if z[3] >= 1.0:
            return _tip_slide(whisker, plane, z[:3], p[el.P_MU])
        return (code, z, p) if normal > 0.0 else None
    if normal <= 0.0:
        return None
    depth, arc = _penetration(code, z, p)
    if depth <= PENETRATION_TOL:
        return code, z, p
    p_line = plane_params(whisker, plane, plane.motion_sign * plane.mu_kinetic)
    z_t = _tangential_from(z, p_line, arc)
    if z_t is None:
        raise UsageError("no tangential equilibrium found against the plane "
                         "(the plane may be pushed in too far for this whisker).")
    return el.TANGENT_LINE, z_t, p_line


def _tip_slide(whisker, plane, z, mu_signed: float):
    """Tip sliding along the surface with the given signed kinetic friction."""
    p = plane_params(whisker, plane, mu_signed)
    z_new, ok = solve_kind(el.TIP_LINE, z, p)
    if not ok:
        return None
    return _settle(whisker, plane, el.TIP_LINE, z_new, p)


def _friction_ratio(force, plane: Plane) -> float:
    """Signed F_t/F_n of a force (any units) against the plane."""
    normal = float(force @ plane.normal)
    return float(force @ plane.tangent) / normal if normal > 0.0 else 0.0


def _stuck_solve(previous: Equilibrium, p: np.ndarray) -> tuple[np.ndarray, bool]:
    """The tip held at the previous anchor, from the last step's trend when there is one."""
    start = previous.solution[1][:3]
    if previous.stuck_step is not None:
        z, ok = solve_kind(el.TIP_POINT, start + previous.stuck_step, p)
        if ok:
            return z, ok
    return solve_kind(el.TIP_POINT, start, p)


def _stuck_step(previous: Equilibrium | None, state) -> np.ndarray | None:
    """Change of the unknowns over a step that stayed stuck at the same anchor, else None."""
    if previous is None or state is None or state[0] != el.TIP_POINT:
        return None
    return state[1] - previous.solution[1][:3]


def _stick_or_slip(whisker, plane: Plane, previous: Equilibrium):
    """From a tip contact: stay stuck to the anchor if the static cone allows, else slip.

    Returns ((code, z, p) or None, sliding, slips): `sliding` True only for steady sliding on
    the kinetic edge (mu_s = mu_k, or no stuck solution), `slips` the stick-slip events in the
    step (a stuck tip breaking loose and sticking again).
    """
    p = plane_params(whisker, plane, 0.0, previous.anchor_mm)
    z, ok = _stuck_solve(previous, p)
    if ok:
        normal, tangential = _forces(z, plane)
        if normal > 0.0 and abs(tangential) <= plane.mu_static * normal:
            return _settle(whisker, plane, el.TIP_POINT, z, p), False, 0
        if normal > 0.0 and plane.coulomb.sticks:
            start = _friction_ratio(np.asarray(previous.force_n), plane)
            ratio, slips = slips_within_step(start, tangential / normal, plane)
            return _tip_slide(whisker, plane, z, ratio), False, slips
        direction = math.copysign(1.0, tangential)
    else:
        direction = float(plane.motion_sign)
        z = previous.solution[1][:3]
    # steady sliding on the kinetic edge: no stick, so no slip events either
    return _tip_slide(whisker, plane, z, direction * plane.mu_kinetic), True, 0


def _at_depth(plane: Plane, depth_mm: float, total_mm: float) -> Plane:
    """`plane` moved back along its normal so that it is `depth_mm` past first touch."""
    return replace(plane, point_mm=plane.point_mm - (total_mm - depth_mm) * plane.normal)


def _first_guesses(plane: Plane, mu_signed: float):
    """Starting points for the first push: no force, then forces along the contact's line of
    action of growing size (a push nearly along the wire needs its buckling load at once)."""
    direction = plane.normal + mu_signed * plane.tangent
    yield np.zeros(3)
    for size in (0.5, 1.5, 3.0, 6.0):
        yield np.array([0.0, *(size * direction)])


def _push(whisker, plane: Plane, state, depth_from: float, depth_to: float, total: float,
          halvings: int = 5):
    """Advance the history-free approach from one depth to the next, halving the move where
    Newton fails. Returns ("ok", state), ("free", None) or ("fail", None)."""
    shifted = _at_depth(plane, depth_to, total)
    mu_signed = plane.motion_sign * plane.mu_kinetic
    p = plane_params(whisker, shifted, mu_signed)
    if state is None:
        guesses, code = _first_guesses(plane, mu_signed), el.TIP_LINE
    else:
        code, z, _ = state
        guesses = [z if code == el.TANGENT_LINE else z[:3]]
    for guess in guesses:
        z_new, ok = solve_kind(code, guess, p)
        if ok and (state is not None or _forces(z_new, plane)[0] > 0.0):
            settled = _settle(whisker, shifted, code, z_new, p)
            return ("ok", settled) if settled is not None else ("free", None)
    if halvings == 0:
        return "fail", None
    middle = 0.5 * (depth_from + depth_to)
    outcome, half = _push(whisker, plane, state, depth_from, middle, total, halvings - 1)
    if outcome != "ok":
        return outcome, None
    return _push(whisker, plane, half, middle, depth_to, total, halvings - 1)


def _approach(whisker, plane: Plane):
    """History-free: push the plane in along its normal from first touch, sliding steadily."""
    offset_touch = plane.normal @ np.array([whisker.reach_mm, 0.0])
    total = plane.offset_mm - offset_touch
    if total <= 0.0:
        return None
    n_steps = max(2, int(math.ceil(total / whisker.length_mm / PATH_STEP)))
    depths = np.linspace(0.0, total, n_steps + 1)
    state = None
    for depth_from, depth_to in zip(depths[:-1], depths[1:]):
        outcome, state = _push(whisker, plane, state, depth_from, depth_to, total)
        if outcome == "free":
            return None
        if outcome == "fail":
            raise UsageError("no equilibrium found against the plane on the way in "
                             f"(at {depth_to:.1f} mm past first touch).")
    return state


def _report(whisker, plane, state, sliding: bool, slips: int = 0,
            previous: Equilibrium | None = None) -> Equilibrium:
    if state is None:
        return free(whisker)
    code, z, p = state
    kind = "tangential" if code == el.TANGENT_LINE else "tip"
    return make_equilibrium(whisker, kind, code, z, p, sliding or code == el.TANGENT_LINE,
                            anchor_on=plane, slips=slips, stuck_step=_stuck_step(previous, state))


def solve_plane(whisker, plane: Plane, previous: Equilibrium | None = None) -> Equilibrium:
    """Equilibrium against a sliding plane with Coulomb friction at the tip.

    Parameters
    ----------
    whisker : WhiskerParams
    plane : Plane
        The surface's pose, slide (mm) and friction coefficients.
    previous : Equilibrium, optional
        The state at the previous plane pose; it carries the stick state (`anchor_mm`). Without
        it (or from "free") the plane is pushed in along its normal while sliding steadily in
        `plane.motion_sign`'s direction, so the tip starts out at kinetic friction. When the
        warm start finds no equilibrium (near the switch to tangential contact the stuck state
        can cut into the plane with no tangential state next to it), the solve falls back to
        the history-free approach.

    Returns
    -------
    Equilibrium
        Kind "tip" (sticking; `sliding` True only for steady sliding on the kinetic edge;
        `slips` counts the slip events since `previous`), "tangential", or "free" when the
        plane does not reach the whisker.
    """
    check_whisker(whisker)
    if not isinstance(plane, Plane):
        raise UsageError(f"expected a Plane, got {type(plane).__name__}.")
    if _from_plane(previous):
        try:
            state, sliding, slips = _continue(whisker, plane, previous)
        except UsageError:
            state, sliding, slips = None, True, 0
        if state is not None or not _reaches(whisker, plane):
            return _report(whisker, plane, state, sliding, slips, previous)
    return _report(whisker, plane, _approach(whisker, plane), True)


def _continue(whisker, plane: Plane, previous: Equilibrium):
    """One warm-started step from a plane contact: (state or None, sliding, slips)."""
    if previous.kind == "tip":
        return _stick_or_slip(whisker, plane, previous)
    p = plane_params(whisker, plane, plane.motion_sign * plane.mu_kinetic)
    z, ok = solve_kind(el.TANGENT_LINE, previous.solution[1], p)
    if not ok:
        return None, True, 0
    return _settle(whisker, plane, el.TANGENT_LINE, z, p), True, 0


def _from_plane(previous: Equilibrium | None) -> bool:
    """Is `previous` a plane contact that this solve can continue from?"""
    if previous is None or len(previous.solution) != 3:
        return False
    code = previous.solution[0]
    return ((code in (el.TIP_POINT, el.TIP_LINE) and math.isfinite(previous.anchor_mm))
            or code == el.TANGENT_LINE)


def _reaches(whisker, plane: Plane) -> bool:
    """Does the surface reach the undeflected whisker's tip?"""
    return bool(plane.normal @ np.array([whisker.reach_mm, 0.0]) < plane.offset_mm)
