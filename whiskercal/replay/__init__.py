"""``replay``: a recorded magnetometer stream -> the tip track through a calibration's runtime.

>>> from whiskercal import runtime
>>> from whiskercal.replay import ReplayOptions, WorldFrame, read_stream, replay, write_all
>>> from whiskercal.recording import read_poses
>>> stream = read_stream("octagon.csv", field_column="magnetic_y")        # doctest: +SKIP
>>> world = WorldFrame(read_poses("/robot/pose", "run/"))                 # doctest: +SKIP
>>> calibration = runtime.load("CAL.h5")                                  # doctest: +SKIP
>>> result = replay(stream, calibration, ReplayOptions(rest=1160.5), world)  # doctest: +SKIP
>>> write_all("out/", result, result.summary())                           # doctest: +SKIP

Every sample goes through :meth:`whiskercal.runtime.Calibration.tracker` (collision detection,
lookup, constant-state Kalman filter) exactly as a robot would feed it, with the chip's Z axis
where the recording has three. docs/replay.md describes the rest reading, the out-of-range
policies and the files written; docs/recordings.md the formats, poses and the mount.
"""

from whiskercal.replay.output import FILES, write_all
from whiskercal.replay.run import (DEFAULT_POLICY, ReplayOptions, ReplayResult, replay,
                                   resolve_rest)
from whiskercal.replay.stream import Stream, read_stream, read_table
from whiskercal.replay.world import WorldFrame

__all__ = ["DEFAULT_POLICY", "FILES", "ReplayOptions", "ReplayResult", "Stream", "WorldFrame",
           "read_stream", "read_table", "replay", "resolve_rest", "write_all"]
