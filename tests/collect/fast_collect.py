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
# A band of a few dozen points (45.5..56.5 mm, -40..-42 deg) for tests that run the grid often.
SMALL_BAND = """
[grid]
reach_min_mm = 45.5
reach_max_mm = 56.5
angle_min_near_deg = -40.0
angle_min_far_deg = -42.0
expected_points = 0
"""
