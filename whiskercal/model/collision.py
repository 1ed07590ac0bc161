"""Collision detection: contact while the deflection departs from the static reading by a threshold.

z is already relative to the static reading (µT), so contact is |z - static_uT| > threshold, with
``static_uT`` left for a drifting baseline. An optional release threshold below the contact one
adds hysteresis, so noise at the threshold does not chatter between contact and free.

``RestTracker`` re-zeroes a drifting reading: its rest is the mean of the first readings (taken
out of contact), then follows every quiet reading out of contact, so the contact threshold,
applied to the reading less that rest, follows the drift.
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


@dataclass(frozen=True)
class RezeroParams:
    """How the rest follows a drifting reading: the mean of the first ``settle_samples``
    readings (the stream must start out of contact), then an exponential average over
    ``time_constant_samples`` of the readings out of contact within ``quiet_uT`` of the rest
    (so that the ramp into a contact, below the threshold, does not drag it)."""

    settle_samples: int = 10
    time_constant_samples: float = 300.0
    quiet_uT: float = 75.0

    def __post_init__(self) -> None:
        if not (isinstance(self.settle_samples, int) and self.settle_samples >= 1):
            raise ModelError(f"settle_samples must be an integer >= 1, not {self.settle_samples!r}")
        if not 1.0 <= self.time_constant_samples < math.inf:
            raise ModelError("time_constant_samples must be a finite number >= 1")
        if not 0 < self.quiet_uT < math.inf:
            raise ModelError(f"quiet_uT must be a finite number > 0 µT, not {self.quiet_uT!r}")


class RestTracker:
    """The rest (µT) of one or more axes of a drifting stream (:class:`RezeroParams`)."""

    def __init__(self, params: RezeroParams | None = None, axes: int = 2) -> None:
        self.params = params or RezeroParams()
        self.rest_uT = np.zeros(axes)
        self._count = 0
        self._weight = 1.0 / self.params.time_constant_samples

    @property
    def settled(self) -> bool:
        """True once the first ``settle_samples`` readings have been averaged."""
        return self._count >= self.params.settle_samples

    def observe(self, reading_uT, in_contact: bool) -> None:
        """One reading (axes,) µT after the contact decision on it; NaN axes keep their rest."""
        reading = np.asarray(reading_uT, float)
        finite = np.isfinite(reading)
        if not self.settled:  # the mean of the first readings, which must be free of contact
            self._count += 1
            self.rest_uT[finite] += (reading[finite] - self.rest_uT[finite]) / self._count
            return
        quiet = finite & (np.abs(reading - self.rest_uT) < self.params.quiet_uT)
        if in_contact or not quiet[0]:  # the first axis (Y) decides whether the wire is free
            return
        self.rest_uT[quiet] += self._weight * (reading[quiet] - self.rest_uT[quiet])


class CreepInverse:
    """Undo a standard linear solid's creep of the suspension on a reading (µT, each axis): the
    reading is the elastic one plus a crept part that relaxes toward ``share`` of it with the
    time constant ``tau_s`` (``twin.nuisances``' viscoelastic model, read at ``rate_hz``), so
    the elastic one is solved for sample by sample. Needs the creep's share and time constant
    measured on the rig (a push held still, its reading relaxing)."""

    def __init__(self, share: float, tau_s: float, rate_hz: float, axes: int = 2) -> None:
        if not (0 <= share <= 1 and 0 < tau_s < math.inf and 0 < rate_hz < math.inf):
            raise ModelError("the creep's share must lie in 0..1, its time constant and the "
                             "rate be positive numbers")
        self.share = float(share)
        self._relax = 1.0 - math.exp(-1.0 / (tau_s * rate_hz))
        self.crept_uT = np.zeros(axes)

    def update(self, reading_uT) -> np.ndarray:
        """The elastic reading (axes,) µT for one crept reading; NaN axes stay NaN."""
        reading = np.asarray(reading_uT, float)
        a, held = self._relax, self.crept_uT
        elastic = (reading - held * (1.0 - a)) / (1.0 + self.share * a)
        finite = np.isfinite(elastic)
        held[finite] += (self.share * elastic[finite] - held[finite]) * a
        return elastic
