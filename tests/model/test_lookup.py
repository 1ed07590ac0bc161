"""The tip lookup: interpolants, out-of-range policies, hold-out choice."""

import numpy as np
import pytest

from analytic import paper_grid_mm, rigid_tip_mm, rigid_z
from whiskercal.model.errors import ModelError, ZOutOfRangeError
from whiskercal.model.lookup import KINDS, TipLookup, build_lookup
from whiskercal.model.surface import fit_surface
from whiskercal.model.trace import Domain, LevelSetProblem

Z = np.linspace(-9000.0, -100.0, 20)
TIPS = np.array([rigid_tip_mm(z, 78.0) for z in Z])


@pytest.mark.parametrize("kind", [k for k in KINDS if k != "polynomial"])
def test_interpolants_pass_through_their_samples(kind):
    lookup = TipLookup(Z, TIPS, kind)
    np.testing.assert_allclose(lookup(Z), TIPS, atol=1e-9)


@pytest.mark.parametrize("kind", KINDS)
def test_scalar_and_batch_paths_agree(kind):
    lookup = TipLookup(Z, TIPS, kind)
    probe = np.linspace(Z[0], Z[-1], 37)
    batch = lookup(probe)
    for z, tip in zip(probe, batch):
        np.testing.assert_allclose(lookup.tip_scalar(float(z)), tip, rtol=0, atol=1e-10)


def test_cubic_spline_between_samples_of_a_smooth_curve():
    lookup = TipLookup(Z, TIPS, "cubic")
    between = (Z[:-1] + Z[1:]) / 2
    truth = np.array([rigid_tip_mm(z, 78.0) for z in between])
    assert np.max(np.linalg.norm(lookup(between) - truth, axis=1)) < 2e-3
    linear = TipLookup(Z, TIPS, "linear")
    assert np.max(np.linalg.norm(linear(between) - truth, axis=1)) > 10 * 2e-3


def test_out_of_range_policies():
    lookup = TipLookup(Z, TIPS, "cubic")
    with pytest.raises(ZOutOfRangeError, match="outside the calibrated range"):
        lookup(-9500.0)
    with pytest.raises(ZOutOfRangeError):
        lookup(np.array([-5000.0, 10.0]))
    nan = lookup(np.array([-5000.0, 10.0, np.nan]), "nan")
    assert np.all(np.isfinite(nan[0])) and np.all(np.isnan(nan[1:]))
    clipped = lookup(np.array([-9500.0, 10.0, np.nan]), "clip")
    np.testing.assert_allclose(clipped[:2], TIPS[[0, -1]], atol=1e-9)
    assert np.all(np.isnan(clipped[2]))
    assert np.all(np.isnan(lookup.tip_scalar(float("nan"), "clip")))
    with pytest.raises(ModelError, match="out_of_range"):
        lookup(-5000.0, "ignore")


def test_build_lookup_chooses_by_holdout_and_reaches_a_micrometre():
    points = paper_grid_mm(reach=(12.5, 90.0), angle_deg=(-50.0, 5.0))
    surface, _ = fit_surface(points, rigid_z(points), 5, "polar")
    z = rigid_z(points)
    problem = LevelSetProblem(surface, Domain.from_points(points, 1.0), 78.0,
                              (float(z.min()), float(z.max())), 26.0)
    lookup, report = build_lookup(problem, 20)
    assert report.rmse_by_kind_mm[report.kind] == min(report.rmse_by_kind_mm.values())
    assert report.holdout_rmse_mm <= 1e-3
    assert problem.z_range_uT[0] <= lookup.z_min_uT < lookup.z_max_uT <= problem.z_range_uT[1]
    tips = np.array([rigid_tip_mm(zz, 78.0) for zz in report.holdout_z_uT])
    assert np.max(np.linalg.norm(lookup(report.holdout_z_uT) - tips, axis=1)) < 5e-3


def test_bad_knots_are_refused():
    with pytest.raises(ModelError):
        TipLookup(Z[::-1], TIPS, "cubic")
    with pytest.raises(ModelError):
        TipLookup(Z, TIPS, "quintic")


def _rigid_problem():
    points = paper_grid_mm(reach=(12.5, 90.0), angle_deg=(-50.0, 5.0))
    surface, _ = fit_surface(points, rigid_z(points), 5, "polar")
    z = rigid_z(points)
    return LevelSetProblem(surface, Domain.from_points(points, 1.0), 78.0,
                           (float(z.min()), float(z.max())), 26.0)


def _failing_at(monkeypatch, bad_z):
    """The fast tracer, made to fail at the given levels (a saddle the trace cannot cross)."""
    from whiskercal.model import trace as trace_module
    from whiskercal.model.errors import NonConvergenceError

    original = trace_module.TRACERS["fast"]

    def tracer(problem, z):
        if np.any(np.isclose(z, bad_z, rtol=0.0, atol=1e-9)):
            raise NonConvergenceError(f"no convergence at z = {z:.1f} µT")
        return original(problem, z)
    monkeypatch.setitem(trace_module.TRACERS, "fast", tracer)


@pytest.mark.parametrize("which", ["knot", "holdout"])
def test_one_untraceable_level_inside_the_range_is_bridged_and_reported(monkeypatch, which):
    problem = _rigid_problem()
    clean, _ = build_lookup(problem, 10)
    knots = clean.z_knots_uT
    bad = knots[5] if which == "knot" else knots[5] + 0.3 * (knots[6] - knots[5])
    dense = np.linspace(knots[0], knots[-1], 9 * 10 + 1)
    bad = dense[np.argmin(np.abs(dense - bad))]
    _failing_at(monkeypatch, [bad])
    lookup, report = build_lookup(problem, 10)
    assert np.allclose(report.untraced_z_uT, [bad]) and "no convergence" in report.untraced_reason
    assert np.array_equal(lookup.z_knots_uT, knots)
    assert bad not in report.holdout_z_uT
    # the bridged knot is where the trace would have put it, to a micrometre
    assert np.max(np.abs(lookup.tips_mm - clean.tips_mm)) < 1e-3


def test_untraceable_levels_in_a_row_are_refused(monkeypatch):
    problem = _rigid_problem()
    clean, _ = build_lookup(problem, 10)
    dense = np.linspace(clean.z_min_uT, clean.z_max_uT, 91)
    _failing_at(monkeypatch, dense[40:42])
    with pytest.raises(ModelError, match="not isolated ones"):
        build_lookup(problem, 10)
