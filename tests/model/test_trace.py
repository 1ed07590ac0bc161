"""Level-set tracing on surfaces with known level sets; every failure detected."""

import functools
import math

import numpy as np
import pytest

from analytic import bent_tip_mm, bent_z, g_uT, paper_grid_mm, rigid_tip_mm, rigid_z
from whiskercal.model.errors import DomainExitError, VanishingGradientError, ZOutOfRangeError
from whiskercal.model.surface import fit_surface
from whiskercal.model.trace import (Domain, LevelSetProblem, find_entry, trace_fast,
                                    trace_paper)

LENGTH_MM = 78.0
WIDE_GRID = paper_grid_mm(reach=(12.5, 90.0), angle_deg=(-70.0, 5.0))  # covers every tip


def problem_for(z_of, points=WIDE_GRID, entry_mm=26.0, **extra) -> LevelSetProblem:
    surface, _ = fit_surface(points, z_of(points), 6, "polar")
    z = z_of(points)
    return LevelSetProblem(surface, Domain.from_points(points, 1.0), LENGTH_MM,
                           (float(z.min()), float(z.max())), entry_mm, **extra)


# fitted when a test first asks (not at collection, which every worker does for every module)
@functools.cache
def rigid_problem() -> LevelSetProblem:
    return problem_for(rigid_z)


@functools.cache
def bent_problem() -> LevelSetProblem:
    return problem_for(bent_z)


@pytest.mark.parametrize("z_uT", [-9000.0, -5000.0, -1500.0, -200.0])
def test_fast_tracer_finds_the_rigid_whiskers_tip(z_uT):
    tip = trace_fast(rigid_problem(), z_uT).tip_mm
    np.testing.assert_allclose(tip, rigid_tip_mm(z_uT, LENGTH_MM), atol=1e-6)


@pytest.mark.parametrize("z_uT", [-8000.0, -3000.0, -500.0])
def test_fast_tracer_follows_a_curved_level_set(z_uT):
    tip = trace_fast(bent_problem(), z_uT).tip_mm
    np.testing.assert_allclose(tip, bent_tip_mm(z_uT, LENGTH_MM, 26.0), atol=1e-5)


@pytest.mark.slow
@pytest.mark.parametrize("z_uT", [-6000.0, -800.0])
def test_paper_and_fast_tracers_agree_at_the_papers_step(z_uT):
    fast, paper = trace_fast(bent_problem(), z_uT), trace_paper(bent_problem(), z_uT)
    assert np.linalg.norm(fast.tip_mm - paper.tip_mm) < 1e-3
    assert paper.evaluations > 100 * fast.evaluations


def test_entry_lies_on_the_level_set_at_the_entry_radius():
    entry = find_entry(bent_problem(), -4000.0)
    assert math.hypot(*entry) == pytest.approx(26.0, abs=1e-9)
    assert float(bent_problem().surface(entry)) == pytest.approx(-4000.0, abs=1e-6)


def test_entry_moves_out_when_the_near_arc_misses_the_level_set():
    # a rectangular grid starting at x = 20 mm: steep level sets cross r = 22 mm outside it
    xs, ys = np.meshgrid(np.arange(20.0, 90.0, 3.0), np.arange(-66.0, 4.0, 3.0))
    grid = np.column_stack([xs.ravel(), ys.ravel()])
    problem = problem_for(rigid_z, grid, entry_mm=22.0)
    result = trace_fast(problem, -9000.0)
    assert math.hypot(*result.entry_mm) > 22.0
    np.testing.assert_allclose(result.tip_mm, rigid_tip_mm(-9000.0, LENGTH_MM), atol=1e-5)


def test_z_outside_the_calibrated_range_is_refused():
    low, high = rigid_problem().z_range_uT
    for z in (low - 1.0, high + 1.0, float("nan")):
        with pytest.raises(ZOutOfRangeError, match="outside the calibrated range"):
            trace_fast(rigid_problem(), z)


def test_leaving_the_domain_is_detected_by_both_tracers():
    short = paper_grid_mm(reach=(12.5, 50.0))  # stops 28 mm short of the tip
    problem = problem_for(rigid_z, short)
    for tracer in (trace_fast, trace_paper):
        with pytest.raises(DomainExitError, match="left the calibrated domain"):
            tracer(problem, -3000.0)


def test_straight_extension_past_the_far_edge_and_its_limit():
    grid = paper_grid_mm()  # reach 65 mm: the tip lies 13 mm past it
    allowed = problem_for(rigid_z, grid, extension_radius_mm=63.0, tip_extension_mm=20.0)
    result = trace_fast(allowed, -3000.0)
    assert result.extension_mm == pytest.approx(15.0, abs=1e-6)
    np.testing.assert_allclose(result.tip_mm, rigid_tip_mm(-3000.0, LENGTH_MM), atol=1e-3)
    limited = problem_for(rigid_z, grid, extension_radius_mm=63.0, tip_extension_mm=10.0)
    with pytest.raises(DomainExitError, match="at most 10.0 mm"):
        trace_fast(limited, -3000.0)


def test_vanishing_gradient_is_reported():
    flat_at_zero = lambda p: 1000.0 * np.arctan2(p[..., 1], p[..., 0]) ** 3  # grad = 0 on θ = 0
    problem = problem_for(flat_at_zero, min_gradient_uT_per_mm=0.1)
    with pytest.raises(VanishingGradientError, match="grad f"):
        trace_fast(problem, -1e-12)
    with pytest.raises(VanishingGradientError):
        trace_paper(problem, -1e-12)


def test_root_shift_moves_the_whole_trace():
    shifted = problem_for(lambda p: g_uT(np.arctan2(p[..., 1], p[..., 0] - 1.0)),
                          root_mm=np.array([1.0, 0.0]))
    result = trace_fast(shifted, -4000.0)
    root = np.array([1.0, 0.0])
    assert np.linalg.norm(result.entry_mm - root) == pytest.approx(26.0, abs=1e-9)
    # the level sets are rays from the shifted root: the tip lies one trace length from it
    assert np.linalg.norm(result.tip_mm - root) == pytest.approx(LENGTH_MM, abs=1e-3)
    direction = (result.tip_mm - root) / LENGTH_MM
    assert math.atan2(direction[1], direction[0]) == pytest.approx(
        math.atan2(*(rigid_tip_mm(-4000.0, 1.0)[::-1])), abs=1e-4)
