"""The sliding plane: tip contact, stick-slip in the friction cone, the switch to tangential
contact and back, the study's geometry, and bad inputs."""

import math
from dataclasses import replace

import numpy as np
import pytest

from whiskercal.errors import UsageError
from whiskercal.twin.physics.mechanics import Plane, WhiskerParams, plane_for_depth, solve_plane
from whiskercal.twin.validation.checks import equilibrium_residual

WHISKER = WhiskerParams()
STEP_MM = 10.0 / 300.0  # the study's 10 mm/s at 300 Hz


def components(eq, plane):
    """(normal, tangential) force on the whisker, N."""
    return eq.force_n @ plane.normal, eq.force_n @ plane.tangent


def slide(depth_mm, n_steps, step_mm=STEP_MM, **friction):
    """Solve along a slide; yields (plane, equilibrium) per step."""
    plane, previous = plane_for_depth(WHISKER, depth_mm, **friction), None
    for i in range(n_steps):
        plane = replace(plane, slide_mm=plane.motion_sign * i * step_mm)
        previous = solve_plane(WHISKER, plane, previous)
        yield plane, previous


def test_plane_short_of_the_tip_leaves_it_free():
    assert solve_plane(WHISKER, plane_for_depth(WHISKER, -2.0)).kind == "free"


def test_tip_contact_lies_on_the_plane_and_balances():
    plane = plane_for_depth(WHISKER, 20.0)
    eq = solve_plane(WHISKER, plane)
    assert eq.kind == "tip"
    assert plane.normal @ eq.tip_mm == pytest.approx(plane.offset_mm, abs=1e-7)
    normal, tangential = components(eq, plane)
    assert normal > 0
    # without history: steady sliding, friction dragging the tip along with the plane
    assert tangential * plane.motion_sign == pytest.approx(plane.mu_kinetic * normal, rel=1e-8)
    assert eq.sliding
    assert equilibrium_residual(eq) < 1e-8


def test_stick_slip_keeps_to_the_friction_cone():
    stuck, slid = 0, 0
    for plane, eq in slide(30.0, 240):
        normal, tangential = components(eq, plane)
        assert eq.kind == "tip" and normal > 0
        if eq.sliding:
            slid += 1
            assert abs(tangential) == pytest.approx(plane.mu_kinetic * normal, rel=1e-9)
            assert tangential * plane.motion_sign > 0  # opposes the tip's slip on the plane
        else:
            stuck += 1
            assert abs(tangential) <= plane.mu_static * normal * (1 + 1e-12)
    assert stuck > 0 and slid > 0


def test_sticking_tip_rides_with_the_plane():
    states = list(slide(30.0, 60))
    pairs = [(a, b) for a, b in zip(states, states[1:]) if not b[1].sliding and not b[1].slips]
    assert pairs
    for (plane_a, eq_a), (plane_b, eq_b) in pairs:
        moved = (plane_b.slide_mm - plane_a.slide_mm) * plane_b.tangent
        np.testing.assert_allclose(eq_b.tip_mm - eq_a.tip_mm, moved, atol=1e-9)
        assert eq_b.anchor_mm == pytest.approx(eq_a.anchor_mm, abs=1e-9)


def test_frictionless_plane_never_sticks_off_the_normal():
    for plane, eq in slide(25.0, 20, mu_static=0.0, mu_kinetic=0.0):
        normal, tangential = components(eq, plane)
        assert abs(tangential) <= 1e-9 * normal


def test_switch_to_tangential_and_back():
    plane, previous, kinds = plane_for_depth(WHISKER, 38.0), None, []
    depths = np.concatenate([np.linspace(38.0, 52.0, 29), np.linspace(52.0, 38.0, 29)])
    for i, depth in enumerate(depths):
        plane = plane_for_depth(WHISKER, depth, plane.motion_sign * i * STEP_MM)
        previous = solve_plane(WHISKER, plane, previous)
        kinds.append(previous.kind)
        if previous.kind == "tangential":
            # the shaft meets the plane before the tip and lies on it to the tip
            assert previous.contact_arc_mm < WHISKER.length_mm
            lying = previous.shape_mm(301)[1:]
            beyond = lying[np.linspace(0, WHISKER.length_mm, 301) > previous.contact_arc_mm]
            np.testing.assert_allclose(beyond @ plane.normal, plane.offset_mm, atol=1e-7)
            assert equilibrium_residual(previous) < 1e-8
        assert np.all(previous.shape_mm(301)[1:] @ plane.normal >= plane.offset_mm - 1e-7)
    assert kinds[0] == "tip" and kinds[-1] == "tip"
    assert "tangential" in kinds
    first, last = kinds.index("tangential"), len(kinds) - 1 - kinds[::-1].index("tangential")
    assert set(kinds[first:last + 1]) == {"tangential"}


