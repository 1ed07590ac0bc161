"""Stick-slip at the tip against the contour scenes' objects (physics.shape_friction): a polygon's
face behaves as the study's plane does, step by step; a tip on the cylinder sticks, breaks loose
at mu_s, slides at mu_k and sticks again; no friction gives the frictionless contact."""

import math
from dataclasses import replace

import numpy as np
import pytest

from whiskercal.twin.physics.contacts import solve_circle
from whiskercal.twin.physics.coulomb import Coulomb, slips_within_step
from whiskercal.twin.physics.mechanics import Circle, Polygon, WhiskerParams, plane_for_depth, solve_plane
from whiskercal.twin.physics.polygon import solve_polygon
from whiskercal.twin.physics.shape_friction import (Stick, friction_ratio, solve_shape_sticking,
                                                    surface_normal)

WHISKER = WhiskerParams()
STEP_MM = 10.0 / 300.0  # the study's 10 mm/s at 300 Hz
TILT = math.radians(20.0)


def face_of(plane) -> Polygon:
    """A 200 mm square whose face toward the whisker is ``plane``'s surface at its slide."""
    point = plane.material_point_mm(0.0)
    a, b = point - 100.0 * plane.tangent, point + 100.0 * plane.tangent
    return Polygon(np.array([a, b, b - 200.0 * plane.normal, a - 200.0 * plane.normal]))


def ratio_of(eq, obstacle) -> float:
    """Signed F_t/F_n at the tip against the obstacle's surface there."""
    return friction_ratio(eq.force_n, surface_normal(obstacle, eq.tip_mm))[1]


def held_ratio(obstacle, previous, carried: Stick) -> float:
    """F_t/F_n the tip would need to stay at its stuck point (a cone it cannot leave)."""
    eq, _ = solve_shape_sticking(WHISKER, obstacle, Coulomb(10.0, 0.0), previous, carried)
    assert eq.slips == 0
    return ratio_of(eq, obstacle)


def check_against_the_model(friction, obstacle, previous, carried: Stick, eq) -> bool:
    """One step against the Coulomb model: held at its point while the cone allows, else broken
    loose past mu_s, slid along the surface and stuck again at the ratio the slip rule gives.
    True when the step stuck."""
    needed, ratio = held_ratio(obstacle, previous, carried), ratio_of(eq, obstacle)
    if abs(needed) <= friction.mu_static:
        assert eq.slips == 0 and ratio == pytest.approx(needed, abs=1e-9)
        np.testing.assert_allclose(eq.tip_mm, carried.anchor_mm, atol=1e-9)
        return True
    expected, slips = slips_within_step(carried.ratio, needed, friction)
    assert (eq.slips, ratio) == (slips, pytest.approx(expected, abs=1e-7))
    assert friction.rest_ratio - 1e-9 <= abs(ratio) < friction.mu_static
    assert np.hypot(*(eq.tip_mm - carried.anchor_mm)) > 1e-4  # it slid along the surface
    return False


@pytest.mark.parametrize("rebound", [0.9, 0.0])
def test_a_polygon_face_sticks_and_slips_as_the_plane_does(rebound):
    # the study's plane (20 mm deep, dragged at 10 mm/s) and a polygon whose face is that plane,
    # both from the plane's first press: the same model, so the same tips, forces and slips
    friction = Coulomb(0.30, 0.22, rebound)
    plane = plane_for_depth(WHISKER, 20.0, mu_static=0.30, mu_kinetic=0.22, slip_rebound=rebound)
    on_plane = solve_plane(WHISKER, plane)
    on_face, stick = on_plane, Stick(on_plane.tip_mm, friction_ratio(on_plane.force_n, plane.normal)[1])
    slips, stuck, ratios = 0, 0, []
    for i in range(1, 151):
        moved = replace(plane, slide_mm=plane.motion_sign * i * STEP_MM)
        carried = Stick(stick.anchor_mm + plane.motion_sign * STEP_MM * plane.tangent, stick.ratio)
        on_plane = solve_plane(WHISKER, moved, on_plane)
        face = face_of(moved)
        previous = on_face
        on_face, stick = solve_shape_sticking(WHISKER, face, friction, previous, carried)
        assert on_face.kind == on_plane.kind == "tip"
        np.testing.assert_allclose(on_face.tip_mm, on_plane.tip_mm, atol=1e-7)
        np.testing.assert_allclose(on_face.force_n, on_plane.force_n, rtol=1e-6, atol=1e-12)
        assert on_face.slips == on_plane.slips
        stuck += check_against_the_model(friction, face, previous, carried, on_face)
        assert abs((on_face.tip_mm - carried.anchor_mm) @ plane.normal) < 1e-7  # on the face
        slips += on_face.slips
        ratios.append(ratio_of(on_face, face))
    assert slips >= 3 and stuck > 20
    if rebound == 0.0:  # a slip comes to rest on the kinetic edge: |F_t| = mu_k·F_n, nothing carried
        rests = [abs(r) for r in ratios if abs(r) < friction.mu_kinetic + 0.02]
        assert rests and min(rests) == pytest.approx(friction.mu_kinetic, abs=0.02)


