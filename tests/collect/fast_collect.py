"""Collect settings that let the twin run a grid in seconds (shared by the collect tests).

Fast feeds, a 50 ms settle, 5 samples a point at 100 Hz: the twin simulates every converted
sample, and nothing the tests assert depends on the dwell.
"""

FAST_MOTION = """
[motion]
travel_feed_mm_min = 3000.0
approach_feed_mm_min = 1500.0
[acquisition]
settle_s = 0.05
samples_per_point = 5
baseline_samples = 30
"""
FAST = FAST_MOTION + """
[sensor]
rate_hz = 100
"""
