"""What a robot loads for contacts anywhere on the shaft: z plus known motion -> contact point.

>>> from whiskercal import runtime, runtime_shaft
>>> calibration = runtime.load("CAL.h5")                               # doctest: +SKIP
>>> tracker = runtime_shaft.shaft_tracker(calibration)                  # doctest: +SKIP
>>> state = tracker.update(z_uT, object_position_mm)  # per sample      # doctest: +SKIP
>>> state.kind, state.localizer.contact_mm, state.localizer.sd_mm       # doctest: +SKIP

``object_position_mm`` is where the touching object is relative to the sensor, in the whisker
frame (mm), up to any constant offset: the stage's or the robot's own position. Only its change
since contact began is used (docs/shaft.md). The tracker detects contact with its own low
threshold (the localizer's prior is that contact begins on the undeflected whisker, so it must
start the contact early), localizes with :class:`whiskercal.model.shaft.ShaftLocalizer`, and
says which kind of contact this is:

- ``"shaft"``: z follows the calibrated surface along the known motion, at a point short of the
  tip; the contact point is ``localizer.contact_mm``;
- ``"tip"``: the data contradict a shaft contact (no point of the surface explains z along the
  motion, or the point lies at the tip): the tip tracker's output (``runtime.Tracker``) applies;
- ``"unknown"``: not decided yet (too little travel or signal); neither output is trusted.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from whiskercal.artifacts import shaft_surface as shaft_surface_group
from whiskercal.artifacts.calibration import surface_of
from whiskercal.model.shaft import (REASON_AMBIGUOUS, REASON_WIDE, LocalizerState, ShaftLocalizer,
                                    ShaftParams)

KIND_SHAFT, KIND_TIP, KIND_UNKNOWN = "shaft", "tip", "unknown"
ONSET_UT = 40.0
"""|z| that begins a contact for the shaft tracker, µT (about 7 samples' noise at 5.6 µT)."""
RELEASE_UT = 25.0
TIP_MARGIN_MM = 3.0
"""A localized contact this close to the trace's end (mm of reach) is the tip's, not the shaft's."""
KIND_SD = 2.0
"""How many standard deviations of the rough contact point must clear the tip's margin."""
TIP_EVIDENCE_TRAVEL_MM = 3.0
"""Travel since contact (mm) after which a shaft model that still fits no point means the tip."""
SAMPLE_NOISE_UT = 5.6
"""One sample's noise, µT: the MLX90393's at the default settings (docs/twin.md); the artifact
holds only the grid's averaged noise. Override with ``noise_uT=`` for another sensor."""
MIN_FIT_UT = 0.0
"""|z| below which a sample adds nothing to the fit (µT): there the surface is extrapolated."""
SHAFT_SURFACE_MISFIT_LENGTH_MM = float("inf")
"""Travel (mm) per independent sample of the shaft surface's misfit: none. What is left of it
after the degree-5 ripple (period a few mm, ``ShaftParams.misfit_length_mm`` 3 mm) varies slowly
along the whisker, over more than a contact's slide, so it counts once per contact; its size is
the artifact's own (the larger of the misfit on the grid and between its columns, docs/shaft.md)."""
MISFIT_RMS = 3.0
"""RMS residual (in noise units) above which the shaft model does not explain z."""


@dataclass(frozen=True)
class ShaftState:
    """One sample: in contact, which kind, and the localizer's estimate (mm)."""

    contact: bool
    kind: str
    localizer: LocalizerState | None

    @property
    def tip_valid(self) -> bool:
        """True when the tip tracker's output applies to this sample (a tip contact)."""
        return self.kind == KIND_TIP


class ShaftTracker:
    """Streaming contact detection, shaft localization and contact kind (module docstring)."""

    def __init__(self, surface, params: ShaftParams, trace_length_mm: float,
                 onset_uT: float = ONSET_UT, release_uT: float = RELEASE_UT,
                 localizer=None) -> None:
        """``localizer``: another localizer with ShaftLocalizer's interface (bench candidates)."""
        self.localizer = localizer if localizer is not None else ShaftLocalizer(surface, params)
        self.trace_length_mm = float(trace_length_mm)
        self.onset_uT, self.release_uT = float(onset_uT), float(release_uT)
        self.contact = False
        self._kind = KIND_UNKNOWN

    def update(self, z_uT: float, position_mm) -> ShaftState:
        """Feed one sample: z (µT, relative to static) and the object's position (mm)."""
        z_uT = float(z_uT)
        if z_uT != z_uT:  # a non-finite sample keeps the contact decision and adds nothing
            return ShaftState(self.contact, self._kind if self.contact else KIND_UNKNOWN, None)
        limit = self.release_uT if self.contact else self.onset_uT
        if abs(z_uT) <= limit:
            if self.contact:
                self.localizer.reset()
            self.contact, self._kind = False, KIND_UNKNOWN
            return ShaftState(False, KIND_UNKNOWN, None)
        self.contact = True
        state = self.localizer.update(z_uT, position_mm)
        self._kind = self._decide(state)
        return ShaftState(True, self._kind, state)

    def _decide(self, state: LocalizerState) -> str:
        """The contact's kind from the localizer's state, afresh each sample: where it puts the
        contact (roughly, three standard deviations clear of the tip's end, before the estimate is
        given), or a shaft model that explains nothing; else unknown."""
        if state.localized:
            reach = float(np.hypot(*state.contact_mm))
            return KIND_TIP if reach > self.trace_length_mm - TIP_MARGIN_MM else KIND_SHAFT
        rough = self.localizer.rough()
        if rough is not None:
            reach, sd = float(np.hypot(*rough[0])), KIND_SD * rough[1]
            if reach + sd < self.trace_length_mm - TIP_MARGIN_MM:
                return KIND_SHAFT
            if reach - sd > self.trace_length_mm - TIP_MARGIN_MM:
                return KIND_TIP
        misfit = state.rms_residual == state.rms_residual and state.rms_residual > MISFIT_RMS
        unexplained = state.reason in (REASON_WIDE, REASON_AMBIGUOUS) or misfit
        if state.travel_mm >= TIP_EVIDENCE_TRAVEL_MM and unexplained:
            return KIND_TIP
        return KIND_UNKNOWN


def shaft_surface_of(calibration):
    """The surface the localizer uses, its misfit on the grid (µT) and the misfit's length (mm):
    the artifact's own shaft surface (``/shaft_surface``, since 1.4), else the tip model's
    surface and its fit RMSE."""
    data = calibration.data
    if data.shaft_surface is not None:
        shaft = data.shaft_surface
        # between the grid's columns the surface may miss by more than on them (column CV)
        misfit = float(np.nanmax([shaft.rmse_uT, shaft.cv_rmse_uT]))
        return (shaft_surface_group.surface_of(shaft), misfit, SHAFT_SURFACE_MISFIT_LENGTH_MM)
    return surface_of(data), float(data.metrics.get("rmse_uT") or 0.0), \
        ShaftParams.misfit_length_mm


def shaft_params_of(calibration, **overrides) -> ShaftParams:
    """Localizer settings for a loaded calibration: a sample's noise and the surface's misfit
    (the RMSE of the surface it uses) in quadrature, its trace length."""
    _, misfit, misfit_length_mm = shaft_surface_of(calibration)
    params = ShaftParams(noise_uT=float(np.hypot(SAMPLE_NOISE_UT, misfit)), systematic_uT=misfit,
                         misfit_length_mm=misfit_length_mm,
                         min_fit_uT=MIN_FIT_UT,
                         search_x_mm=(5.0, float(calibration.data.trace_length_mm)))
    return replace(params, **overrides)


def shaft_tracker(calibration, **overrides) -> ShaftTracker:
    """A fresh shaft tracker for a loaded calibration (``whiskercal.runtime.load``).

    ``overrides``: any :class:`~whiskercal.model.shaft.ShaftParams` field.
    """
    surface = shaft_surface_of(calibration)[0]
    return ShaftTracker(surface, shaft_params_of(calibration, **overrides),
                        calibration.data.trace_length_mm)
