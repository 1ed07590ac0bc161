"""A contour run as a robot's recorder would have written it: the magnetometer's stream and the
sensor base's poses in a ROS 2 bag (MCAP), which ``whiskercal replay`` reads back.

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


def refuse_existing(path: str | Path | None) -> None:
    """Refuse a bag path that exists, before a run starts rather than after it."""
    if path is not None and Path(path).exists():
        raise UsageError(f"{path} exists: choose another --record (a bag is never overwritten)")


def record_bag(path: str | Path, columns: dict[str, np.ndarray], rest_field_uT) -> Path:
    """Write the run's stream (``t_s``, ``z_uT``, ``axial_uT``) and poses (``pose``) as a bag."""
    rest = np.asarray(rest_field_uT, float)
    t_s = np.asarray(columns["t_s"], float)
    field = np.tile(rest, (len(t_s), 1))
    field[:, 1] += np.asarray(columns["z_uT"], float)
    field[:, 2] += np.asarray(columns["axial_uT"], float)
    pose = np.asarray(columns["pose"], float).reshape(-1, 3)
    return write_bag(path, [Series(FIELD_TOPIC, "field", t_s, field, SENSOR_FRAME),
                            Series(POSE_TOPIC, "pose", t_s, pose)])
