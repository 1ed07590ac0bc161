"""The collision threshold ``fit`` stores for the runtime, chosen for the build when not given.

The paper's 300 µT is, on its sensor, the Y deflection of a tip pushed about two millimetres.
On a build whose magnet turns less for the same push (a long or thin wire, a stiff root) 300 µT
is a contact many millimetres deep, and every shallower one reads as no contact at all. So
where the fitted model's frictionless tip curve reads under 300 µT at ``TIP_MOTION_MM`` of tip
motion, the threshold is the z it reads there, never below ``NOISE_FLOOR_SIGMAS`` of one
sample's Y noise (a reading at rest must not pass it). Every other build keeps 300 µT.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.errors import WhiskercalError
from whiskercal.mechfit.tipcurve import tip_family
from whiskercal.model.collision import CollisionParams

PAPER_THRESHOLD_UT = CollisionParams.threshold_uT
# a build reading under 300 µT at this much frictionless tip motion (mm) gets a lower threshold:
# the paper's sensor reads 300 µT a little short of it, so it keeps 300 µT with a margin the
# fitted curve's error cannot cross
TIP_MOTION_MM = 3.0
# one sample's Y noise passes 20 standard deviations essentially never (the real sensor's
# 5.6 µT at rest: 112 µT), and leaves room for slow drift from the static reading
NOISE_FLOOR_SIGMAS = 20.0
# a threshold the tip must move further than this (mm) to pass is warned: shallower contacts
# read as no contact at all
WARN_TIP_MOTION_MM = TIP_MOTION_MM
# tip slopes (rad) the curve is followed to: past 3 mm of tip motion, and past where the noise
# floor is passed, on every build of the family (a 45 mm wire bent 0.4 rad: about 12 mm)
CURVE_MAX_SLOPE_RAD = 0.4


@dataclass(frozen=True)
class ContactThreshold:
    """The threshold (µT from the static reading), the frictionless tip motion (mm) at which
    the fitted model reads it (NaN without a model) and why it was chosen."""

    threshold_uT: float
    tip_motion_mm: float
    source: str

    def metrics(self) -> dict:
        return {"collision_threshold_uT": self.threshold_uT,
                "collision_tip_motion_mm": self.tip_motion_mm,
                "collision_threshold_source": self.source}


def threshold_from_curve(depth_uT: np.ndarray, motion_mm: np.ndarray,
                         sample_noise_uT: float) -> ContactThreshold:
    """The build's threshold from a frictionless tip curve from rest (|z| (n,) µT from the
    static reading and the tip's motion (n,) mm, rest first, both growing) and one sample's Y
    noise (µT)."""
    at_motion = float(np.interp(TIP_MOTION_MM, motion_mm, depth_uT, right=math.inf))
    floor = NOISE_FLOOR_SIGMAS * float(sample_noise_uT)
    if at_motion >= PAPER_THRESHOLD_UT:
        threshold, source = PAPER_THRESHOLD_UT, "paper"
    elif at_motion >= floor:
        threshold, source = at_motion, "tip motion"
    else:
        threshold, source = floor, "noise floor"
    return ContactThreshold(threshold, motion_at(threshold, depth_uT, motion_mm), source)


def motion_at(threshold_uT: float, depth_uT: np.ndarray, motion_mm: np.ndarray) -> float:
    """The tip motion (mm) where the curve's |z| first reaches ``threshold_uT`` (NaN where it
    never does)."""
    reached = np.flatnonzero(depth_uT >= threshold_uT)
    if not len(reached) or reached[0] == 0:
        return math.nan
    k = reached[0]
    share = (threshold_uT - depth_uT[k - 1]) / (depth_uT[k] - depth_uT[k - 1])
    return float(motion_mm[k - 1] + share * (motion_mm[k] - motion_mm[k - 1]))


def contact_threshold(given_uT: float | None, mechanics, sample_noise_uT: float) -> ContactThreshold:
    """``given_uT`` when the user gave one, else the build's (:func:`threshold_from_curve`) on
    the fitted mechanics' tip curve; the paper's 300 µT where no model was fitted. The tip
    motion is reported either way where there is a model."""
    curve = _tip_curve(mechanics)
    if given_uT is not None:
        motion = math.nan if curve is None else motion_at(given_uT, *curve)
        return ContactThreshold(float(given_uT), motion, "given")
    if curve is None:
        return ContactThreshold(PAPER_THRESHOLD_UT, math.nan, "paper (no fitted model)")
    return threshold_from_curve(*curve, sample_noise_uT)


def threshold_warnings(threshold: ContactThreshold) -> list[str]:
    """One line when the runtime sees a contact only after the tip has moved
    ``WARN_TIP_MOTION_MM`` or more."""
    if not threshold.tip_motion_mm > WARN_TIP_MOTION_MM:
        return []
    why = {"given": "as given", "noise floor": f"{NOISE_FLOOR_SIGMAS:g} times one sample's noise"}
    return [f"the collision threshold, {threshold.threshold_uT:.0f} µT "
            f"({why.get(threshold.source, threshold.source)}), is a tip moved "
            f"{threshold.tip_motion_mm:.1f} mm on this build: shallower contacts read as none"]


def _tip_curve(mechanics):
    """(|z| (n,) µT, tip motion (n,) mm) along the fitted model's frictionless tip contact
    from rest, or None without a model or where its curve cannot be followed."""
    if mechanics is None:
        return None
    fit = mechanics.fit
    try:
        family = tip_family(fit.suspension, max_slope_rad=CURVE_MAX_SLOPE_RAD)
    except WhiskercalError:
        return None
    z = fit.pose_map(family.pose)[:, 0]
    return np.abs(z - z[0]), np.linalg.norm(family.tip_mm - family.tip_mm[0], axis=1)
