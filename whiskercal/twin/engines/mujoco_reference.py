"""Exact large-deflection references that the MuJoCo engine is compared with.

A cantilever of length L and bending stiffness EI, clamped at an angle φ, carries a dead load P
perpendicular to the undeformed axis at its tip (Bisshopp & Drucker, 1945). With α = P·L²/EI and
θ(s) the tangent angle, EI·θ'' = -P·cos θ and θ'(L) = 0 integrate once to

    θ'² = 2α·(sin θ_tip - sin θ)          (s in units of L)

so the length, the tip's coordinates and the moment at the clamp are elliptic-type integrals
over θ. Substituting sin θ = sin θ_tip - u² removes the integrable singularity at the tip, and
the integrals are evaluated by adaptive quadrature to ~1e-12; only the tip angle (and, on a
compliant root, the root rotation) are found by bracketing root finders. Nothing here shares
code or method with either twin engine (shooting with RK4, MuJoCo), which is what makes it a
reference. In particular x_tip = √(2·(sin θ_tip - sin φ)/α) holds in closed form.

Units: lengths in units of L unless a name says mm; angles in rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq

from whiskercal.errors import UsageError

_QUAD_TOL = 1e-12
_ROOT_ANGLE_MAX = 1.4  # rad (80°)


@dataclass(frozen=True)
class ReferenceTip:
    """Tip of the loaded whisker, relative to the suspension's centre of rotation.

    Attributes
    ----------
    tip_mm : ndarray (2,)
        Tip position (mm) for a load toward +y.
    root_rotation_rad : float
        Rotation of the root (0 when clamped).
    root_shift_mm : ndarray (2,)
        Translation of the centre of rotation (mm).
    tip_angle_rad : float
        Tangent angle at the tip.
    """

    tip_mm: np.ndarray
    root_rotation_rad: float
    root_shift_mm: np.ndarray
    tip_angle_rad: float


def _arc_integral(alpha: float, tip_angle: float, root_angle: float, weight) -> float:
    """∫ weight(sin θ) ds from the clamp (θ = root_angle) to the tip (θ = tip_angle).

    With sin θ = sin θ_tip - u², ds = dθ/θ' = 2·du / (√(2α)·cos θ).
    """
    s_tip = math.sin(tip_angle)
    # 1 - sin θ_tip without cancellation, since cos θ is small near the tip at large loads.
    gap_tip = 2.0 * math.sin(0.25 * math.pi - 0.5 * tip_angle) ** 2
    u_max = math.sqrt(max(s_tip - math.sin(root_angle), 0.0))

    def integrand(u: float) -> float:
        sin_theta = s_tip - u * u
        return weight(sin_theta) / math.sqrt((gap_tip + u * u) * (1.0 + sin_theta))

    value, _ = quad(integrand, 0.0, u_max, epsabs=_QUAD_TOL, epsrel=_QUAD_TOL, limit=200)
    return 2.0 / math.sqrt(2.0 * alpha) * value


def _tip_angle(alpha: float, root_angle: float) -> float:
    """Tip angle for which the elastica from ``root_angle`` has unit length."""
    def excess_length(tip_angle: float) -> float:
        return _arc_integral(alpha, tip_angle, root_angle, lambda s: 1.0) - 1.0

    low = root_angle + 1e-15
    # Widen the bracket toward π/2 only as far as needed: the integrand peaks sharply there.
    for digits in range(1, 7):
        high = max(0.5 * math.pi - 10.0**-digits, low + 1e-9)
        if excess_length(high) > 0:
            return brentq(excess_length, low, high, xtol=1e-15, rtol=1e-15, maxiter=200)
    raise UsageError(f"load parameter {alpha:.4g} turns the tip to within 1e-6 rad of the load's "
                     "direction, beyond the reference's range.")


def _tip_relative_to_clamp(alpha: float, root_angle: float) -> tuple[float, float, float]:
    """(x, y) of the tip from the clamp in world axes (units of L), and the tip angle."""
    tip_angle = _tip_angle(alpha, root_angle)
    x = math.sqrt(2.0 * (math.sin(tip_angle) - math.sin(root_angle)) / alpha)
    y = _arc_integral(alpha, tip_angle, root_angle, lambda s: s)
    return x, y, tip_angle


def cantilever_tip(alpha: float) -> np.ndarray:
    """Tip of a rigidly clamped cantilever under a perpendicular tip load, in units of L.

    Parameters
    ----------
    alpha : float
        Load parameter P·L²/EI (> 0), the load toward +y.

    Returns
    -------
    ndarray (2,)
        (x/L, y/L) of the tip; y/L → α/3 as α → 0 (beam theory).
    """
    if not alpha > 0:
        raise UsageError(f"the load parameter alpha must be positive, got {alpha}.")
    x, y, _ = _tip_relative_to_clamp(alpha, 0.0)
    return np.array([x, y])


def suspended_tip(whisker, load_n: float) -> ReferenceTip:
    """Tip of the whisker on its compliant root under a perpendicular dead load at the tip.

    Parameters
    ----------
    whisker : RodSpec or WhiskerParams
        Any object with ``length_mm``, ``root_offset_mm``, ``bending_stiffness_n_mm2`` and the
        root stiffnesses (rotational in N·mm/rad, translational in N/mm; None means rigid).
    load_n : float
        Load toward +y (N, > 0).

    Returns
    -------
    ReferenceTip
        The root turns by φ with k_θ·φ = P·(offset·cos φ + x_wire), x_wire the wire's
        reach along x from the clamp; the centre of rotation shifts by P/k_t along +y.
    """
    length, offset, ei, k_rot, k_lin = _whisker_numbers(whisker)
    alpha = load_n * length**2 / ei
    stub = offset / length
    if k_rot is None:
        root_angle = 0.0
    else:
        compliance = ei / (length * k_rot)

        def moment_mismatch(phi: float) -> float:
            x_wire, _, _ = _tip_relative_to_clamp(alpha, phi)
            return phi - compliance * alpha * (stub * math.cos(phi) + x_wire)

        # x_wire <= 1 and cos φ <= 1 bound the root angle; near π/2 the wire would hang along
        # the load, a regime the whisker never reaches (the suspension's stop comes first).
        upper = min(compliance * alpha * (stub + 1.0), _ROOT_ANGLE_MAX)
        if moment_mismatch(upper) < 0:
            raise UsageError(f"a load of {load_n:.4g} N turns this root past "
                             f"{math.degrees(_ROOT_ANGLE_MAX):.0f} degrees; no reference there.")
        root_angle = brentq(moment_mismatch, 0.0, upper, xtol=1e-15, rtol=1e-15)
    x_wire, y_wire, tip_angle = _tip_relative_to_clamp(alpha, root_angle)
    shift = np.array([0.0, 0.0 if k_lin is None else load_n / k_lin])
    clamp = stub * np.array([math.cos(root_angle), math.sin(root_angle)])
    tip = (clamp + np.array([x_wire, y_wire])) * length + shift
    return ReferenceTip(tip, root_angle, shift, tip_angle)


def _whisker_numbers(whisker) -> tuple[float, float, float, float | None, float | None]:
    """(L, offset, EI, k_rot, k_lin) from a RodSpec or a WhiskerParams (same field names)."""
    return (whisker.length_mm, whisker.root_offset_mm, whisker.bending_stiffness_n_mm2,
            whisker.root_rotational_stiffness_n_mm_per_rad,
            whisker.root_translational_stiffness_n_per_mm)
