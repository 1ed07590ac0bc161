"""The replayed contacts in the world frame: the robot's poses at each sample's time, through
the sensor's mount, applied to the filtered tip.

A pose says where the end effector is (x mm, y mm, heading rad); the mount
(:class:`whiskercal.mount.Mount`) where the sensor's base frame sits on it. Poses are
interpolated at each sample's time (heading unwrapped); a sample farther than ``max_gap_s`` from
every pose gets no world point and is counted. ``latency_s`` shifts the poses: a pose stamped t
describes the robot at t − latency; None estimates it from the data, as the latency that places
the raw tips the smoothest (``model.pose_latency``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.mount import Mount, base_to_world
from whiskercal.recording import Poses, poses_at

DEFAULT_MAX_GAP_S = 0.1


@dataclass(frozen=True)
class WorldFrame:
    """Poses and the mount that place a replay's contacts in the world."""

    poses: Poses
    mount: Mount = Mount()
    max_gap_s: float = DEFAULT_MAX_GAP_S
    latency_s: float | None = 0.0
    mount_source: str = "none (the poses are the sensor's base frame)"

    def place(self, result) -> None:
        """Fill ``result.base_pose``, ``result.world_mm`` and ``result.world`` (a
    :class:`whiskercal.replay.run.ReplayResult`)."""
        latency_s = self.latency_s if self.latency_s is not None else self.estimated_latency_s(result)
        effector, far = poses_at(self.poses, result.t_s, self.max_gap_s, latency_s)
        if len(far) and np.all(far):
            offset = float(np.median(self.poses.t_s) - np.median(result.t_s))
            raise UsageError(f"{self.poses.source}: no sample lies within "
                             f"{self.max_gap_s * 1e3:g} ms of a pose (the poses' clock is "
                             f"{offset:+.6g} s from the stream's): the two are not of one run, "
                             "or not on one clock")
        result.base_pose = self.mount.base_pose(effector)
        result.world_mm = base_to_world(result.base_pose, result.filtered_tip_mm)
        contact_far = int(np.count_nonzero(far & result.contact))
        result.world = {"poses": self.poses.source, "pose_count": len(self.poses),
                        "mount": self.mount_source, "max_pose_gap_ms": self.max_gap_s * 1e3,
                        "pose_latency_ms": latency_s * 1e3,
                        "pose_latency_estimated": self.latency_s is None,
                        "samples_without_pose": int(np.count_nonzero(far)),
                        "contact_samples_without_pose": contact_far,
                        "world_points": int(np.count_nonzero(np.isfinite(result.world_mm[:, 0])))}

    def estimated_latency_s(self, result, max_latency_s: float = 0.25) -> float:
        """The pose latency (s) that places the replay's raw tips the smoothest in the world.

        Raises UsageError when the stream holds no run of contacts long enough."""
        from whiskercal.model.errors import ModelError
        from whiskercal.model.pose_latency import estimate_pose_latency

        period = float(np.median(np.diff(result.t_s))) if len(result.t_s) > 1 else 0.0

        def place(lag: float) -> np.ndarray:
            effector, _ = poses_at(self.poses, result.t_s, self.max_gap_s, lag)
            return base_to_world(self.mount.base_pose(effector), result.raw_tip_mm)

        try:
            return estimate_pose_latency(place, period, max_latency_s).latency_s
        except ModelError as error:
            raise UsageError(f"--pose-latency-ms auto: {error}") from None
