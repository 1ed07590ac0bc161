"""Collect settings that let the twin run a grid in seconds (shared by the collect tests).

Fast feeds, a 50 ms settle, 5 samples a point at 100 Hz: the twin simulates every converted
sample, and nothing the tests assert depends on the dwell. The tip sweep is off: these tests
are about the grid and the run; tests/collect/test_tip_sweep.py runs the sweep (``FAST_DWELL``).
"""

FAST_DWELL = """
[motion]
travel_feed_mm_min = 3000.0
approach_feed_mm_min = 1500.0
[acquisition]
settle_s = 0.05
samples_per_point = 5
baseline_samples = 30
"""
SWEEP_OFF = """
[sweep]
enabled = false
"""
FAST_MOTION = FAST_DWELL + SWEEP_OFF
FAST = FAST_MOTION + """
[sensor]
rate_hz = 100
"""
