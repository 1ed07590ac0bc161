"""Expected failures of the calibration models.

Each is a :class:`~whiskercal.errors.WhiskercalError`, so the CLI prints it as one line; the runtime
raises them unchanged. They subclass :class:`~whiskercal.errors.UsageError` because an input (a z
value, a dataset, an option) is what makes them happen.
"""

from __future__ import annotations

from whiskercal.errors import UsageError


class ModelError(UsageError):
    """A calibration model cannot be fitted or evaluated on this input."""


class FitError(ModelError):
    """The surface cannot be fitted (too few points, an ill-conditioned basis)."""


class TraceError(ModelError):
    """The level-set trace failed; the subclass says why."""


class ZOutOfRangeError(TraceError):
    """The deflection z lies outside the calibrated range."""


class DomainExitError(TraceError):
    """The trace left the calibrated domain (the grid's convex hull plus a margin)."""


class VanishingGradientError(TraceError):
    """|grad f| is too small for the level set to have a direction."""


class NonConvergenceError(TraceError):
    """The trace or the projection onto the level set did not converge."""


class TraceDriftError(TraceError):
    """A fixed-step trace drifted off its level set by more than its step allows (step too large)."""


class ExtrapolationLimitError(TraceError):
    """The tip lies farther past the calibrated grid than the trace may extrapolate."""
