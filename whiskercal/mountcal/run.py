"""``whiskercal mount-cal`` as a library call: press the whisker on a known cylinder on the twin
(``sim://``) or a robot over rosbridge, fit the mount, and say how well it is known.

The twin in process is the default: ``sim://cylinder`` (the twin's Ø160 mm cylinder at the
world's origin) with the options ``mount_error=DX,DY,DEG`` (the sensor truly sits off the
nominal mount by this: mm, mm, degrees), ``seed=N`` and ``rate_hz=R``. A robot is driven
through ``contour.on_robot.connected``, as ``contour run --robot`` drives it: the same link,
mount, limits and watchdog, and a zero twist on every way out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable
from urllib.parse import parse_qs, urlparse

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.mount import Mount
from whiskercal.mountcal.plan import (RETREAT_MM, STANDOFF_MM, Cylinder, plan_presses,
                                      station_angles, transit)
from whiskercal.mountcal.solve import MountFit, solve_mount
from whiskercal.mountcal.touch import RobotDriver, Touch, TwinDriver, go_to, press, retreat

TWIN_URL = "sim://cylinder"
TWIN_OPTIONS = ("mount_error", "seed", "rate_hz")
TWIN_CYLINDER = Cylinder((0.0, 0.0), 80.0)  # twin.outlines' cylinder: Ø160 mm at the origin


@dataclass(frozen=True)
class Routine:
    """What to press and where: the cylinder, the nominal mount, the side the robot comes from
    (deg from the cylinder's centre), the arc the stations span (deg), their number, and the
    deflection the depths are fractions of (None: the artifact's target, µT)."""

    cylinder: Cylinder = TWIN_CYLINDER
    nominal: Mount = Mount()
    side_deg: float = 180.0
    arc_deg: float = 120.0
    stations: int = 4
    target_z_uT: float | None = None


@dataclass
class MountCalResult:
    """The fit, the touches it was made from, and on the twin the true mount."""

    fit: MountFit
    touches: list[Touch]
    routine: Routine
    source: str
    true_mount: Mount | None = None
    extra: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """JSON-able: the fit and its uncertainty; on the twin, the nominal's and the fit's
        error against the true mount."""
        summary = {"source": self.source, "mount": self.fit.summary(),
                   "nominal": self.routine.nominal.as_dict(),
                   "object": {"center_mm": list(self.routine.cylinder.center_mm),
                              "radius_mm": self.routine.cylinder.radius_mm}, **self.extra}
        if self.true_mount is not None:
            summary["truth"] = {"true_mount": self.true_mount.as_dict(),
                                "nominal_error": mount_error(self.routine.nominal, self.true_mount),
                                "fit_error": mount_error(self.fit.mount, self.true_mount),
                                "kinds": sorted({t.kind for t in self.touches})}
        return summary


def mount_error(mount: Mount, true: Mount) -> dict:
    """``mount`` minus ``true`` (mm, mm, deg)."""
    return {key: float(getattr(mount, key) - getattr(true, key)) for key in ("x_mm", "y_mm", "yaw_deg")}


def parse_twin_url(url: str) -> dict:
    """The options of ``sim://cylinder?...`` (module docstring), checked."""
    from whiskercal.checks import positive, seed
    from whiskercal.mount import parse_mount_error

    parsed = urlparse(url)
    if parsed.scheme != "sim" or parsed.netloc not in ("", "cylinder") or parsed.path not in ("", "/"):
        raise UsageError(f"--robot {url!r}: the twin's mount-cal scene is {TWIN_URL}[?options] "
                         "(the cylinder); a robot is rosbridge://HOST:PORT")
    query = parse_qs(parsed.query)
    unknown = set(query) - set(TWIN_OPTIONS)
    if unknown:
        raise UsageError(f"unknown sim:// option(s) {', '.join(sorted(unknown))}; known: "
                         f"{', '.join(TWIN_OPTIONS)}")
    value = lambda key, default: query.get(key, [default])[-1]
    return {"mount_error": parse_mount_error(value("mount_error", "0,0,0"), "sim:// option mount_error"),
            "seed": seed(value("seed", 0), "sim:// option seed"),
            "rate_hz": positive(value("rate_hz", 300.0), "sim:// option rate_hz", high=2000.0, unit="Hz")}


def mount_cal(artifact: str | Path, routine: Routine = Routine(), url: str = TWIN_URL,
              setup=None, echo: Callable[[str], None] = print) -> MountCalResult:
    """Press, fit and return the result (nothing written: :func:`write_result`). ``url`` is
    the twin's (module docstring) unless ``setup`` (a ``contour.on_robot.RobotSetup``, whose
    mount is the nominal one) drives a robot."""
    from whiskercal import runtime

    options = parse_twin_url(url) if setup is None else None
    angles = station_angles(routine.side_deg, routine.arc_deg, routine.stations)
    calibration = runtime.load(artifact)
    reference = calibration.target_z_uT if routine.target_z_uT is None else routine.target_z_uT
    presses = plan_presses(reference, angles)
    tip_of = tip_reader(calibration)
    if setup is not None:
        return _on_robot(setup, calibration, routine, presses, tip_of, echo)
    twin, driver = _twin(calibration.sensor_id, routine, options, presses[0])
    reach_mm = twin.carried.mobile.sensor.whisker.reach_mm
    touches = run_presses(driver, presses, routine.cylinder, tip_of, reach_mm)
    fit = fit_touches(touches, routine, tip_error(calibration))
    return MountCalResult(fit, touches, routine, url, twin.true, {"seed": options["seed"]})


def mount_cal_recorded(track_path: str | Path, artifact: str | Path,
                       routine: Routine = Routine()) -> MountCalResult:
    """The mount from the held touches of a replay track (``mountcal.recorded``) instead of
    pressing; ``artifact`` is the one the replay read (its tip error goes into the
    uncertainty)."""
    from whiskercal import runtime
    from whiskercal.mountcal.recorded import touches_from_track

    touches = touches_from_track(track_path)
    fit = fit_touches(touches, routine, tip_error(runtime.load(artifact)))
    return MountCalResult(fit, touches, routine, str(track_path))


def fit_touches(touches: list[Touch], routine: Routine, tip_error_mm: float) -> MountFit:
    """The mount of the held touches (``solve.solve_mount``)."""
    return solve_mount([t.effector_pose for t in touches], [t.tip_mm for t in touches],
                       routine.cylinder, routine.nominal, tip_error_mm,
                       [t.geometry for t in touches])


def tip_error(calibration) -> float:
    """The artifact's own estimate of its tip error (mm) for the reading mount-cal makes: its
    (Y, Z) table's where it has one, else its shipped lookup's; 0 where it records none."""
    metrics = getattr(calibration.data, "metrics", None) or {}
    key = "field_table_estimated_tip_error_mm" if calibration.field_table is not None else None
    value = metrics.get(key) if key else None
    value = metrics.get("estimated_tip_error_mm") if value is None else value
    return float(value) if value is not None and math.isfinite(float(value)) else 0.0


def tip_reader(calibration) -> Callable[[float, float], np.ndarray]:
    """The tip (base frame, mm) of a held z and Z axis (µT): the artifact's (Y, Z) table where
    it has one and it answers (it reads the contact's direction from the Z axis), else its z
    lookup."""
    table = calibration.field_table

    def tip_of(z_uT: float, axial_uT: float) -> np.ndarray:
        if table is not None:
            x, y = table.tip_scalar(z_uT, axial_uT)
            if x == x:
                return np.array([x, y])
        return np.asarray(calibration.tip(z_uT, out_of_range="clip"), float)
    return tip_of


def _twin(sensor_id: str, routine: Routine, options: dict, first):
    """The twin's cylinder with the sensor at the first press's retreat, and its driver."""
    from whiskercal.contour.mounted import MountedTwin
    from whiskercal.twin.mobile import MobileSensor
    from whiskercal.twin.outlines import outline
    from whiskercal.twin.sensor_file import resolve_sensor

    sensor = resolve_sensor(sensor_id)
    start = first.standoff(TWIN_CYLINDER, sensor.whisker.reach_mm, RETREAT_MM)
    mobile = MobileSensor(sensor, outline("cylinder"), start, seed=options["seed"])
    twin = MountedTwin.placed(mobile, routine.nominal, options["mount_error"])
    return twin, TwinDriver(twin, options["rate_hz"])


def run_presses(driver, presses, cylinder: Cylinder, tip_of, reach_mm: float) -> list[Touch]:
    """Every press in turn, with the transits between them; the touches held. ``reach_mm``
    places the standoffs (the tip's distance from the base frame's origin, undeflected)."""
    touches: list[Touch] = []
    for index, planned in enumerate(presses):
        if index:
            for pose in transit(cylinder, reach_mm, presses[index - 1], planned):
                go_to(driver, pose)
        else:
            go_to(driver, planned.standoff(cylinder, reach_mm, RETREAT_MM))
        go_to(driver, planned.standoff(cylinder, reach_mm, STANDOFF_MM), TRANSIT_APPROACH_MM_S)
        held = press(driver, planned.heading(), planned.z_uT, tip_of)
        touches += [replace(touch, geometry=f"{planned.tilt_deg:g}deg/{level:.0f}uT")
                    for touch, level in zip(held, planned.z_uT)]
        retreat(driver, planned.heading(), RETREAT_MM - STANDOFF_MM)
    driver.robot.stop()
    return touches


TRANSIT_APPROACH_MM_S = 10.0  # the last stretch to a standoff


def _on_robot(setup, calibration, routine: Routine, presses, tip_of, echo) -> MountCalResult:
    """The presses on a robot over rosbridge (a zero twist on every way out)."""
    from whiskercal.contour.on_robot import connected
    from whiskercal.contour.robot_run import RobotLoop, rest_reading

    if setup.dry_run:
        raise UsageError("mount-cal fits what the whisker touches: a --dry-run touches nothing")
    with connected(setup, echo) as (robot, samples):
        robot.stop()
        loop = RobotLoop(0.0, watchdog_s=setup.safety.watchdog_s)
        rest, rate = rest_reading(robot, samples, loop)
        driver = RobotDriver(robot, samples, rest, rate, setup.safety.watchdog_s)
        touches = run_presses(driver, presses, routine.cylinder, tip_of, reach(calibration))
    fit = fit_touches(touches, routine, tip_error(calibration))
    return MountCalResult(fit, touches, routine, setup.url, None, {"rest_uT": list(rest), "rate_hz": rate})


def reach(calibration) -> float:
    """The whisker's reach from the artifact alone (mm): its lookup's tip at the deflection
    nearest rest, which is where the tip of the straight whisker lies, to a fraction of a mm."""
    low, high = calibration.z_range_uT
    return float(np.hypot(*calibration.tip(high if abs(high) < abs(low) else low)))


def parse_cylinder(spec: str, pose_text: str | None) -> Cylinder:
    """``circle:d=D`` (mm) centred at ``X,Y`` (mm; None: the origin) as the known cylinder;
    any other object is refused in one line."""
    from whiskercal.checks import number, positive

    kind, _, rest = str(spec).partition(":")
    key, _, value = rest.partition("=")
    if kind.strip().lower() != "circle" or key.strip() != "d":
        raise UsageError(f"--object {spec!r}: mount-cal touches a cylinder of known diameter: "
                         "give circle:d=D (mm)")
    diameter = positive(value, "--object d", unit="mm")
    cells = [0.0, 0.0] if pose_text is None else str(pose_text).split(",")
    if len(cells) != 2:
        raise UsageError(f"--object-pose must be X,Y (mm, the cylinder's centre), not {pose_text!r}")
    x, y = (number(cell, f"--object-pose {axis}", unit="mm") for axis, cell in zip("xy", cells))
    return Cylinder((x, y), diameter / 2)


def write_result(path: str | Path, result: MountCalResult) -> Path:
    """The fitted mount as a mount file (``whiskercal.mount``), atomically, its uncertainty in
    the comment."""
    from whiskercal.atomic import write_text
    from whiskercal.mount import mount_text

    x, y, yaw = result.fit.std
    comment = (f"whiskercal mount-cal: {len(result.touches)} touches on a cylinder of "
               f"radius {result.routine.cylinder.radius_mm:g} mm ({result.source})\n"
               f"one standard deviation: x {x:.3f} mm, y {y:.3f} mm, yaw {yaw:.3f} deg")
    return write_text(path, mount_text(result.fit.mount, comment))
