"""``forward.rod_poses``: the grid's rod solves in one compiled loop give ``rod_equilibria``'s
poses, from rest (each column followed down) and warm-started from a nearby suspension."""

import numpy as np
import pytest

from whiskercal.errors import UsageError
from whiskercal.mechfit.forward import Suspension, pose_of, rod_equilibria, rod_poses
from whiskercal.twin.physics import mechanics

RADIUS_MM = 1.5


def _grid() -> np.ndarray:
    """Three columns of rod centres (mm), each pressed deeper in the stage's order, the last
    past the tip (a tip contact) and one point out of reach (free)."""
    columns = [(30.0, np.linspace(1.0, -6.0, 5)), (55.0, np.linspace(1.0, -12.0, 6)),
               (76.5, np.linspace(2.0, -14.0, 5)), (90.0, np.array([-3.0]))]
    return np.array([(x, y) for x, ys in columns for y in ys])


def _poses(equilibria):
    return np.array([pose_of(e) for e in equilibria]), np.array([e.in_contact for e in equilibria])


def test_poses_from_rest_and_warm_match_the_solver_point_by_point():
    centers = _grid()
    first = Suspension(78.0, 3.0, 1 / 15.0, 4e-4)
    near = Suspension(78.0, 3.0003, 1 / 15.1, 4.1e-4)
    equilibria = rod_equilibria(first, centers, RADIUS_MM)
    solved = rod_poses(first, centers, RADIUS_MM)
    expected, contact = _poses(equilibria)
    assert contact.sum() >= 12 and not contact.all()  # shaft and tip contacts, and a free point
    np.testing.assert_array_equal(solved.in_contact, contact)
    # the same arithmetic in the same order: equal far below any tolerance of the fit
    np.testing.assert_allclose(solved.poses, expected, rtol=0, atol=1e-12)
    warm = rod_poses(near, centers, RADIUS_MM, solved)
    expected_warm, contact_warm = _poses(rod_equilibria(near, centers, RADIUS_MM, equilibria))
    np.testing.assert_array_equal(warm.in_contact, contact_warm)
    np.testing.assert_allclose(warm.poses, expected_warm, rtol=0, atol=1e-12)
    assert np.abs(warm.poses - solved.poses).max() > 1e-6  # the suspension did change them


def test_fresh_points_are_solved_from_rest_and_a_rod_on_the_stub_is_refused():
    centers = _grid()
    suspension = Suspension(78.0, 3.0, 1 / 15.0, 4e-4)
    solved = rod_poses(suspension, centers, RADIUS_MM)
    fresh = np.zeros(len(centers), bool)
    fresh[-2] = True  # the deepest tip contact, solved along its approach again
    again = rod_poses(suspension, centers, RADIUS_MM, solved.warm_starts(fresh))
    np.testing.assert_allclose(again.poses, solved.poses, rtol=0, atol=1e-9)
    with pytest.raises(UsageError, match="beyond the clamp"):
        rod_poses(suspension, np.array([[2.0, -1.0]]), RADIUS_MM)


def test_points_without_a_start_follow_the_rods_path_in_as_the_solver_does():
    """Every point solved from first touch (the tip sweep's way, at every evaluation of a fit)
    in the compiled loop: the contact solver's path, step for step, on a stiff and a soft root,
    with tip contacts and a wire that slips past the rod."""
    centers = np.vstack([_grid(), [(78.5, -1.0), (77.5, -10.0), (78.8, -3.0)]])
    for suspension in (Suspension(78.0, 3.0, 1 / 15.0, 4e-4), Suspension(78.0, 2.0, 1 / 1.5, 0.05)):
        fresh = np.ones(len(centers), bool)
        solved = rod_poses(suspension, centers, RADIUS_MM)
        again = rod_poses(suspension, centers, RADIUS_MM, solved.warm_starts(fresh))
        whisker = suspension.whisker()
        equilibria = [mechanics.solve_rod(whisker, c, RADIUS_MM) for c in centers]
        expected, contact = _poses(equilibria)
        kinds = [e.kind for e in equilibria]
        assert kinds.count("tip") >= 2 and any(e.slipped_past for e in equilibria)
        np.testing.assert_array_equal(again.in_contact, contact)
        np.testing.assert_allclose(again.poses, expected, rtol=0, atol=1e-12)
