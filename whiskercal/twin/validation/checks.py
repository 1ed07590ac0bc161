"""Checks of the twin's mechanics against references that do not use its own solver.

- the large-deflection cantilever (Bisshopp & Drucker's closed form with elliptic integrals);
- the root-spring limit: a very stiff wire on a soft root turns rigidly about the root;
- equilibrium residuals: each solution re-integrated by scipy's adaptive ODE solver from the
  root (moment balance at the suspension, force balance, contact geometry);
- the friction cone on the first, history-free step of a slide (on its kinetic edge) and
  along a slide (inside it while sticking);
- stick-slip along a finely stepped slide: every reported state sticks inside the cone; before
  each slip event the tip held at its anchor reaches mu_s, after it the ratio sits at the rest
  ratio (`Plane.rest_ratio`) plus only the load the rest of that step adds.

Each check returns a `Check` (value against its limit); `run_all()` returns them all.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import ellipeinc, ellipkinc

from whiskercal.twin.physics.cantilever import cantilever_tip
from whiskercal.twin.physics.contacts import solve_rod
from whiskercal.twin.physics.mechanics import solve_shape
from whiskercal.twin.physics.plane import solve_plane
from whiskercal.twin.physics.obstacles import Circle, Plane, plane_for_depth, regular_polygon
from whiskercal.twin.physics.whisker import Equilibrium, WhiskerParams

CANTILEVER_ALPHAS = (0.01, 0.1, 0.5, 1.0, 2.0, 3.0, 5.0, 7.5, 10.0, 15.0, 20.0)
CANTILEVER_LIMIT_L = 1e-4
RESIDUAL_LIMIT = 1e-6   # moment in units of |F|·L, positions in units of L


@dataclass(frozen=True)
class Check:
    """One validation result: `value` must not exceed `limit`."""

    name: str
    value: float
    limit: float
    detail: str = ""

    @property
    def ok(self) -> bool:
        """True when the value is finite and within its limit."""
        return bool(math.isfinite(self.value) and self.value <= self.limit)


def bisshopp_drucker_tip(alpha: float) -> tuple[float, float]:
    """Exact tip (x/L, y/L) of a cantilever with a perpendicular tip load, α = P·L²/EI.

    Bisshopp & Drucker (1945): with the tip slope φ0 and modulus p² = (1 + sin φ0)/2,
    √α = K(p) - F(φ1, p) where sin φ1 = 1/(p√2); then x/L = √(2 sin φ0 / α) and
    y/L = 1 - (2/√α)·(E(p) - E(φ1, p)).
    """
    if alpha == 0.0:
        return 1.0, 0.0

    def parts(tip_slope):
        m = (1.0 + math.sin(tip_slope)) / 2.0
        phi1 = math.asin(min(1.0, 1.0 / math.sqrt(2.0 * m)))
        return m, phi1

    def mismatch(tip_slope):
        m, phi1 = parts(tip_slope)
        return ellipkinc(math.pi / 2, m) - ellipkinc(phi1, m) - math.sqrt(alpha)

    tip_slope = brentq(mismatch, 1e-15, math.pi / 2 - 1e-15, xtol=1e-15, rtol=1e-15)
    m, phi1 = parts(tip_slope)
    x = math.sqrt(2.0 * math.sin(tip_slope) / alpha)
    y = 1.0 - 2.0 / math.sqrt(alpha) * (ellipeinc(math.pi / 2, m) - ellipeinc(phi1, m))
    return x, y


def check_cantilever(alphas=CANTILEVER_ALPHAS) -> Check:
    """Largest tip error (in L) of the shooting solver against the closed form."""
    errors = [max(abs(a - b) for a, b in zip(cantilever_tip(alpha), bisshopp_drucker_tip(alpha)))
              for alpha in alphas]
    worst = int(np.argmax(errors))
    return Check("cantilever tip vs Bisshopp-Drucker (L)", float(errors[worst]),
                 CANTILEVER_LIMIT_L, f"worst at alpha={alphas[worst]:g}")


def check_root_spring_limit() -> Check:
    """A wire 1e6 times stiffer on the default root: the tip must follow the rigid rotation."""
    soft = WhiskerParams()
    stiff = replace(soft, youngs_modulus_n_per_mm2=soft.youngs_modulus_n_per_mm2 * 1e6)
    eq = solve_rod(stiff, (60.0, -8.0), 1.0)
    turn = eq.root_rotation_rad
    rigid_tip = eq.root_shift_mm + stiff.reach_mm * np.array([math.cos(turn), math.sin(turn)])
    error = float(np.linalg.norm(eq.tip_mm - rigid_tip)) / stiff.length_mm
    return Check("stiff wire turns rigidly about the root (L)", error, 1e-5,
                 f"root turned {math.degrees(turn):.2f} deg")


def _reintegrate(eq: Equilibrium) -> np.ndarray:
    """Position and moment at the contact from scipy's adaptive solver: (x, y, θ, m) at s_c."""
    w = eq.whisker
    ei, turn, (fx, fy) = w.bending_stiffness_n_mm2, eq.root_rotation_rad, eq.force_n
    clamp = eq.root_shift_mm + w.root_offset_mm * np.array([math.cos(turn), math.sin(turn)])
    root_moment = w.root_rotational_stiffness_n_mm_per_rad * turn
    clamp_moment = root_moment - w.root_offset_mm * (math.cos(turn) * fy - math.sin(turn) * fx)

    def rhs(_, state):
        x, y, th, m = state
        return [math.cos(th), math.sin(th), m / ei, -(math.cos(th) * fy - math.sin(th) * fx)]

    solution = solve_ivp(rhs, (0.0, eq.contact_arc_mm), [*clamp, turn, clamp_moment],
                         method="DOP853", rtol=1e-12, atol=1e-14)
    return solution.y[:, -1]


