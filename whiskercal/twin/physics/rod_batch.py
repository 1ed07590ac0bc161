"""The touch rod's warm-started solves for many rod centres at once, compiled.

A mechanics fit solves the same grid of rod contacts thousands of times, each warm-started from
a nearby suspension's solution (or from the point before it in the stage's column); one such
solve is a Newton iteration or two, and through ``contacts.solve_rod`` the Python around it
(the circle, its checks, the `Equilibrium`) costs more than the iteration itself. Here the same
steps run in one compiled loop: the rod swept into the wire or not (``contacts.swept_into_wire``),
the warm step with its switch between a shaft and a tip contact (``contacts._circle_step``) and
the same physical checks (``contacts.circle_state_ok``), giving the same solutions. A point that
needs the path in from first touch (no warm start, or the warm step failed) follows it here too,
as ``contacts._circle_path`` does, step for step (``_from_touch``): the tip sweep's points take
that path at every evaluation of a fit, so the loop does not stop for them.
Only a centre on the rigid stub is left to ``contacts.solve_rod`` (to refuse): the loop stops
there (``run_rods``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from whiskercal.twin.physics import elastica as el
from whiskercal.twin.physics.contacts import MAX_ITER, PATH_STEP, TOLERANCE

FREE, SOLVED, NEEDS_PATH = 0, 1, 2
NO_START = -1  # a state code: no warm start for this point
PATH_HALVINGS = 4  # ``contacts._circle_advance``'s: a failed path step is halved at most this often


@njit(cache=True)
def _touch(cx, radius, side, reach):
    """``contacts._touch_y`` beyond the stub: y (mm) where the rod first touches the straight
    wire, and whether it can touch it at all."""
    if cx <= reach:
        return side * radius, True
    if cx - radius >= reach:
        return 0.0, False
    return side * math.sqrt(radius ** 2 - (cx - reach) ** 2), True


@njit(cache=True)
def _swept(cx, cy, radius, side, stub, reach):
    """(swept into the wire, needs the Python solve): ``contacts.swept_into_wire``, with a
    centre on the rigid stub left to ``contacts.solve_rod`` to refuse."""
    if side * cy >= radius:
        return False, False
    if cx <= stub:
        return False, True
    touch, touches = _touch(cx, radius, side, reach)
    return touches and side * (cy - touch) < 0.0, False


@njit(cache=True)
def _state_ok(code, z, p):
    """``contacts.circle_state_ok``."""
    x, y, th, tip_x, tip_y = el.end_state(code, z, p, el.DEFAULT_STEPS)
    if code == el.SHAFT_CIRCLE:
        normal_x, normal_y = p[el.P_SIDE] * math.sin(th), -p[el.P_SIDE] * math.cos(th)
        return 0.0 < z[3] <= 1.0 and z[1] * normal_x + z[2] * normal_y > 0.0
    away_x, away_y = tip_x - p[el.P_CX], tip_y - p[el.P_CY]
    return (z[1] * away_x + z[2] * away_y > 0.0
            and math.cos(th) * away_x + math.sin(th) * away_y <= 1e-12)


@njit(cache=True)
def _step(code, z, p):
    """``contacts._circle_step``: (code, z, solved)."""
    for _ in range(2):
        z_new, converged, _ = el.newton(code, z, p, el.DEFAULT_STEPS, TOLERANCE, MAX_ITER)
        ok = converged and np.all(np.isfinite(z_new))
        if ok and _state_ok(code, z_new, p):
            return code, z_new, True
        if code == el.SHAFT_CIRCLE and ok and z_new[3] > 1.0:
            code, z = el.TIP_CIRCLE, z_new[:3].copy()
        elif code == el.TIP_CIRCLE and ok:
            z = np.append(z_new, 0.999)
            code = el.SHAFT_CIRCLE
        else:
            return code, z_new, False
    return code, z, False


@njit(cache=True)
def _start(k, centers, codes, states, follow_columns):
    """The warm start (code, z) of point ``k``: its own state, or with ``follow_columns`` the
    point before it when that one is in the same column (x) and in contact."""
    if not follow_columns:
        return codes[k], states[k]
    if k == 0 or centers[k - 1, 0] != centers[k, 0]:
        return NO_START, states[k]
    return codes[k - 1], states[k - 1]


@njit(cache=True)
def _rod_params(base, cx, cy, radius, side, length):
    """``contacts.circle_params`` for the rod at (cx, cy) mm."""
    p = base.copy()
    p[el.P_CX], p[el.P_CY] = cx / length, cy / length
    p[el.P_RADIUS], p[el.P_SIDE] = radius / length, side
    return p


@njit(cache=True)
def _from_touch(base, cx, cy, radius, side, length, stub):
    """``contacts._circle_path``: the rod brought in along -side·y from first touch, each step
    warm-started from the last and halved where Newton fails (``contacts._circle_advance``, its
    recursion as a stack of targets). (code, z, p, solved); not solved: the wire slipped past."""
    touch, _ = _touch(cx, radius, side, stub + length)
    n_steps = max(2, int(math.ceil(abs(cy - touch) / length / PATH_STEP)))
    if cx <= stub + length:
        code, z = el.SHAFT_CIRCLE, np.array([0.0, 0.0, 0.0, (cx - stub) / length])
    else:
        code, z = el.TIP_CIRCLE, np.zeros(3)
    step = (cy - touch) / n_steps  # np.linspace(touch, cy, n_steps + 1)'s points, exactly
    y_now, p = touch, base.copy()
    for i in range(1, n_steps + 1):
        y_step = cy if i == n_steps else i * step + touch
        targets, halvings = [y_step], [PATH_HALVINGS]
        while targets:
            y_to, left = targets.pop(), halvings.pop()
            p_to = _rod_params(base, cx, y_to, radius, side, length)
            new_code, new_z, solved = _step(code, z, p_to)
            if solved:
                code, z, p, y_now = new_code, new_z, p_to, y_to
            elif left == 0:
                return code, z, p, False
            else:  # the far half after the near one, each with one halving fewer
                targets.append(y_to)
                targets.append(0.5 * (y_now + y_to))
                halvings.append(left - 1)
                halvings.append(left - 1)
    return code, z, p, True


@njit(cache=True)
def _store(k, code, z, p, length, codes, states, poses):
    """Point ``k``'s solved state and its root pose (rotation rad, shift x, y mm)."""
    codes[k] = code
    states[k, :] = np.nan
    states[k, :z.shape[0]] = z
    moment, fx, fy, _ = el.unpack(code, z, p)
    poses[k, 0] = p[el.P_CROT] * moment
    poses[k, 1] = p[el.P_CTRANS] * fx * length
    poses[k, 2] = p[el.P_CTRANS] * fy * length


