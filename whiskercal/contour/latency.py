"""A contour run's pose latency, estimated from its own stream and poses, and its contacts placed
again with the poses that estimate shifts (``model.pose_latency``).

The estimate reads the raw tips again from the recorded z and Z axis (the filter's own lag
would otherwise pass for a latency), and places them with the recorded poses interpolated at
each sample's time plus the latency tried. The contacts are then the follower's filtered tips
(recovered from its world estimates and the poses it used) with the shifted poses.
"""

from __future__ import annotations

import numpy as np

from whiskercal.model.pose_latency import LatencyEstimate, estimate_pose_latency


def base_to_world(pose: np.ndarray, tip_mm: np.ndarray) -> np.ndarray:
    """Points (n, 2) of the sensor's base frame in the world, for poses (n, 3)."""
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    return np.column_stack([c * tip_mm[:, 0] - s * tip_mm[:, 1] + pose[:, 0],
                            s * tip_mm[:, 0] + c * tip_mm[:, 1] + pose[:, 1]])


def world_to_base(pose: np.ndarray, world_mm: np.ndarray) -> np.ndarray:
    """World points (n, 2) in the sensor's base frame at poses (n, 3)."""
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    d = world_mm - pose[:, :2]
    return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])


def shifted_poses(t_s: np.ndarray, pose: np.ndarray, latency_s: float) -> np.ndarray:
    """The pose at each sample's time when a pose stamped t describes the robot at t - latency."""
    stamps = t_s - latency_s
    heading = np.unwrap(pose[:, 2])
    return np.column_stack([np.interp(t_s, stamps, pose[:, 0]), np.interp(t_s, stamps, pose[:, 1]),
                            np.interp(t_s, stamps, heading)])


def raw_tips(columns: dict, calibration, rezero: bool) -> np.ndarray:
    """The raw tips (n, 2) mm, base frame (NaN out of contact), read again from the run's z and
    Z axis by a fresh tracker of ``calibration``."""
    tracker = calibration.tracker(out_of_range="clip", rezero=rezero)
    tips = np.full((len(columns["z_uT"]), 2), np.nan)
    for index, (z, axial) in enumerate(zip(columns["z_uT"], columns["axial_uT"])):
        axial = None if axial != axial else float(axial)
        state = tracker.update(float(z), axial)
        if state.raw_tip_mm is not None:
            tips[index] = state.raw_tip_mm
    return tips


def run_latency(columns: dict, calibration, rate_hz: float, rezero: bool = False,
                max_latency_s: float = 0.25) -> LatencyEstimate:
    """The pose latency of a run's columns (``t_s``, ``pose``, ``z_uT``, ``axial_uT``) at its
    loop rate (Hz)."""
    t_s, pose = np.asarray(columns["t_s"], float), np.asarray(columns["pose"], float)
    tips = raw_tips(columns, calibration, rezero)
    return estimate_pose_latency(lambda lag: base_to_world(shifted_poses(t_s, pose, lag), tips),
                                 1.0 / rate_hz, max_latency_s=max_latency_s)


def replaced_contacts(columns: dict, latency_s: float) -> np.ndarray:
    """The run's contact estimates (n, 2) placed again with the poses shifted by ``latency_s``."""
    t_s, pose = np.asarray(columns["t_s"], float), np.asarray(columns["pose"], float)
    tips = world_to_base(pose, np.asarray(columns["estimate_mm"], float))
    return base_to_world(shifted_poses(t_s, pose, latency_s), tips)
