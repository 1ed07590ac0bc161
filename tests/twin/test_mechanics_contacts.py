"""Rod, circle and polygon contacts: geometry, balance, the free cases, paths and bad inputs."""

import math
from dataclasses import replace

import numpy as np
import pytest

from whiskercal.errors import UsageError
from whiskercal.twin.physics.mechanics import (Circle, Polygon, WhiskerParams, free, plane_for_depth,
                                       regular_polygon, solve_plane, solve_rod, solve_shape)
from whiskercal.twin.outlines import outline
from whiskercal.twin.physics import elastica as el
from whiskercal.twin.physics.contacts import make_equilibrium
from whiskercal.twin.physics.polygon import polygon_params
from whiskercal.twin.validation.checks import equilibrium_residual

WHISKER = WhiskerParams()
L = WHISKER.length_mm


def tangent_at(eq, arc_mm):
    """Unit tangent of the wire at an arc length, by differencing a fine shape."""
    points = eq.shape_mm(2001)[1:]
    index = int(round(arc_mm / L * 2000))
    lo, hi = max(index - 1, 0), min(index + 1, 2000)
    direction = points[hi] - points[lo]
    return direction / np.linalg.norm(direction)


def test_rod_on_the_shaft_touches_tangentially():
    center, radius = np.array([50.0, -12.0]), 1.5
    eq = solve_rod(WHISKER, center, radius)
    assert eq.kind == "shaft"
    assert 0 < eq.contact_arc_mm < L
    assert np.linalg.norm(eq.contact_mm - center) == pytest.approx(radius, abs=1e-7)
    # frictionless: the force is normal to the wire and points away from the rod
    assert abs(eq.force_n @ tangent_at(eq, eq.contact_arc_mm)) < 1e-3 * np.linalg.norm(eq.force_n)
    assert eq.force_n @ (eq.contact_mm - center) > 0
    assert eq.root_rotation_rad < 0 and eq.tip_mm[1] < 0
    assert equilibrium_residual(eq) < 1e-8


def test_rod_near_the_tip_holds_the_tip():
    center, radius = np.array([78.5, -1.0]), 1.5
    eq = solve_rod(WHISKER, center, radius)
    assert eq.kind == "tip"
    assert eq.contact_arc_mm == pytest.approx(L)
    assert np.linalg.norm(eq.tip_mm - center) == pytest.approx(radius, abs=1e-7)
    away = (eq.tip_mm - center) / radius
    assert eq.force_n @ away == pytest.approx(np.linalg.norm(eq.force_n), rel=1e-7)
    assert equilibrium_residual(eq) < 1e-8


@pytest.mark.parametrize("center", [(90.0, -5.0), (40.0, 3.0), (79.6, -0.5)],
                         ids=["beyond the tip", "above the shaft", "just past the tip"])
def test_rod_that_does_not_reach_leaves_it_free(center):
    eq = solve_rod(WHISKER, center, 1.5)
    assert eq.kind == "free"
    assert np.all(np.isnan(eq.contact_mm)) and np.all(eq.force_n == 0)


def test_whisker_slips_past_a_rod_pushed_beyond_its_reach():
    # At 20 mm down the rotated tip cannot reach x = 77 any more: the wire springs back.
    slipped = solve_rod(WHISKER, (77.0, -20.0), 1.0)
    assert slipped.kind == "free" and slipped.slipped_past
    assert not solve_rod(WHISKER, (90.0, -20.0), 1.0).slipped_past  # never touched at all
    # it stays past the rod while the rod stands where the wire would be ...
    assert solve_rod(WHISKER, (77.0, -2.0), 1.0, slipped).slipped_past
    # ... and meets it again once the rod has cleared the wire and comes back from above
    cleared = solve_rod(WHISKER, (77.0, 5.0), 1.0, slipped)
    assert cleared.kind == "free" and not cleared.slipped_past
    assert solve_rod(WHISKER, (77.0, -2.0), 1.0, cleared).kind == "shaft"


def test_moment_and_force_balance_at_the_root():
    eq = solve_rod(WHISKER, (60.0, -20.0), 1.0)
    lever = eq.contact_mm - eq.root_shift_mm
    moment = lever[0] * eq.force_n[1] - lever[1] * eq.force_n[0]
    k_rot = WHISKER.root_rotational_stiffness_n_mm_per_rad
    assert k_rot * eq.root_rotation_rad == pytest.approx(moment, rel=1e-8)
    k_lin = WHISKER.root_translational_stiffness_n_per_mm
    np.testing.assert_allclose(k_lin * eq.root_shift_mm, eq.force_n, rtol=1e-10)


