"""The elastica against references that share no code with it: a collocation BVP solve,
Bisshopp & Drucker's published table and small-deflection beam theory."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_bvp

from whiskercal.errors import UsageError
from whiskercal.twin.physics.mechanics import cantilever_tip
from whiskercal.twin.validation.checks import bisshopp_drucker_tip

SPEC_TOLERANCE_L = 1e-4

# Bisshopp & Drucker (1945), Q. Appl. Math. 3: alpha = P·L²/EI -> (vertical deflection / L,
# horizontal tip displacement / L), five decimals as tabulated.
BISSHOPP_DRUCKER_TABLE = {
    1.0: (0.30172, 0.05643),
    2.0: (0.49346, 0.16064),
    3.0: (0.60325, 0.25442),
    5.0: (0.71379, 0.38763),
    10.0: (0.81061, 0.55500),
}


def bvp_tip(alpha: float) -> tuple[float, float]:
    """theta'' = -alpha·cos(theta), theta(0) = 0, theta'(1) = 0, by collocation with load steps."""
    s = np.linspace(0.0, 1.0, 101)
    guess = np.zeros((4, s.size))

    def rhs(_, state, load):
        theta, curvature = state[0], state[1]
        return np.vstack([curvature, -load * np.cos(theta), np.cos(theta), np.sin(theta)])

    for load in np.linspace(0.0, alpha, int(math.ceil(alpha / 3)) + 2)[1:]:
        result = solve_bvp(lambda t, y: rhs(t, y, load),
                           lambda a, b: np.array([a[0], b[1], a[2], a[3]]),
                           s, guess, tol=1e-8, max_nodes=100_000)
        assert result.success, result.message
        s, guess = result.x, result.y
    return float(guess[2, -1]), float(guess[3, -1])


@pytest.mark.parametrize("alpha", [0.3, 1.7, 4.0, 8.5, 14.0, 20.0])
def test_cantilever_matches_collocation_reference(alpha):
    x, y = cantilever_tip(alpha)
    x_ref, y_ref = bvp_tip(alpha)
    assert abs(x - x_ref) < SPEC_TOLERANCE_L
    assert abs(y - y_ref) < SPEC_TOLERANCE_L


@pytest.mark.parametrize("alpha", sorted(BISSHOPP_DRUCKER_TABLE))
def test_cantilever_matches_published_table(alpha):
    deflection, shortening = BISSHOPP_DRUCKER_TABLE[alpha]
    x, y = cantilever_tip(alpha)
    # the table is rounded to 5 decimals
    assert abs(y - deflection) <= 0.6e-5
    assert abs((1.0 - x) - shortening) <= 0.6e-5


@pytest.mark.parametrize("alpha", [1e-4, 1e-3, 1e-2])
def test_small_loads_follow_beam_theory(alpha):
    x, y = cantilever_tip(alpha)
    assert y == pytest.approx(alpha / 3.0, rel=alpha)  # next term is O(alpha^3)
    assert 1.0 - x == pytest.approx(alpha ** 2 / 15.0, rel=0.05)  # (3/5)·(y²/L)


@pytest.mark.parametrize("alpha", [34.0, 42.0, 50.0])
def test_large_loads_stay_on_the_bent_branch(alpha):
    # up to the largest accepted load, against Bisshopp & Drucker's closed form
    assert cantilever_tip(alpha) == pytest.approx(bisshopp_drucker_tip(alpha), abs=SPEC_TOLERANCE_L)


def test_no_load_leaves_it_straight():
    assert cantilever_tip(0.0) == pytest.approx((1.0, 0.0), abs=1e-12)


@pytest.mark.parametrize("alpha", [-1.0, math.nan, math.inf, 51.0, "two"])
def test_bad_alpha_is_refused(alpha):
    with pytest.raises(UsageError, match="alpha"):
        cantilever_tip(alpha)
