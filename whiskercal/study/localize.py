"""Tip estimates for a recorded stream, through the calibration's runtime (lookup, collision, filter).

The study judges the calibration exactly as a robot would use it: one ``whiskercal.runtime``
tracker per trial, fed one sample at a time (collision detection, the lookup z -> tip, the
constant-state Kalman filter). Samples whose z the calibration cannot map (outside its
calibrated range) get no estimate and are counted. The chip's Z axis goes along when the
calibration carries a (Y, Z) table (``fit``'s default) or loads to follow (``load_branches``);
otherwise Y alone, as the lookup takes it.

``Countermeasures`` asks the tracker for what a rig that drifts and creeps needs
(``runtime.Calibration.tracker``): the rest re-zeroed out of contact, the creep undone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Countermeasures:
    """What the tracker does against a real rig's nuisances (docs/error-budget.md): ``rezero``
    its rest out of contact (the stream must then start out of contact), ``creep`` the
    suspension's (share, time constant s) undone. None of them: the tracker as it ships."""

    rezero: bool = False
    creep: tuple[float, float] | None = None

    @property
    def any(self) -> bool:
        return self.rezero or self.creep is not None


@dataclass
class Estimates:
    """Per-sample output of the runtime's tracker for one stream (mm; NaN where none)."""

    contact: np.ndarray
    raw_tip_mm: np.ndarray
    filtered_tip_mm: np.ndarray
    unmapped: int
    """Samples in contact whose z the calibration refused (out of its range)."""

    @classmethod
    def of(cls, contact: np.ndarray, raw_tip_mm: np.ndarray, filtered_tip_mm: np.ndarray) -> "Estimates":
        """The estimates with their count of contact samples left without a raw tip."""
        return cls(contact=contact, raw_tip_mm=raw_tip_mm, filtered_tip_mm=filtered_tip_mm,
                   unmapped=int(np.sum(contact & np.isnan(raw_tip_mm[:, 0]))))

    def kept(self, mask: np.ndarray) -> "Estimates":
        """The samples of ``mask`` alone."""
        return Estimates.of(self.contact[mask], self.raw_tip_mm[mask], self.filtered_tip_mm[mask])


def track(calibration, z_uT: np.ndarray, axial_uT: np.ndarray | None = None,
          countermeasures: Countermeasures = Countermeasures()) -> Estimates:
    """Run a fresh tracker of ``calibration`` over a stream of z (µT, relative to static).

    Parameters
    ----------
    calibration
        What ``whiskercal.runtime.load`` returns: has ``tracker(out_of_range=)`` whose
        ``update(z_uT)`` returns a state with ``contact``, ``raw_tip_mm`` and ``filtered_tip_mm``.
    z_uT
        The deflection per sample (µT).
    axial_uT
        The chip's Z axis per sample (µT from its static reading), used when the calibration
        has a ``field_table`` or ``load_branches``.
    countermeasures
        Against drift and creep (none by default).
    """
    # "nan": a z outside the calibrated range gives no raw tip, and the tracker goes on
    options = {"rezero": countermeasures.rezero, "creep": countermeasures.creep} \
        if countermeasures.any else {}
    tracker = calibration.tracker(out_of_range="nan", **options)
    n = len(z_uT)
    contact = np.zeros(n, bool)
    raw = np.full((n, 2), np.nan)
    filtered = np.full((n, 2), np.nan)
    axial = None
    if axial_uT is not None and _reads_z_axis(calibration):
        axial = np.asarray(axial_uT, float)
    for i, z in enumerate(np.asarray(z_uT, float)):
        state = tracker.update(float(z)) if axial is None else \
            tracker.update(float(z), float(axial[i]))
        contact[i] = bool(state.contact)
        if state.raw_tip_mm is not None:
            raw[i] = state.raw_tip_mm
        if state.filtered_tip_mm is not None:
            filtered[i] = state.filtered_tip_mm
    return Estimates.of(contact, raw, filtered)


def _reads_z_axis(calibration) -> bool:
    return any(getattr(calibration, name, None) is not None
               for name in ("field_table", "load_branches"))
