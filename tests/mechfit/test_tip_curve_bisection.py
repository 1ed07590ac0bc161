"""The z lookup's tips: every knot's bisection in the tip slope run at once gives the tips a
bisection of each knot alone finds."""

import types

import numpy as np

from whiskercal.mechfit.forward import Suspension
from whiskercal.mechfit.tables import _TipCurve
from whiskercal.mechfit.tipcurve import tip_family


def _one_at_a_time(curve, z_uT):
    k = int(np.clip(np.searchsorted(-curve.z_samples, -z_uT), 1, len(curve.z_samples) - 1))
    lo, hi = curve.slope[k - 1], curve.slope[k]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if curve.z_of_slope(mid) > z_uT else (lo, mid)
    return curve.tip_of_slope(0.5 * (lo + hi))


def test_the_knots_bisected_together_land_where_each_alone_does():
    suspension = Suspension(78.0, 3.0, 1 / 15.0, 4e-4)
    # a pose map whose z falls with the root's turn, bent by the shift and the turn's square
    fit = types.SimpleNamespace(suspension=suspension, pose_map=lambda pose: np.column_stack(
        [4e4 * pose[:, 0] + 900 * pose[:, 2] - 3e3 * pose[:, 0] ** 2, 3e3 * pose[:, 0]]))
    curve = _TipCurve(fit, tip_family(suspension))
    knots = np.linspace(curve.z_samples[-1], curve.z_samples[0], 37)
    expected = np.array([_one_at_a_time(curve, z) for z in knots])
    # the spline is evaluated point by point either way: the same arithmetic, the same tips
    np.testing.assert_allclose(curve.tips_at(knots), expected, rtol=0, atol=1e-12)
    assert np.ptp(expected[:, 1]) > 5.0  # the knots span a real deflection
