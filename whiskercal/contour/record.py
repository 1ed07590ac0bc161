"""A contour run as a robot's recorder would have written it: the magnetometer's stream and the
sensor base's poses in a ROS 2 bag (MCAP), which ``whiskercal replay`` reads back. A twin run's
bag is made from its run file's columns (:func:`record_bag`); a robot run's from the samples as
they arrive (:class:`BagRecorder`).

The field messages carry the readings a magnetometer reports: the twin's static field plus the
deflection on Y and Z (the twin models no deflection on X, which keeps its static reading).
The poses are the sensor's base frame in the world (the twin's mobile base carries the sensor
with no mount offset). The static field is kept in the run file's config
(``record.rest_field_uT``): it is the rest reading to replay the bag with.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.recording.bagwrite import (FIELD_TOPIC, POSE_TOPIC, SENSOR_FRAME, Series,
                                           write_bag)


def refuse_existing(path: str | Path | None, force: bool = False) -> None:
    """Refuse a bag path that exists unless ``force`` (the output rule), before a run starts
    rather than after it."""
    if path is not None and Path(path).exists() and not force:
        raise UsageError(f"the bag {path} already exists: pass --force to replace it")


def record_bag(path: str | Path, columns: dict[str, np.ndarray], rest_field_uT,
               replace: bool = False) -> Path:
    """Write the run's stream (``t_s``, ``z_uT``, ``axial_uT``) and poses (``pose``) as a bag."""
    rest = np.asarray(rest_field_uT, float)
    t_s = np.asarray(columns["t_s"], float)
    field = np.tile(rest, (len(t_s), 1))
    field[:, 1] += np.asarray(columns["z_uT"], float)
    field[:, 2] += np.asarray(columns["axial_uT"], float)
    return _stream_bag(path, t_s, field, columns["pose"], replace)


def _stream_bag(path, t_s, field_uT, pose, replace: bool) -> Path:
    """The bag of a field stream (n, 3) µT and the sensor base's poses (n, 3) at times ``t_s``."""
    pose = np.asarray(pose, float).reshape(-1, 3)
    return write_bag(path, [Series(FIELD_TOPIC, "field", t_s, field_uT, SENSOR_FRAME),
                            Series(POSE_TOPIC, "pose", t_s, pose)], replace=replace)


class BagRecorder:
    """A robot run's stream as it arrives (``contour.robot_run.Recorder``): each sample's whole
    reading (µT, X Y Z) at its stamp, and the sensor base's pose then (the end effector's through
    the mount, in the pose topic's frame); :meth:`write` makes the bag, also of a stopped run."""

    def __init__(self, path: str | Path, mount, replace: bool = False) -> None:
        self.path, self.mount, self.replace = Path(path), mount, replace
        self.stamps: list[float] = []
        self.fields: list[np.ndarray] = []
        self.poses: list[np.ndarray] = []

    def add(self, stamp_s: float, field_uT, effector_pose) -> None:
        """One sample."""
        self.stamps.append(float(stamp_s))
        self.fields.append(np.asarray(field_uT, float)[:3])
        self.poses.append(self.mount.base_pose(np.asarray(effector_pose, float)))

    def write(self) -> Path:
        """The bag of every sample added (the field and the base's poses, one each a sample)."""
        return _stream_bag(self.path, np.asarray(self.stamps, float),
                           np.asarray(self.fields, float).reshape(-1, 3), self.poses, self.replace)