def test_stiff_wire_on_soft_root_turns_rigidly():
    stiff = replace(WHISKER, youngs_modulus_n_per_mm2=WHISKER.youngs_modulus_n_per_mm2 * 1e6)
    eq = solve_rod(stiff, (40.0, -6.0), 1.0)
    turn = eq.root_rotation_rad
    rigid_tip = eq.root_shift_mm + stiff.reach_mm * np.array([math.cos(turn), math.sin(turn)])
    assert np.linalg.norm(eq.tip_mm - rigid_tip) < 1e-5 * L
    # the rod, the rotated straight wire and the root agree: it touches where the line passes
    assert np.linalg.norm(eq.contact_mm - np.array([40.0, -6.0])) == pytest.approx(1.0, abs=1e-6)


def test_warm_path_reaches_the_cold_solution():
    previous = None
    for y in np.linspace(-1.0, -25.0, 25):
        previous = solve_rod(WHISKER, (55.0, y), 1.0, previous)
    cold = solve_rod(WHISKER, (55.0, -25.0), 1.0)
    np.testing.assert_allclose(previous.tip_mm, cold.tip_mm, atol=1e-8)
    assert previous.kind == cold.kind == "shaft"


def test_solves_are_deterministic():
    first = solve_rod(WHISKER, (65.0, -15.0), 1.0)
    second = solve_rod(WHISKER, (65.0, -15.0), 1.0)
    assert np.array_equal(first.shape_mm(), second.shape_mm())
    assert np.array_equal(first.force_n, second.force_n)


def test_shape_has_the_wire_length():
    eq = solve_rod(WHISKER, (50.0, -20.0), 1.0)
    points = eq.shape_mm(401)
    np.testing.assert_allclose(points[0], eq.root_shift_mm)
    wire = np.linalg.norm(np.diff(points[1:], axis=0), axis=1).sum()
    assert wire == pytest.approx(L, rel=1e-4)
    np.testing.assert_allclose(points[-1], eq.tip_mm, atol=1e-9)
    straight = free(WHISKER).shape_mm(11)
    assert straight.shape == (12, 2) and straight[-1, 0] == pytest.approx(WHISKER.reach_mm)


def test_circle_shape_is_the_rod():
    rod = solve_rod(WHISKER, (45.0, -10.0), 2.0)
    circle = solve_shape(WHISKER, Circle((45.0, -10.0), 2.0))
    np.testing.assert_allclose(rod.tip_mm, circle.tip_mm)


def test_octagon_corner_on_the_shaft():
    octagon = regular_polygon((66.0, 25.0), 30.0, 8, math.pi / 8)
    eq = solve_shape(WHISKER, octagon)
    assert eq.kind == "shaft"
    # the contact is one of the corners, and no part of the wire is inside the octagon
    assert np.min(np.linalg.norm(octagon.vertices_mm - eq.contact_mm, axis=1)) < 1e-6
    assert np.all(octagon.depth_mm(eq.shape_mm(301)[1:]) <= 1e-6)
    assert equilibrium_residual(eq) < 1e-8


def test_tip_on_a_polygon_edge_matches_a_frictionless_plane():
    # a big square whose lower-left face is the study's plane 10 mm in: only the tip meets it
    plane = plane_for_depth(WHISKER, 10.0, mu_static=0.0, mu_kinetic=0.0)
    circumradius = 40.0
    center = plane.point_mm - circumradius * math.cos(math.pi / 4) * plane.normal
    square = regular_polygon(center, circumradius, 4, plane.normal_rad - 1.25 * math.pi)
    eq = solve_shape(WHISKER, square)
    assert eq.kind == "tip"
    assert abs(square.depth_mm(eq.tip_mm[None, :])[0]) < 1e-6
    assert np.all(square.depth_mm(eq.shape_mm(301)[1:]) <= 1e-6)
    np.testing.assert_allclose(eq.tip_mm, solve_plane(WHISKER, plane).tip_mm, atol=1e-6)
    assert equilibrium_residual(eq) < 1e-8


