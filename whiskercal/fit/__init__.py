"""The fit stage: a raw calibration grid -> the calibration artifact, as a library call.

``fit(raw, FitOptions(...)) -> FitResult`` runs every step of ``whiskercal fit`` between reading
the raw grid and writing the artifact (``FitResult.write(path)``); the command, the regression
and the report call it, and so can any script, without click.

- ``options``: ``FitOptions``, one field per option of ``whiskercal fit``.
- ``args``: ``options_from_args``, the options from ``whiskercal fit`` words (golden files).
- ``trace_length``: which trace length a fit uses, and which recorded one it overrides.
- ``run``: ``fit`` and ``calibrate_raw``.
- ``metrics``: the numbers recorded in the artifact's /metrics.
- ``truth``: ``compare_with_twin_truth``, the calibration against the twin's ground truth.
- ``result``: ``FitResult`` and the artifact it writes.
"""

from whiskercal.fit.args import options_from_args
from whiskercal.fit.options import FitOptions
from whiskercal.fit.result import FitResult
from whiskercal.fit.run import calibrate_raw, fit, z_sem_uT
from whiskercal.fit.trace_length import resolve_trace_length
from whiskercal.fit.truth import (TruthComparison, compare_with_twin_truth,
                                  lookup_vs_twin_truth)

__all__ = ["FitOptions", "FitResult", "TruthComparison", "calibrate_raw",
           "compare_with_twin_truth", "fit", "lookup_vs_twin_truth", "options_from_args",
           "resolve_trace_length", "z_sem_uT"]