def test_study_defaults_follow_the_paper():
    # reference/README.md: tip contact up to about 40 mm, tangential near 45 mm, and at 40 mm
    # the tip near the authors' (54.43, -50.82) mm
    at_40 = solve_plane(WHISKER, plane_for_depth(WHISKER, 40.0))
    assert at_40.kind == "tip"
    assert np.linalg.norm(at_40.tip_mm - [54.43, -50.82]) < 1.5
    assert solve_plane(WHISKER, plane_for_depth(WHISKER, 42.0)).kind == "tip"
    assert solve_plane(WHISKER, plane_for_depth(WHISKER, 47.0)).kind == "tangential"


def test_plane_solves_are_deterministic():
    a = [eq.tip_mm for _, eq in slide(35.0, 30)]
    b = [eq.tip_mm for _, eq in slide(35.0, 30)]
    assert np.array_equal(np.array(a), np.array(b))


@pytest.mark.parametrize("bad", [
    dict(point_mm=(math.nan, 0.0), normal_rad=math.pi),
    dict(point_mm=(70.0, 0.0), normal_rad=math.nan),
    dict(point_mm=(70.0, 0.0), normal_rad=math.pi, slide_mm=math.inf),
    dict(point_mm=(70.0, 0.0), normal_rad=math.pi, mu_static=0.1, mu_kinetic=0.2),
    dict(point_mm=(70.0, 0.0), normal_rad=math.pi, mu_kinetic=-0.1),
    dict(point_mm=(70.0, 0.0), normal_rad=math.pi, motion_sign=0),
])
def test_bad_planes_are_refused(bad):
    with pytest.raises(UsageError):
        Plane(**bad)


def test_bad_depth_is_refused():
    with pytest.raises(UsageError, match="depth_mm"):
        plane_for_depth(WHISKER, math.nan)
    with pytest.raises(UsageError, match="Plane"):
        solve_plane(WHISKER, "the floor")


def _slide_record(depth_mm, step_mm, travel_mm, **friction):
    """Per step of a slide: slide (mm), F_n and F_t along the motion (N), slips, sliding."""
    rows = []
    for plane, eq in slide(depth_mm, int(round(travel_mm / step_mm)), step_mm, **friction):
        normal, tangential = components(eq, plane)
        rows.append((abs(plane.slide_mm), normal, tangential * plane.motion_sign, eq.slips,
                     eq.sliding))
    return np.array(rows)


@pytest.mark.parametrize("depth_mm, motion_sign", [(20.0, -1), (40.0, 1), (40.0, -1)])
def test_stick_slip_saws_with_the_period_the_stiffness_gives(depth_mm, motion_sign):
    rows = _slide_record(depth_mm, 0.002, 1.5, motion_sign=motion_sign)[100:]
    slide_mm, normal, tangential, slips = rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]
    events = slide_mm[slips > 0]
    assert events.size >= 5 and np.all(slips <= 1)   # it re-sticks after every slip
    period_mm = (events[-1] - events[0]) / (events.size - 1)
    # The stiffness against the cone, measured on the stuck steps: the rate at which F_t/F_n
    # climbs, i.e. (dF_t/ds - F_t/F_n·dF_n/ds)/F_n, for F_n changes while the tip is dragged.
    # The slip drops the force by (mu_s - rest ratio)·F_n, so that is the sawtooth's period.
    stuck = (slips[1:] == 0) & (slips[:-1] == 0)
    climb_per_mm = np.median(np.diff(tangential / normal)[stuck] / np.diff(slide_mm)[stuck])
    plane = plane_for_depth(WHISKER, depth_mm, motion_sign=motion_sign)
    assert period_mm == pytest.approx((plane.mu_static - plane.rest_ratio) / climb_per_mm,
                                      rel=0.03)
    # the same period in force terms: ~ (mu_s - rest)·F_n over the tangential stiffness (the
    # stiffness alone ignores F_n's change, 5-30 % at these depths)
    stiffness_n_per_mm = np.median(np.diff(tangential)[stuck] / np.diff(slide_mm)[stuck])
    drop_n = (plane.mu_static - plane.rest_ratio) * np.median(normal)
    assert period_mm == pytest.approx(drop_n / stiffness_n_per_mm, rel=0.3)
    # the sawtooth: the tangential force climbs to mu_s·F_n while stuck, falls to the rest ratio
    ratio = tangential / normal
    assert np.max(ratio) == pytest.approx(plane.mu_static, abs=0.01)
    assert np.min(ratio) == pytest.approx(plane.rest_ratio, abs=0.01)


