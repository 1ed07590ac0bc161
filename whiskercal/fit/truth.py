"""A calibration against the twin's ground truth, when the raw grid came from the twin.

A real rig has no truth, so every function here answers None for its grids. The twin's true tips
are those of a frictionless contact at the tip (``twin.truth.tip_curve``), the contact the lookup
is meant for; the rod correction is judged against the true contact points the twin recorded.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from whiskercal.fit.trace_length import twin_sensor

TRUTH_SAMPLES = 161  # points of the twin's tip curve (its default)


@dataclass(frozen=True)
class TruthComparison:
    """The lookup against the twin's true tips, and the rod correction against the true contacts.

    Attributes
    ----------
    z_uT : ndarray (m,)
        The truth's z inside the lookup's range, µT.
    true_tip_mm, lookup_tip_mm : ndarray (m, 2)
        The twin's true tip and the lookup's tip at each z, mm.
    contact_error_uncorrected_mm, contact_error_corrected_mm : float or None
        Mean distance (mm) from the true contact points to the rod centres as recorded, and to
        the contact points after the rod correction; None when the grid recorded no contacts.
    """

    z_uT: np.ndarray
    true_tip_mm: np.ndarray
    lookup_tip_mm: np.ndarray
    contact_error_uncorrected_mm: float | None = None
    contact_error_corrected_mm: float | None = None

    @property
    def error_mm(self) -> np.ndarray:
        """Distance (m,) mm between the lookup's and the true tip."""
        return np.linalg.norm(self.lookup_tip_mm - self.true_tip_mm, axis=1)

    @property
    def rmse_mm(self) -> float:
        """RMS of ``error_mm``, mm."""
        return float(np.sqrt(np.mean(self.error_mm ** 2)))

    @property
    def max_mm(self) -> float:
        """Largest ``error_mm``, mm."""
        return float(self.error_mm.max())

    def metrics(self) -> dict:
        """The artifact's truth metrics (``lookup_vs_truth_*``, ``contact_error_*``)."""
        found = {"lookup_vs_truth_rmse_mm": self.rmse_mm, "lookup_vs_truth_max_mm": self.max_mm,
                 "lookup_vs_truth_points": int(len(self.z_uT))}
        if self.contact_error_corrected_mm is not None:
            found["contact_error_uncorrected_mm"] = self.contact_error_uncorrected_mm
            found["contact_error_corrected_mm"] = self.contact_error_corrected_mm
        return found

    def arrays(self) -> dict[str, np.ndarray]:
        """The artifact's /metrics/truth arrays."""
        return {"z_uT": self.z_uT, "true_tip_mm": self.true_tip_mm,
                "lookup_tip_mm": self.lookup_tip_mm, "error_mm": self.error_mm}


def true_tip_curve(sensor, n: int = TRUTH_SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """The twin sensor's tip curve, its first branch only: z (m,) µT, true tips (m, 2) mm.

    On a soft suspension z folds back, and the tips past the fold (tens of mm from the first
    branch's at the same z) are not what a z -> tip lookup is for.
    """
    from whiskercal.twin import truth

    return truth.first_branch(*truth.tip_curve(sensor, n))


def true_tips_in_range(sensor, z_low_uT: float, z_high_uT: float,
                       n: int = TRUTH_SAMPLES, curve=None) -> tuple[np.ndarray, np.ndarray]:
    """The twin sensor's tip-curve samples (``true_tip_curve``, or ``curve`` made by it
    already) with z in [low, high] µT: z (m,), true tips (m, 2) mm."""
    z, tips = true_tip_curve(sensor, n) if curve is None else curve
    inside = (z >= z_low_uT) & (z <= z_high_uT)
    return z[inside], tips[inside]


def compare_lookup(lookup, z_uT: np.ndarray, true_tip_mm: np.ndarray) -> TruthComparison:
    """A lookup's tips against given true tips (mm) at z (µT) inside its range."""
    return TruthComparison(np.asarray(z_uT, float), np.asarray(true_tip_mm, float),
                           lookup(np.asarray(z_uT, float)))


def truth_sensor(raw):
    """The twin's sensor a raw grid came from, or None unless it has /truth and a twin
    sensor's description or id (a real rig's grid)."""
    return None if raw.truth is None else twin_sensor(raw)


def lookup_vs_twin_truth(raw, lookup, curve=None) -> TruthComparison | None:
    """A lookup (a :class:`~whiskercal.model.lookup.TipLookup`) over its z range against the
    twin's true tips, or None unless the raw grid came from a twin sensor. ``curve``: the
    sensor's ``true_tip_curve``, where it was made already."""
    sensor = truth_sensor(raw)
    if sensor is None:
        return None
    return compare_lookup(lookup, *true_tips_in_range(sensor, lookup.z_min_uT, lookup.z_max_uT,
                                                      curve=curve))


def compare_with_twin_truth(raw, calibration, curve=None) -> TruthComparison | None:
    """A :class:`~whiskercal.model.calibrate.Calibration` of the raw grid against the twin's
    truth: its lookup against the true tips, its rod correction against the true contacts.

    None unless the raw grid came from a twin sensor (it has /truth and a twin sensor's id).
    ``curve``: the sensor's ``true_tip_curve``, where it was made already.
    """
    comparison = lookup_vs_twin_truth(raw, calibration.lookup, curve)
    contact = raw.truth.get("contact_mm") if comparison is not None else None
    if contact is None:
        return comparison
    true_contact = contact[calibration.used]
    known = np.all(np.isfinite(true_contact), axis=1)
    before = np.linalg.norm(raw.rod_center_mm[calibration.used] - true_contact, axis=1)[known]
    after = np.linalg.norm(calibration.contact_points_mm - true_contact, axis=1)[known]
    return replace(comparison, contact_error_uncorrected_mm=float(np.mean(before)),
                   contact_error_corrected_mm=float(np.mean(after)))


# |true z| above which a point is taken as pressed for the sign check, µT (well above any noise)
PRESSED_UT = 100.0


def refuse_z_against_truth(raw) -> None:
    """Refuse, before any fitting, a twin grid whose z reads against its own truth: the pressed
    points' measured z and the twin's noise-free z of the same poses have opposite signs (the
    Y axis read flipped, or the truth belongs to other readings).

    Raises
    ------
    UsageError
        When the pressed points' z and true z point opposite ways.
    """
    from whiskercal.errors import UsageError

    if raw.truth is None or "z_uT" not in raw.truth:
        return
    true_z, z = np.asarray(raw.truth["z_uT"], float), np.asarray(raw.z_uT, float)
    pressed = np.isfinite(true_z) & np.isfinite(z) & (np.abs(true_z) > PRESSED_UT)
    if pressed.sum() >= 3 and float(np.dot(z[pressed], true_z[pressed])) < 0:
        raise UsageError(f"the grid's z reads against the twin's truth at its {int(pressed.sum())} "
                         "pressed points (opposite signs): its Y axis reads flipped; record it "
                         "again with the sensor as calibrated")