def cylinder_at(depth_mm: float, dragged_mm: float) -> Circle:
    """The Ø160 mm cylinder pressed ``depth_mm`` past the undeflected tip along the study's
    20° normal, then moved ``dragged_mm`` along its surface's tangent there."""
    normal = np.array([-math.cos(TILT), -math.sin(TILT)])
    tangent = np.array([-normal[1], normal[0]])
    touch = np.array([WHISKER.reach_mm, 0.0]) + depth_mm * normal
    return Circle(touch - 80.0 * normal + dragged_mm * tangent, 80.0)


def drag_cylinder(friction, n_steps: int, step_mm: float = -STEP_MM):
    """Press the tip 20 mm on the cylinder (frictionless first touch), then drag the cylinder;
    yields (circle, previous equilibrium, stick carried into the step, equilibrium) per step."""
    circle = cylinder_at(20.0, 0.0)
    eq, stick = solve_shape_sticking(WHISKER, circle, friction)
    for i in range(1, n_steps + 1):
        moved = cylinder_at(20.0, i * step_mm)
        carried = Stick(stick.anchor_mm + moved.center_mm - circle.center_mm, stick.ratio)
        previous = eq
        eq, stick = solve_shape_sticking(WHISKER, moved, friction, previous, carried)
        circle = moved
        yield circle, previous, carried, eq


def test_a_tip_on_the_cylinder_sticks_breaks_loose_at_mu_s_and_sticks_again():
    friction = Coulomb(0.30, 0.22)
    slips, ratios = [], []
    for circle, previous, carried, eq in drag_cylinder(friction, 150, step_mm=-STEP_MM / 4):
        assert eq.kind == "tip"
        assert abs(np.hypot(*(eq.tip_mm - circle.center_mm)) - 80.0) < 1e-7  # on the surface
        check_against_the_model(friction, circle, previous, carried, eq)
        slips.append(eq.slips)
        ratios.append(abs(ratio_of(eq, circle)))
    assert slips.count(0) > 40 and sum(slips) >= 10
    # loaded from the frictionless first touch (ratio 0), held until the cone's edge
    first = next(i for i, count in enumerate(slips) if count)
    assert first >= 2 and 0.0 < ratios[0] < ratios[1] < ratios[first - 1] < friction.mu_static


def test_a_tip_sliding_on_the_cylinder_feels_mu_k():
    # mu_s = mu_k: no re-sticking; once loose the tip slides with |F_t| = mu_k·F_n
    friction = Coulomb(0.22, 0.22)
    sliding = 0
    for circle, _, carried, eq in drag_cylinder(friction, 120):
        normal_force, ratio = friction_ratio(eq.force_n, surface_normal(circle, eq.tip_mm))
        assert eq.slips == 0 and normal_force > 0
        if eq.sliding:
            sliding += 1
            assert abs(ratio) == pytest.approx(0.22, rel=1e-8)
            assert np.hypot(*(eq.tip_mm - carried.anchor_mm)) > 1e-4
        else:
            np.testing.assert_allclose(eq.tip_mm, carried.anchor_mm, atol=1e-9)
            assert abs(ratio) <= 0.22
    assert sliding > 50


def test_without_friction_the_cylinder_contact_is_the_frictionless_one():
    frictionless = None
    for circle, _, _, eq in drag_cylinder(Coulomb(0.0, 0.0), 60, step_mm=-0.2):
        frictionless = solve_circle(WHISKER, circle, frictionless)
        assert eq.kind == frictionless.kind == "tip"
        np.testing.assert_allclose(eq.tip_mm, frictionless.tip_mm, atol=1e-7)
        np.testing.assert_allclose(eq.force_n, frictionless.force_n, rtol=1e-6, atol=1e-12)


def test_without_friction_the_polygon_contact_is_the_frictionless_one():
    plane = plane_for_depth(WHISKER, 15.0)
    face = face_of(plane)
    eq, stick = solve_shape_sticking(WHISKER, face, Coulomb(0.0, 0.0))
    frictionless = solve_polygon(WHISKER, face)
    for i in range(1, 61):
        moved = face_of(replace(plane, slide_mm=-0.2 * i))
        shift = moved.vertices_mm[0] - face.vertices_mm[0]
        eq, stick = solve_shape_sticking(WHISKER, moved, Coulomb(0.0, 0.0), eq,
                                         Stick(stick.anchor_mm + shift, stick.ratio))
        frictionless = solve_polygon(WHISKER, moved, frictionless)
        face = moved
        assert eq.kind == frictionless.kind == "tip"
        np.testing.assert_allclose(eq.tip_mm, frictionless.tip_mm, atol=1e-7)
        np.testing.assert_allclose(eq.force_n, frictionless.force_n, rtol=1e-6, atol=1e-12)
