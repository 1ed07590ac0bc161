"""Compiled planar elastica with one point load: the shooting integrator and a Newton solver.

Everything in this module is nondimensional: lengths in units of the wire length L, forces in
EI/L², moments in EI/L. With one point force F at arc length s_c the wire beyond s_c is straight
and, before it, the internal moment m = EI·θ' obeys m' = -(cosθ·F_y - sinθ·F_x); m(s_c) = 0.

The root suspension enters through the unknown M, the moment of F about the centre of rotation:
the suspension turns by φ = M/k_θ and shifts by u = F/k_t, and the moment at the clamp is
M minus the moment of F carried by the rigid stub. Using M (not φ) as the unknown keeps a rigid
root (compliance 0) well posed.

Each contact kind is a square nonlinear system in (M, F_x, F_y[, s_c]) solved by a damped Newton
iteration whose Jacobian comes from the variational equations integrated alongside the rod;
classical RK4 on a uniform grid over [0, s_c]
integrates the rod (the right-hand side is smooth there, so 96 steps give ~1e-8 L).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# Contact-kind codes of the nondimensional systems.
CANTILEVER = 0     # given force at the tip; unknown M                         (1 unknown)
SHAFT_CIRCLE = 1   # frictionless shaft tangent to a circle (radius 0: a corner) (4 unknowns)
TIP_CIRCLE = 2     # tip on a circle with tangential force = mu_signed·normal  (3 unknowns)
TIP_POINT = 3      # tip held at a point (sticking, or a polygon's corner)      (3 unknowns)
TIP_LINE = 4       # tip on a line with tangential force = mu_signed·normal      (3 unknowns)
TANGENT_LINE = 5   # shaft tangent to a line at s_c, lying along it to the tip    (4 unknowns)

# Indices into the parameter vector p.
P_STUB, P_CROT, P_CTRANS = 0, 1, 2
P_CX, P_CY, P_RADIUS, P_SIDE = 3, 4, 5, 6
P_NX, P_NY, P_OFFSET, P_MU = 7, 8, 9, 10
P_AX, P_AY, P_FX, P_FY = 11, 12, 13, 14
P_SIZE = 15

DEFAULT_STEPS = 96


@njit(cache=True)
def root_state(p, moment, fx, fy):
    """Clamp state (x, y, θ, m) and the root pose (φ, ux, uy) for a trial M and F."""
    phi = p[P_CROT] * moment
    ux = p[P_CTRANS] * fx
    uy = p[P_CTRANS] * fy
    c, s = math.cos(phi), math.sin(phi)
    stub = p[P_STUB]
    m0 = moment - stub * (c * fy - s * fx)
    return ux + stub * c, uy + stub * s, phi, m0, ux, uy


@njit(cache=True)
def integrate(x, y, th, m, fx, fy, length, steps):
    """RK4 from arc 0 to `length`; returns the state (x, y, θ, m) at the end."""
    h = length / steps
    for _ in range(steps):
        c1, s1 = math.cos(th), math.sin(th)
        k1m = -(c1 * fy - s1 * fx)
        th2 = th + 0.5 * h * m
        c2, s2 = math.cos(th2), math.sin(th2)
        m2 = m + 0.5 * h * k1m
        k2m = -(c2 * fy - s2 * fx)
        th3 = th + 0.5 * h * m2
        c3, s3 = math.cos(th3), math.sin(th3)
        m3 = m + 0.5 * h * k2m
        k3m = -(c3 * fy - s3 * fx)
        th4 = th + h * m3
        c4, s4 = math.cos(th4), math.sin(th4)
        m4 = m + h * k3m
        k4m = -(c4 * fy - s4 * fx)
        x += h * (c1 + 2.0 * c2 + 2.0 * c3 + c4) / 6.0
        y += h * (s1 + 2.0 * s2 + 2.0 * s3 + s4) / 6.0
        th += h * (m + 2.0 * m2 + 2.0 * m3 + m4) / 6.0
        m += h * (k1m + 2.0 * k2m + 2.0 * k3m + k4m) / 6.0
    return x, y, th, m


@njit(cache=True)
def unpack(kind, z, p):
    """(M, F_x, F_y, s_c) from the unknowns of a contact kind."""
    if kind == CANTILEVER:
        return z[0], p[P_FX], p[P_FY], 1.0
    if kind == SHAFT_CIRCLE or kind == TANGENT_LINE:
        return z[0], z[1], z[2], z[3]
    return z[0], z[1], z[2], 1.0


@njit(cache=True)
def _circle_rows(kind, x, y, th, fx, fy, p, r, d_res, explicit):
    """Rows 1.. of the circle kinds: residuals, their end-state and direct derivatives."""
    c, s = math.cos(th), math.sin(th)
    if kind == SHAFT_CIRCLE:
        side, radius = p[P_SIDE], p[P_RADIUS]
        r[1] = fx * c + fy * s
        d_res[1, 2] = -fx * s + fy * c
        explicit[1, 1], explicit[1, 2] = c, s
        r[2] = x - p[P_CX] - radius * side * s
        d_res[2, 0], d_res[2, 2] = 1.0, -radius * side * c
        r[3] = y - p[P_CY] + radius * side * c
        d_res[3, 1], d_res[3, 2] = 1.0, -radius * side * s
    else:
        dx, dy = x - p[P_CX], y - p[P_CY]
        dist = max(math.sqrt(dx * dx + dy * dy), 1e-300)
        r[1] = dist - p[P_RADIUS]
        d_res[1, 0], d_res[1, 1] = dx / dist, dy / dist
        # tangential force minus mu_signed times the normal force, both times the distance
        # (the tangent is the outward normal turned +90°, as on a line); mu 0: frictionless
        mu = p[P_MU]
        r[2] = dx * fy - dy * fx - mu * (dx * fx + dy * fy)
        d_res[2, 0], d_res[2, 1] = fy - mu * fx, -fx - mu * fy
        explicit[2, 1], explicit[2, 2] = -dy - mu * dx, dx - mu * dy


@njit(cache=True)
def _line_rows(kind, x, y, th, fx, fy, p, r, d_res, explicit):
    """Rows 1.. of the tip-on-point and line kinds (see `_circle_rows`)."""
    if kind == TIP_POINT:
        r[1], r[2] = x - p[P_AX], y - p[P_AY]
        d_res[1, 0], d_res[2, 1] = 1.0, 1.0
        return
    nx, ny, mu = p[P_NX], p[P_NY], p[P_MU]
    r[1] = x * nx + y * ny - p[P_OFFSET]
    d_res[1, 0], d_res[1, 1] = nx, ny
    # tangential force minus the friction it must equal, mu_signed times the normal force
    r[2] = (-fx * ny + fy * nx) - mu * (fx * nx + fy * ny)
    explicit[2, 1], explicit[2, 2] = -ny - mu * nx, nx - mu * ny
    if kind == TANGENT_LINE:
        c, s = math.cos(th), math.sin(th)
        r[3] = c * nx + s * ny
        d_res[3, 2] = -s * nx + c * ny


@njit(cache=True)
def contact_rows(kind, state, fx, fy, p, r, d_res, explicit):
    """All residuals of `kind` at the end state (x, y, θ, m) at s_c.

    Row 0 is the moment left at s_c; the others say where and how the contact holds. `d_res`
    (k, 4) receives their derivatives to the end state, `explicit` (k, k) those to the unknowns
    (M, F_x, F_y[, s_c]) that do not pass through the rod.
    """
    r[0] = state[3]
    d_res[0, 3] = 1.0
    if kind == SHAFT_CIRCLE or kind == TIP_CIRCLE:
        _circle_rows(kind, state[0], state[1], state[2], fx, fy, p, r, d_res, explicit)
    elif kind != CANTILEVER:
        _line_rows(kind, state[0], state[1], state[2], fx, fy, p, r, d_res, explicit)


@njit(cache=True)
def residual(kind, z, p, steps, out):
    """Fill `out` with the residuals of contact `kind` at unknowns `z`."""
    moment, fx, fy, arc = unpack(kind, z, p)
    x0, y0, th0, m0, _, _ = root_state(p, moment, fx, fy)
    x, y, th, m = integrate(x0, y0, th0, m0, fx, fy, arc, steps)
    k = z.shape[0]
    contact_rows(kind, np.array([x, y, th, m]), fx, fy, p, out, np.zeros((k, 4)),
                 np.zeros((k, k)))


@njit(cache=True)
def _stage(th, m, sens, fx, fy, d_state, d_sens):
    """Right-hand side of the rod and of its sensitivities to (M, F_x, F_y) at one RK4 stage."""
    c, s = math.cos(th), math.sin(th)
    d_state[0], d_state[1], d_state[2], d_state[3] = c, s, m, -c * fy + s * fx
    stiff = s * fy + c * fx
    for j in range(3):
        d_sens[0, j] = -s * sens[2, j]
        d_sens[1, j] = c * sens[2, j]
        d_sens[2, j] = sens[3, j]
        d_sens[3, j] = stiff * sens[2, j]
    d_sens[3, 1] += s
    d_sens[3, 2] -= c


@njit(cache=True)
def integrate_sensitivity(state, sens, fx, fy, length, steps):
    """RK4 of the rod and its variational equations; updates `state` (4,) and `sens` (4, 3)."""
    h = length / steps
    k_state = np.empty((4, 4))
    k_sens = np.empty((4, 4, 3))
    trial_state = np.empty(4)
    trial_sens = np.empty((4, 3))
    weights = (0.5, 0.5, 1.0)
    for _ in range(steps):
        _stage(state[2], state[3], sens, fx, fy, k_state[0], k_sens[0])
        for stage in range(3):
            w = weights[stage] * h
            for i in range(4):
                trial_state[i] = state[i] + w * k_state[stage, i]
                for j in range(3):
                    trial_sens[i, j] = sens[i, j] + w * k_sens[stage, i, j]
            _stage(trial_state[2], trial_state[3], trial_sens, fx, fy,
                   k_state[stage + 1], k_sens[stage + 1])
        for i in range(4):
            state[i] += h * (k_state[0, i] + 2.0 * k_state[1, i] + 2.0 * k_state[2, i]
                             + k_state[3, i]) / 6.0
            for j in range(3):
                sens[i, j] += h * (k_sens[0, i, j] + 2.0 * k_sens[1, i, j]
                                   + 2.0 * k_sens[2, i, j] + k_sens[3, i, j]) / 6.0


@njit(cache=True)
def _end_with_jacobian(kind, z, p, steps):
    """End state (x, y, θ, m) at s_c, its Jacobian to the unknowns z (4, k), and F."""
    moment, fx, fy, arc = unpack(kind, z, p)
    x0, y0, th0, m0, _, _ = root_state(p, moment, fx, fy)
    stub, crot, ctrans = p[P_STUB], p[P_CROT], p[P_CTRANS]
    c0, s0 = math.cos(th0), math.sin(th0)
    state = np.array([x0, y0, th0, m0])
    sens = np.zeros((4, 3))
    sens[0, 0], sens[1, 0], sens[2, 0] = -stub * s0 * crot, stub * c0 * crot, crot
    sens[3, 0] = 1.0 + stub * crot * (s0 * fy + c0 * fx)
    sens[0, 1], sens[3, 1] = ctrans, stub * s0
    sens[1, 2], sens[3, 2] = ctrans, -stub * c0
    integrate_sensitivity(state, sens, fx, fy, arc, steps)
    k = z.shape[0]
    jac = np.zeros((4, k))
    if kind == CANTILEVER:
        for i in range(4):
            jac[i, 0] = sens[i, 0]
    else:
        for i in range(4):
            for j in range(3):
                jac[i, j] = sens[i, j]
    if k == 4:
        c, s = math.cos(state[2]), math.sin(state[2])
        jac[0, 3], jac[1, 3], jac[2, 3], jac[3, 3] = c, s, state[3], -c * fy + s * fx
    return state, jac, fx, fy


@njit(cache=True)
def residual_and_jacobian(kind, z, p, steps, r, jac):
    """Residuals of contact `kind` (into r) and their exact Jacobian (into jac)."""
    state, d_end, fx, fy = _end_with_jacobian(kind, z, p, steps)
    k = z.shape[0]
    d_res = np.zeros((k, 4))
    explicit = np.zeros((k, k))
    contact_rows(kind, state, fx, fy, p, r, d_res, explicit)
    for i in range(k):
        for j in range(k):
            total = explicit[i, j]
            for e in range(4):
                total += d_res[i, e] * d_end[e, j]
            jac[i, j] = total


@njit(cache=True)
def solve_small(a, b):
    """x with a·x = b for a tiny dense system (Gaussian elimination, partial pivoting).

    Returns (x, ok); ok is False for a (numerically) singular matrix. Hand-written because
    numba's LAPACK binding raises on singular matrices and is slow to compile.
    """
    n = b.shape[0]
    m = a.copy()
    x = b.copy()
    scale = max(np.max(np.abs(a)), 1e-300)
    for col in range(n):
        pivot = col + np.argmax(np.abs(m[col:, col]))
        if abs(m[pivot, col]) <= 1e-14 * scale:
            return x, False
        if pivot != col:
            for j in range(n):
                m[col, j], m[pivot, j] = m[pivot, j], m[col, j]
            x[col], x[pivot] = x[pivot], x[col]
        for row in range(col + 1, n):
            factor = m[row, col] / m[col, col]
            for j in range(col, n):
                m[row, j] -= factor * m[col, j]
            x[row] -= factor * x[col]
    for row in range(n - 1, -1, -1):
        total = x[row]
        for j in range(row + 1, n):
            total -= m[row, j] * x[j]
        x[row] = total / m[row, row]
    return x, True


@njit(cache=True)
def newton(kind, z0, p, steps, tol, max_iter):
    """Damped Newton with the exact (variational) Jacobian.

    Returns (z, converged, iterations).
    """
    k = z0.shape[0]
    z = z0.copy()
    r = np.empty(k)
    r_trial = np.empty(k)
    jac = np.empty((k, k))
    for it in range(max_iter):
        residual_and_jacobian(kind, z, p, steps, r, jac)
        norm = np.max(np.abs(r))
        if norm < tol:
            return z, True, it
        step, solvable = solve_small(jac, -r)
        if not solvable or not np.all(np.isfinite(step)):
            return z, False, it
        scale = 1.0
        accepted = False
        for _ in range(12):
            trial = z + scale * step
            residual(kind, trial, p, steps, r_trial)
            trial_norm = np.max(np.abs(r_trial))
            if trial_norm < norm or trial_norm < tol:
                z = trial
                accepted = True
                break
            scale *= 0.5
        if not accepted:
            return z, False, it
        if trial_norm < tol:
            return z, True, it + 1
    return z, False, max_iter


@njit(cache=True)
def shape(kind, z, p, steps, n_points):
    """Whisker points in L units: centre of rotation, clamp, then n_points along the wire."""
    moment, fx, fy, arc = unpack(kind, z, p)
    x, y, th, m, ux, uy = root_state(p, moment, fx, fy)
    out = np.empty((n_points + 2, 2))
    out[0, 0], out[0, 1] = ux, uy
    out[1, 0], out[1, 1] = x, y
    s_prev = 0.0
    for i in range(n_points):
        s_next = (i + 1) / n_points
        if s_prev < arc:
            seg = min(s_next, arc) - s_prev
            sub = max(1, int(math.ceil(steps * seg / max(arc, 1e-12))))
            x, y, th, m = integrate(x, y, th, m, fx, fy, seg, sub)
            if s_next > arc:
                x += (s_next - arc) * math.cos(th)
                y += (s_next - arc) * math.sin(th)
        else:
            x += (s_next - s_prev) * math.cos(th)
            y += (s_next - s_prev) * math.sin(th)
        out[i + 2, 0], out[i + 2, 1] = x, y
        s_prev = s_next
    return out


@njit(cache=True)
def deepest_behind_line(kind, z, p, steps, n_nodes):
    """How far the wire's nodes before s_c (or before the tip) reach behind the line
    n·r = offset, in L (positive: behind), and the arc of the deepest node."""
    moment, fx, fy, arc = unpack(kind, z, p)
    x, y, th, m, _, _ = root_state(p, moment, fx, fy)
    nx, ny, offset = p[P_NX], p[P_NY], p[P_OFFSET]
    last = arc if kind == TANGENT_LINE else 1.0
    worst, worst_arc = -1e300, 0.0
    sub = max(1, steps // n_nodes)
    for i in range(1, n_nodes):
        s_node = last * i / n_nodes
        x, y, th, m = integrate(x, y, th, m, fx, fy, last / n_nodes, sub)
        depth = offset - (x * nx + y * ny)
        if depth > worst:
            worst, worst_arc = depth, s_node
    return worst, worst_arc


@njit(cache=True)
def end_state(kind, z, p, steps):
    """(x, y, θ) at s_c and the tip (x, y), the wire straight beyond s_c."""
    moment, fx, fy, arc = unpack(kind, z, p)
    x0, y0, th0, m0, _, _ = root_state(p, moment, fx, fy)
    x, y, th, _ = integrate(x0, y0, th0, m0, fx, fy, arc, steps)
    rest = 1.0 - arc
    return x, y, th, x + rest * math.cos(th), y + rest * math.sin(th)


def new_params() -> np.ndarray:
    """A zeroed parameter vector."""
    return np.zeros(P_SIZE)


def shape_of(eq, n: int) -> np.ndarray:
    """`Equilibrium.shape_mm` (see there)."""
    whisker = eq.whisker
    if eq.kind == "free":
        x = np.concatenate([[0.0], whisker.root_offset_mm + whisker.length_mm
                            * np.linspace(0.0, 1.0, n)])
        return np.column_stack([x, np.zeros_like(x)])
    code, z, p = eq.solution[:3]
    return shape(code, z, p, DEFAULT_STEPS, n - 1) * whisker.length_mm