@njit(cache=True)
def run_rods(base, centers, radius, side, length, stub, begin, follow_columns,
             codes, states, poses, status):
    """Solve points ``begin``.. in order until one has its centre on the rigid stub.

    ``base``: the whisker's parameter vector (``contacts.base_params``); ``centers`` (n, 2) mm;
    ``codes`` (n,) and ``states`` (n, 4): each point's warm start on entry (``NO_START``: none)
    and its solution on return, with ``poses`` (n, 3) and ``status`` (n,). Returns the index of
    the point left to ``contacts.solve_rod`` (n when none is). A point without a warm start, or
    whose warm step fails, follows the path in from first touch (``_from_touch``).
    """
    reach = stub + length
    for k in range(begin, centers.shape[0]):
        cx, cy = centers[k, 0], centers[k, 1]
        swept, needs_python = _swept(cx, cy, radius, side, stub, reach)
        if needs_python:
            return k
        if not swept:
            codes[k], status[k] = NO_START, FREE
            poses[k, :] = 0.0
            continue
        code, z = _start(k, centers, codes, states, follow_columns)
        solved = False
        if code == el.SHAFT_CIRCLE or code == el.TIP_CIRCLE:
            p = _rod_params(base, cx, cy, radius, side, length)
            n_unknowns = 4 if code == el.SHAFT_CIRCLE else 3
            code, z, solved = _step(code, z[:n_unknowns].copy(), p)
        if not solved:
            code, z, p, solved = _from_touch(base, cx, cy, radius, side, length, stub)
        if solved:
            _store(k, code, z, p, length, codes, states, poses)
            status[k] = SOLVED
        else:  # slipped past the rod: the wire springs back (``contacts.solve_circle``)
            codes[k], status[k] = NO_START, FREE
            states[k, :] = np.nan
            poses[k, :] = 0.0
    return centers.shape[0]