def test_polygon_along_a_path_stays_outside():
    octagon = regular_polygon((66.0, 40.0), 30.0, 8, math.pi / 8)
    previous, kinds = None, set()
    for dy in np.linspace(0.0, -20.0, 21):
        moved = Polygon(octagon.vertices_mm + [0.0, dy])
        previous = solve_shape(WHISKER, moved, previous)
        kinds.add(previous.kind)
        assert np.all(moved.depth_mm(previous.shape_mm(201)[1:]) <= 1e-6)
    assert "shaft" in kinds


def test_a_tip_sliding_over_a_rounded_corner_goes_on_along_it_not_round_the_far_side():
    # seen in a contour run on the rounded square at -7 mT: warm-started from the tip on the
    # top face's last edge, the corner's vertex solves to a physical state with the wire bent
    # the other way (tip 82 mm off); the next edge continues the contact and must be chosen
    pose = np.array([21.12791562, 120.21856511, -1.92318147])
    turn = np.array([[math.cos(pose[2]), math.sin(pose[2])], [-math.sin(pose[2]), math.cos(pose[2])]])
    square = Polygon((outline("rounded-rect").obstacle().vertices_mm - pose[:2]) @ turn.T)
    z = np.array([-1.61401152, -1.74996062, -0.6959451])  # the last pose's tip on edge 62
    p = polygon_params(WHISKER, square, el.TIP_LINE, 62)
    before = make_equilibrium(WHISKER, "tip", el.TIP_LINE, z, p)
    previous = replace(before, solution=before.solution + (62,))
    eq = solve_shape(WHISKER, square, previous)
    assert eq.kind == "tip" and eq.tip_mm[1] < 0.0  # still bent toward -y by the square
    assert np.linalg.norm(eq.tip_mm - before.tip_mm) < 0.1
    assert np.all(square.depth_mm(eq.shape_mm(201)[1:]) <= 1e-6)


@pytest.mark.parametrize("radius", [-1.0, math.nan, math.inf, "thick", None])
def test_bad_rod_radius_is_refused(radius):
    with pytest.raises(UsageError, match="radius"):
        solve_rod(WHISKER, (50.0, -5.0), radius)


@pytest.mark.parametrize("center", [(math.nan, 0.0), (50.0,), "here"])
def test_bad_rod_center_is_refused(center):
    with pytest.raises(UsageError, match="center"):
        solve_rod(WHISKER, center, 1.0)


def test_bad_inputs_are_refused():
    with pytest.raises(UsageError, match="length_mm"):
        WhiskerParams(length_mm=math.nan)
    with pytest.raises(UsageError, match="stiffness"):
        WhiskerParams(root_rotational_stiffness_n_mm_per_rad=-1.0)
    with pytest.raises(UsageError, match="convex"):
        Polygon([[0, 0], [10, 0], [0, 10], [10, 10]])
    with pytest.raises(UsageError, match="Circle or a Polygon"):
        solve_shape(WHISKER, "a cylinder")
    with pytest.raises(UsageError, match="rigid"):
        solve_rod(WHISKER, (2.0, 0.5), 1.0)


def test_a_rod_from_below_mirrors_one_from_above():
    above = solve_rod(WHISKER, (55.0, -14.0), 1.0)
    below = solve_rod(WHISKER, (55.0, 14.0), 1.0, side=-1)
    assert above.kind == below.kind == "shaft"
    np.testing.assert_allclose(below.tip_mm, above.tip_mm * [1, -1], atol=1e-9)
    assert below.root_rotation_rad == pytest.approx(-above.root_rotation_rad, abs=1e-12)


def test_previous_from_another_obstacle_is_only_a_hint():
    from whiskercal.twin.physics.mechanics import plane_for_depth, solve_plane

    octagon_state = solve_shape(WHISKER, regular_polygon((66.0, 25.0), 30.0, 8, math.pi / 8))
    plane = plane_for_depth(WHISKER, 30.0)
    assert np.array_equal(solve_plane(WHISKER, plane, octagon_state).tip_mm,
                          solve_plane(WHISKER, plane).tip_mm)
    rod_state = solve_rod(WHISKER, (60.0, -10.0), 1.0)
    np.testing.assert_allclose(solve_rod(WHISKER, (50.0, -5.0), 1.0, rod_state).tip_mm,
                               solve_rod(WHISKER, (50.0, -5.0), 1.0).tip_mm, atol=1e-9)
