"""Numbers of the recorded session the replay tests imitate."""

REST_UT = 1160.5      # the octagon session's static reading (docs/replay.md)
