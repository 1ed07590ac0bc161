"""One rig session shared by every run that moves the stage against the whisker.

``RigSession`` (``rig_session``) opens both boards, identifies, homes or checks homing, starts the
sensor, moves in the whisker frame or in stage coordinates, measures on samples chosen by the
sensor's own clock, halts and stops on every exit path, and gives the run summary's frame counts
and times. ``RigFrame`` (``frame``) maps the whisker frame to stage coordinates. This package sits
above ``whiskercal.rig`` and ``whiskercal.protocol`` and below collect and the study; it does not
import the twin.
"""

from whiskercal.session.frame import RigFrame, outside_travel, rotation
from whiskercal.session.rig_session import (Devices, EncoderMismatchError, RigSession,
                                            SessionConfig, SessionSummary, identify)

__all__ = ["Devices", "EncoderMismatchError", "RigFrame", "RigSession", "SessionConfig",
           "SessionSummary", "identify", "outside_travel", "rotation"]
