"""``replay``: a recorded magnetometer stream -> the tip track through a calibration's runtime.

>>> from whiskercal import runtime
>>> from whiskercal.replay import ReplayOptions, read_stream, replay, write_all
>>> stream = read_stream("octagon.csv", field_column="magnetic_y")        # doctest: +SKIP
>>> result = replay(stream, runtime.load("CAL.h5"), ReplayOptions(rest=1160.5))  # doctest: +SKIP
>>> write_all("out/", result, result.summary())                           # doctest: +SKIP

Every sample goes through :meth:`whiskercal.runtime.Calibration.tracker` (collision detection,
lookup, constant-state Kalman filter) exactly as a robot would feed it. docs/replay.md describes
the inputs, the rest reading, the out-of-range policies and the files written.
"""

from whiskercal.replay.output import FILES, write_all
from whiskercal.replay.run import (DEFAULT_POLICY, ReplayOptions, ReplayResult, replay,
                                   resolve_rest)
from whiskercal.replay.stream import Stream, read_stream, read_table

__all__ = ["DEFAULT_POLICY", "FILES", "ReplayOptions", "ReplayResult", "Stream", "read_stream",
           "read_table", "replay", "resolve_rest", "write_all"]
