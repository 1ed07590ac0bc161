"""The accuracy goals, and the margin at which a test checks a method against one.

A goal is measured and reported by ``whiskercal bench`` (JSON), never asserted at its edge: an
optimizer's or a simulation's figure moves by a few per cent across CPUs and BLAS builds, so a
test that asserts "<= the goal" passes on one machine and fails on the next. A test asserts
what the method guarantees, with a margin such a move cannot cross: its figure within
:data:`MARGIN` times the goal. That still fails what the tests are there to catch: a lost
identification falls back to the level set (0.44 mm against the 0.25 mm tip-curve goal), a
wrong suspension misses by millimetres.
"""

MARGIN = 1.5

TIP_CURVE_RMSE_MM = 0.25
"""The family's tip-curve goal, RMS over the lookup's range."""
TIP_CURVE_MAX_MM = 0.5
"""The family's tip-curve goal, the worst point."""
DEFAULT_SENSOR_RMSE_MM = 0.15
"""The default sensor's tip-curve goal, RMS."""
REALISTIC_HELD_MM = 0.3
"""Realistic contacts (friction, slant) read through the (Y, Z) table, held 30 samples, RMS."""


def within(value: float, goal: float) -> bool:
    """``value`` within the test margin of ``goal`` (see the module's docstring)."""
    return value <= MARGIN * goal
