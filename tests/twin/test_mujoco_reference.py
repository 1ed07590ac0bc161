"""The exact elastica references that the MuJoCo engine is judged against.

They are checked against beam theory at small loads and against scipy's collocation BVP solver
(a different method: finite differences of the full ODE system, not quadrature of its first
integral).
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_bvp

from whiskercal.errors import UsageError
from whiskercal.twin.engines.mujoco_model import RodSpec
from whiskercal.twin.engines.mujoco_reference import cantilever_tip, suspended_tip

# A whisker with a compliant root, its numbers written out so the test does not follow the
# twin's defaults as they are tuned.
SUSPENDED = RodSpec(length_mm=75.0, diameter_mm=0.25, youngs_modulus_n_per_mm2=75_000.0,
                    root_offset_mm=3.0, root_rotational_stiffness_n_mm_per_rad=0.5,
                    root_translational_stiffness_n_per_mm=0.05)


def _bvp_tip(alpha: float, stub: float = 0.0, compliance: float = 0.0) -> np.ndarray:
    """Tip (units of L, from the centre of rotation) by collocation on x, y, θ, m and φ."""
    def ode(s, state, params):
        _, _, theta, moment = state
        return np.vstack([np.cos(theta), np.sin(theta), moment, -alpha * np.cos(theta)])

    def boundary(start, end, params):
        (phi,) = params
        return np.array([start[0] - stub * math.cos(phi), start[1] - stub * math.sin(phi),
                         start[2] - phi, end[3], phi - compliance * alpha * end[0]])

    s = np.linspace(0.0, 1.0, 201)
    guess = np.vstack([s, np.zeros_like(s), np.zeros_like(s), alpha * (1.0 - s)])
    solution = solve_bvp(ode, boundary, s, guess, p=[0.0], tol=1e-10, max_nodes=100_000)
    assert solution.success
    return solution.sol(1.0)[:2]


def test_small_load_matches_beam_theory():
    alpha = 1e-3
    x, y = cantilever_tip(alpha)
    assert y == pytest.approx(alpha / 3.0, rel=1e-3)
    # Second order: the tip draws in by the integral of half the squared slope, α²/15.
    assert 1.0 - x == pytest.approx(alpha**2 / 15.0, rel=1e-2)


@pytest.mark.parametrize("alpha", [0.5, 2.0, 10.0])
def test_cantilever_matches_collocation(alpha):
    assert np.allclose(cantilever_tip(alpha), _bvp_tip(alpha), atol=1e-7)


@pytest.mark.parametrize("alpha", [0.5, 2.0])
def test_suspended_matches_collocation(alpha):
    length = SUSPENDED.length_mm
    load_n = alpha * SUSPENDED.force_scale_n
    reference = suspended_tip(SUSPENDED, load_n)
    k_rot, k_lin = (SUSPENDED.root_rotational_stiffness_n_mm_per_rad,
                    SUSPENDED.root_translational_stiffness_n_per_mm)
    compliance = SUSPENDED.bending_stiffness_n_mm2 / (length * k_rot)
    expected = _bvp_tip(alpha, SUSPENDED.root_offset_mm / length, compliance) * length
    expected[1] += load_n / k_lin
    assert np.allclose(reference.tip_mm, expected, atol=1e-5)
    assert reference.root_shift_mm[1] == pytest.approx(load_n / k_lin)


def test_stiff_root_reduces_to_the_clamped_cantilever_on_its_stub():
    stiff = RodSpec(75.0, 0.25, 75_000.0, 3.0, 1e9, 1e9)
    alpha = 2.0
    reference = suspended_tip(stiff, alpha * stiff.force_scale_n)
    clamped = cantilever_tip(alpha) * 75.0 + np.array([3.0, 0.0])
    assert np.allclose(reference.tip_mm, clamped, atol=1e-6)


def test_loads_that_turn_the_root_past_its_range_are_refused():
    with pytest.raises(UsageError, match="turns"):
        suspended_tip(SUSPENDED, 1e4 * SUSPENDED.force_scale_n)
    with pytest.raises(UsageError, match="alpha must be positive"):
        cantilever_tip(0.0)
