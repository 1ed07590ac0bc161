"""Collision detection: contact while the deflection departs from the static reading by a threshold.

z is already relative to the static reading (µT), so contact is |z - static_uT| > threshold, with
``static_uT`` left for a drifting baseline. An optional release threshold below the contact one
adds hysteresis, so noise at the threshold does not chatter between contact and free.
"""

from __future__ import annotations

import math

from dataclasses import dataclass

import numpy as np

from whiskercal.model.errors import ModelError


@dataclass(frozen=True)
class CollisionParams:
    """Thresholds in µT (the paper: 300 µT above the static reading, no hysteresis)."""

    threshold_uT: float = 300.0
    release_uT: float | None = None
    static_uT: float = 0.0

    def __post_init__(self) -> None:
        if not 0 < self.threshold_uT < math.inf:
            raise ModelError(f"the collision threshold must be a finite number > 0 µT, not {self.threshold_uT!r}")
        if self.release_uT is not None and not 0 < self.release_uT <= self.threshold_uT:
            raise ModelError("the release threshold must lie in (0, threshold]")

    @property
    def release_level_uT(self) -> float:
        """The |z - static| below which a contact ends."""
        return self.threshold_uT if self.release_uT is None else self.release_uT


class CollisionDetector:
    """Streaming detector: :meth:`update` one z at a time."""

    def __init__(self, params: CollisionParams | None = None) -> None:
        self.params = params or CollisionParams()
        self.contact = False

    def update(self, z_uT: float) -> bool:
        """True while in contact; a non-finite z keeps the previous decision."""
        if z_uT != z_uT or abs(z_uT) == float("inf"):
            return self.contact
        departure = abs(z_uT - self.params.static_uT)
        limit = self.params.release_level_uT if self.contact else self.params.threshold_uT
        self.contact = departure > limit
        return self.contact


def detect(z_uT: np.ndarray, params: CollisionParams | None = None) -> np.ndarray:
    """Contact flags (n,) for a series of z (n,) µT; equal to feeding :meth:`update` in order."""
    params = params or CollisionParams()
    z = np.asarray(z_uT, float)
    if params.release_uT is None:
        departure = np.abs(z - params.static_uT)
        flags = departure > params.threshold_uT
        if np.all(np.isfinite(z)):
            return flags
    detector = CollisionDetector(params)
    return np.array([detector.update(float(value)) for value in z], dtype=bool)