def test_stick_slip_does_not_depend_on_the_path_step():
    periods = []
    for step_mm in (0.002, 0.05):  # the world steps at most 0.05 mm
        rows = _slide_record(40.0, step_mm, 4.0, motion_sign=1)
        events = np.repeat(rows[:, 0], rows[:, 3].astype(int))
        periods.append((events[-1] - events[1]) / (events.size - 2))
    assert 0.05 < periods[0] < 0.5
    # within one step the ratio is extrapolated linearly: half-period steps stay within 5 %
    assert periods[1] == pytest.approx(periods[0], rel=0.05)


def test_equal_coefficients_slide_steadily_on_the_kinetic_edge():
    rows = _slide_record(30.0, STEP_MM, 1.0, mu_static=0.22, mu_kinetic=0.22)
    assert np.all(rows[1:, 4] == 1.0) and np.all(rows[:, 3] == 0)  # sliding, never a stick-slip
    np.testing.assert_allclose(rows[:, 2] / rows[:, 1], 0.22, rtol=1e-9)


def test_a_full_rebound_doubles_the_force_drop():
    half = plane_for_depth(WHISKER, 30.0, slip_rebound=0.0)
    full = plane_for_depth(WHISKER, 30.0, slip_rebound=1.0)
    assert half.mu_static - half.rest_ratio == pytest.approx(0.08)
    assert full.mu_static - full.rest_ratio == pytest.approx(0.16)
    with pytest.raises(UsageError, match="slip_rebound"):
        plane_for_depth(WHISKER, 30.0, slip_rebound=1.5)


@pytest.mark.parametrize("motion_sign", [1, -1])
@pytest.mark.parametrize("step_mm", [1 / 60, 1 / 30, 0.1, 0.25])
def test_warm_push_in_through_the_switch_to_tangential_never_fails(step_mm, motion_sign):
    # the push-in of a study trial (5 to 40 mm/s at 300 Hz and coarser), warm-started each step
    previous, kinds = None, []
    for depth in np.arange(40.0, 50.0 + 1e-9, step_mm):
        plane = plane_for_depth(WHISKER, depth, motion_sign=motion_sign)
        previous = solve_plane(WHISKER, plane, previous)
        kinds.append(previous.kind)
        assert previous.in_contact
        # no part of the wire behind the surface (the switch is decided on 48 nodes: between
        # them the wire may sag into the plane by a few 1e-5 mm just before it lies down)
        assert np.all(previous.shape_mm(201)[1:] @ plane.normal >= plane.offset_mm - 1e-4)
    switch = kinds.index("tangential")
    assert set(kinds[:switch]) == {"tip"} and set(kinds[switch:]) == {"tangential"}


def test_a_long_step_holds_as_many_slips_as_periods_of_load():
    from whiskercal.twin.physics.plane import slips_within_step

    plane = plane_for_depth(WHISKER, 30.0)            # mu_s 0.30, rest ratio 0.148
    period = plane.mu_static - plane.rest_ratio
    # loaded from 0.2 by 0.5: 0.1 to break loose, then 0.4 = two more periods and 0.096 over
    ratio, slips = slips_within_step(0.2, 0.7, plane)
    assert slips == 3 and ratio == pytest.approx(plane.rest_ratio + 0.4 - 2 * period)
    assert slips_within_step(-0.2, -0.7, plane) == (pytest.approx(-ratio), 3)
    # just over the edge: one slip, at rest
    assert slips_within_step(0.29, 0.3001, plane) == (pytest.approx(plane.rest_ratio + 1e-4), 1)
