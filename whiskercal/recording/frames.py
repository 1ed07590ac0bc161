"""Poses from ROS's units (metres, quaternions) to whiskercal's (mm, heading rad), and poses at
each field sample's time."""

from __future__ import annotations

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.recording.types import Poses, check_times

M_TO_MM = 1000.0


def heading_of(quaternion) -> np.ndarray:
    """The rotation about the world's z axis (rad) of quaternions (..., 4) as (x, y, z, w)."""
    q = np.asarray(quaternion, float)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def quaternion_of(heading_rad) -> np.ndarray:
    """Quaternions (..., 4) (x, y, z, w) of rotations by ``heading_rad`` about z."""
    half = 0.5 * np.asarray(heading_rad, float)
    zero = np.zeros_like(half)
    return np.stack([zero, zero, np.sin(half), np.cos(half)], axis=-1)


def poses_from_arrays(t_s, position_m, quaternion, source: str) -> Poses:
    """:class:`Poses` (mm, unwrapped heading) from times (n,) s, positions (n, 2) m and
    quaternions (n, 4); refused when empty, not finite, or out of time order."""
    t_s = np.asarray(t_s, float)
    position = np.asarray(position_m, float).reshape(-1, 2) * M_TO_MM
    heading = heading_of(np.asarray(quaternion, float).reshape(-1, 4))
    check_times(t_s, source)
    if not (np.all(np.isfinite(position)) and np.all(np.isfinite(heading))):
        raise UsageError(f"{source}: a pose is not finite")
    return Poses(t_s, np.column_stack([position, np.unwrap(heading)]), source)


def poses_at(poses: Poses, t_s, max_gap_s: float, latency_s: float = 0.0):
    """The pose (n, 3) at each time of ``t_s`` (x, y and the unwrapped heading interpolated
    linearly) and a mask (n,) of the times farther than ``max_gap_s`` from every pose (their
    pose is NaN). A pose stamped t describes the robot at t - ``latency_s``."""
    t_s = np.asarray(t_s, float)
    stamps = np.asarray(poses.t_s, float) - latency_s
    heading = np.unwrap(poses.pose[:, 2])
    pose = np.column_stack([np.interp(t_s, stamps, poses.pose[:, 0]),
                            np.interp(t_s, stamps, poses.pose[:, 1]),
                            np.interp(t_s, stamps, heading)])
    after = np.clip(np.searchsorted(stamps, t_s), 0, len(stamps) - 1)
    before = np.clip(after - 1, 0, len(stamps) - 1)
    nearest = np.minimum(np.abs(stamps[after] - t_s), np.abs(t_s - stamps[before]))
    far = nearest > max_gap_s
    pose[far] = np.nan
    return pose, far