def equilibrium_residual(eq: Equilibrium) -> float:
    """Largest of: moment left at the contact (in |F|·L), contact position mismatch (in L) and
    the suspension's force imbalance (in |F|), all from an independent re-integration."""
    w = eq.whisker
    force = float(np.linalg.norm(eq.force_n))
    x, y, _, moment = _reintegrate(eq)
    spring = w.root_translational_stiffness_n_per_mm * eq.root_shift_mm - eq.force_n
    return max(abs(moment) / (force * w.length_mm),
               float(np.linalg.norm([x, y] - eq.contact_mm)) / w.length_mm,
               float(np.linalg.norm(spring)) / force)


def contact_gap(eq: Equilibrium, obstacle) -> float:
    """Distance (in L) of the contact from the obstacle's surface; for tangential contact also
    the sine of the angle between the shaft and the surface there."""
    w, point = eq.whisker, eq.contact_mm
    if isinstance(obstacle, Circle):
        gap = abs(np.linalg.norm(point - obstacle.center_mm) - obstacle.radius_mm)
    elif isinstance(obstacle, Plane):
        gap = abs(obstacle.normal @ point - obstacle.offset_mm)
        if eq.kind == "tangential":
            _, _, angle, _ = _reintegrate(eq)
            gap = max(gap, w.length_mm * abs(obstacle.normal @ [math.cos(angle), math.sin(angle)]))
    else:
        gap = abs(obstacle.depth_mm(point[None, :])[0])
    return float(gap) / w.length_mm


def check_residuals(whisker: WhiskerParams | None = None) -> list[Check]:
    """Equilibrium residuals and contact gaps of rod, plane and polygon solves."""
    whisker = whisker or WhiskerParams()
    cases = {
        "rod on the shaft": Circle((50.0, -12.0), 1.5),
        "rod at the tip": Circle((78.5, -1.0), 1.5),
        "plane, tip contact (40 mm)": plane_for_depth(whisker, 40.0),
        "plane, tangential (50 mm)": plane_for_depth(whisker, 50.0),
        "octagon": regular_polygon((66.0, 25.0), 30.0, 8, math.pi / 8),
    }
    checks = []
    for name, obstacle in cases.items():
        eq = (solve_plane(whisker, obstacle) if isinstance(obstacle, Plane)
              else solve_shape(whisker, obstacle))
        value = (max(equilibrium_residual(eq), contact_gap(eq, obstacle))
                 if eq.in_contact else math.inf)
        checks.append(Check(f"equilibrium residual: {name}", value, RESIDUAL_LIMIT,
                            f"kind {eq.kind}"))
    return checks


