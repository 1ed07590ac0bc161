"""Where the whisker touches the cylinder: stations round it, tilts at each, depths at each tilt.

Why this geometry identifies the mount: the runtime gives the tip in the base frame, and a
pressed tip lies on the cylinder, so each touch says how far the mount puts that tip from the
surface along the surface's normal seen from the sensor. A mount offset along that normal
moves every tip by the same amount: with one tilt only one direction of the offset is seen.
Tilting the whisker against the normal turns that direction in the base frame, so several
tilts see both x and y. The yaw turns the tips about the base's origin; pressed deeper, the tip
swings round that origin along its arc, so tips at several depths separate a turn from a
shift. Stations round the cylinder make an error in where it stands read differently from each
side, which no mount does, so the wider their arc the less of it goes into the fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.errors import UsageError

TILTS_DEG = (6.0, 14.0, 22.0)
"""How far the whisker leans back from the surface's inward normal, per press (deg): the
object then pushes the whisker toward -y, the side the calibration is made on."""
DEPTHS = (0.3, 0.55, 0.8)
"""The deflections held in each press, as fractions of the reference deflection (the
artifact's target)."""
STANDOFF_MM = 5.0   # the tip this far short of the surface before a press
RETREAT_MM = 35.0   # between presses the tip backs off this far along the whisker
MAX_STEP_DEG = 40.0  # a transit between stations goes round in steps no wider than this


@dataclass(frozen=True)
class Cylinder:
    """The known object: its centre in the robot's world frame and its radius (mm)."""

    center_mm: tuple[float, float]
    radius_mm: float

    def distance_mm(self, points_mm) -> np.ndarray:
        """Signed distance of points (..., 2) from the surface (outside positive)."""
        offset = np.asarray(points_mm, float) - np.asarray(self.center_mm, float)
        return np.hypot(offset[..., 0], offset[..., 1]) - self.radius_mm


@dataclass(frozen=True)
class Press:
    """One press: at a station (deg round the cylinder's centre, from its +x axis), the
    whisker tilted by ``tilt_deg``, holding each deflection of ``z_uT`` in turn (µT)."""

    station_deg: float
    tilt_deg: float
    z_uT: tuple[float, ...]

    def heading(self) -> float:
        """The base frame's heading (rad): the inward normal leaned back by the tilt."""
        return math.radians(self.station_deg) + math.pi - math.radians(self.tilt_deg)

    def standoff(self, cylinder: Cylinder, reach_mm: float, back_mm: float = STANDOFF_MM) -> np.ndarray:
        """The base frame's pose (x mm, y mm, heading rad) with the tip ``back_mm`` short of the
        station's surface point along the whisker."""
        angle = math.radians(self.station_deg)
        surface = np.asarray(cylinder.center_mm, float) + cylinder.radius_mm * np.array(
            [math.cos(angle), math.sin(angle)])
        heading = self.heading()
        base = surface - (reach_mm + back_mm) * np.array([math.cos(heading), math.sin(heading)])
        return np.array([*base, heading])


def station_angles(side_deg: float = 180.0, arc_deg: float = 120.0, stations: int = 4) -> np.ndarray:
    """The stations' directions from the cylinder's centre (deg): ``stations`` along an arc
    ``arc_deg`` wide centred on ``side_deg`` (where the robot comes from), checked."""
    from whiskercal.checks import integer, number

    arc = number(arc_deg, "--arc", low=0.0, high=360.0, unit="deg")
    count = integer(stations, "--stations", low=1, high=36)
    span = arc * (1.0 - 1.0 / count) if arc >= 360.0 else arc
    return side_deg + (np.linspace(-span / 2, span / 2, count) if count > 1 else np.zeros(1))


def plan_presses(reference_z_uT: float | None, angles_deg, tilts_deg=TILTS_DEG,
                 depths=DEPTHS) -> list[Press]:
    """The presses, station by station (``station_angles``), each tilt at each station holding
    the ``depths`` of ``reference_z_uT`` (µT, negative: the calibration's side)."""
    if reference_z_uT is None or not reference_z_uT < 0:
        raise UsageError("the artifact has no deflection target to press to: write one with "
                         "`whiskercal optimal-depth report`, or give --target-uT")
    levels = tuple(float(reference_z_uT) * fraction for fraction in depths)
    return [Press(float(angle), float(tilt), levels) for angle in angles_deg for tilt in tilts_deg]


def transit(cylinder: Cylinder, reach_mm: float, start: Press, end: Press) -> list[np.ndarray]:
    """The poses from one press's retreat to the next's: round the cylinder in steps of at most
    MAX_STEP_DEG at the retreat's distance, then to the next retreat."""
    first, last = start.standoff(cylinder, reach_mm, RETREAT_MM), end.standoff(cylinder, reach_mm, RETREAT_MM)
    turn = end.station_deg - start.station_deg
    steps = int(math.ceil(abs(turn) / MAX_STEP_DEG))
    poses = []
    for k in range(1, steps):
        middle = Press(start.station_deg + turn * k / steps, end.tilt_deg, end.z_uT)
        poses.append(middle.standoff(cylinder, reach_mm, RETREAT_MM))
    return [first, *poses, last]
