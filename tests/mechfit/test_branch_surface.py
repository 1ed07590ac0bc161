"""The follower's loads are kept only near the root poses the magnet map was fitted on."""

import numpy as np

from whiskercal.mechfit.branch_surface import POSE_MARGIN, near_fitted_poses

# a grid's contacts turn and shift the root one way (rad, mm, mm): the 4x stiffer root's
FITTED = np.array([[-0.0804, -0.5484, -0.6685], [-0.0012, -0.0001, -0.0042],
                   [-0.04, -0.3, -0.3]])


def test_a_pose_turned_the_other_way_from_every_contact_is_left_out():
    span = FITTED.max(axis=0) - FITTED.min(axis=0)
    beyond = FITTED.max(axis=0) + 1.01 * POSE_MARGIN * span
    poses = np.array([FITTED.min(axis=0) - 0.99 * POSE_MARGIN * span,  # just past the deepest
                      [0.03, -0.1, -0.1],  # the root turned the other way (a +y bend)
                      [-0.04, -0.3, beyond[2]]])
    assert near_fitted_poses(poses, FITTED).tolist() == [True, False, False]
    # the table's envelope, symmetric about rest, keeps the turned pose
    assert np.all(np.abs(poses[1]) <= 1.5 * np.max(np.abs(FITTED), axis=0))