def check_friction_cone(whisker: WhiskerParams | None = None, depth_mm: float = 40.0,
                        n_steps: int = 300, step_mm: float = 0.05) -> list[Check]:
    """Slide the plane: |F_t|/F_n <= mu_s while sticking and = mu_k while sliding.

    With stick-slip the only steady sliding is the first, history-free step (the approach
    slides on the kinetic edge); `check_stick_slip` covers the slip events.
    """
    whisker = whisker or WhiskerParams()
    stick_excess, slide_error, n_sliding = -math.inf, 0.0, 0
    for plane, eq, _ in _slide(whisker, depth_mm, n_steps, step_mm):
        ratio = _ratio(eq, plane)
        if eq.sliding:
            n_sliding += 1
            slide_error = max(slide_error, abs(ratio - plane.mu_kinetic))
        else:
            stick_excess = max(stick_excess, ratio - plane.mu_static)
    return [Check("sticking: |Ft|/Fn - mu_s (must be <= 0)", stick_excess, 0.0),
            Check("sliding: | |Ft|/Fn - mu_k |", slide_error if n_sliding else math.inf, 1e-9,
                  f"{n_sliding} of {n_steps} steps slid steadily (the history-free first step)")]


def _ratio(eq: Equilibrium, plane: Plane) -> float:
    """|F_t|/F_n of a contact force against the plane."""
    return abs(float(eq.force_n @ plane.tangent)) / float(eq.force_n @ plane.normal)


def _held_ratio(whisker: WhiskerParams, plane: Plane, previous: Equilibrium) -> float:
    """|F_t|/F_n with the tip held at the previous anchor: the same step under a cone so wide
    (mu_s = 100) that it cannot slip."""
    return _ratio(solve_plane(whisker, replace(plane, mu_static=100.0), previous), plane)


def _slide(whisker, depth_mm: float, n_steps: int, step_mm: float):
    """Walk a slide; yield (plane, state, previous state) per step."""
    base, previous = plane_for_depth(whisker, depth_mm), None
    for i in range(n_steps):
        plane = replace(base, slide_mm=base.motion_sign * i * step_mm)
        eq = solve_plane(whisker, plane, previous)
        yield plane, eq, previous
        previous = eq


def check_stick_slip(whisker: WhiskerParams | None = None, depth_mm: float = 20.0,
                     n_steps: int = 2000, step_mm: float = 0.005) -> list[Check]:
    """A 10 mm slide in 5 µm steps: the cone, breakaway at mu_s and rest after each slip.

    Three values: the largest |F_t|/F_n - mu_s of any state after the first (<= 0: every state
    sticks inside the cone); at each slip event the largest mu_s - |F_t|/F_n of the tip held at
    its anchor (<= 0: the load reached mu_s before the slip); and the largest distance of the
    ratio after the slip from the rest ratio plus the load that the rest of the step adds after
    breakaway (the held ratio's excess over mu_s; a fine step keeps it small).
    """
    whisker = whisker or WhiskerParams()
    outside, short_of_breakaway, off_rest, events = -math.inf, -math.inf, 0.0, 0
    largest_carried = 0.0
    for plane, eq, previous in _slide(whisker, depth_mm, n_steps, step_mm):
        if previous is None:
            continue  # the history-free first step slides on the kinetic edge
        ratio = _ratio(eq, plane)
        outside = max(outside, ratio - plane.mu_static)
        if eq.slips:
            events += eq.slips
            held = _held_ratio(whisker, plane, previous)
            short_of_breakaway = max(short_of_breakaway, plane.mu_static - held)
            # load applied after breakaway, less one full period per further slip in the step
            period = plane.mu_static - plane.rest_ratio
            carried = held - plane.mu_static - (eq.slips - 1) * period
            largest_carried = max(largest_carried, carried)
            off_rest = max(off_rest, abs(ratio - plane.rest_ratio - carried))
    detail = (f"{events} slip events in {n_steps} steps of {step_mm * 1e3:g} µm at "
              f"{depth_mm:g} mm; load carried past a slip <= {largest_carried:.4f}")
    return [Check("stick-slip: every state inside the cone, |Ft|/Fn - mu_s (<= 0)", outside,
                  0.0, detail),
            Check("stick-slip: before each slip the held tip reaches mu_s, mu_s - |Ft|/Fn (<= 0)",
                  short_of_breakaway if events else math.inf, 0.0, detail),
            Check("stick-slip: after each slip |Ft|/Fn sits at the rest ratio",
                  off_rest if events else math.inf, 1e-6, detail)]


def run_all() -> list[Check]:
    """Every mechanics check, in the order `whiskercal twin validate` prints them."""
    return [check_cantilever(), check_root_spring_limit(), *check_residuals(),
            *check_friction_cone(), *check_stick_slip()]
