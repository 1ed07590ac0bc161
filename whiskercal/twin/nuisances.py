"""What a real rig does that an ideal twin does not: the nuisances, each a typed parameter, all off
unless asked (docs/error-budget.md says what each models and where its realistic level comes from).

- ``[nuisances.drift]``: the field at the chip moves with no deflection. A session offset (the
  rest reading lands somewhere else each time the sensor is mounted and powered), a temperature
  ramp that scales the magnet's whole field (NdFeB's remanence coefficient), and a stray-field
  step on X, Y and Z while the robot's motors run.
- ``[nuisances.viscoelastic]``: the PLA spiral arms creep. A standard linear solid on the root
  rotation: under a held moment the rotation grows by ``creep_share`` of its elastic value with
  the time constant ``tau_s``, and recovers the same way; loading and unloading at the rates of a
  contour run trace a hysteresis loop.
- ``[nuisances.contact]``: the object's surface is not the ideal outline. Coulomb stick-slip at
  the tip (``mu_static``, ``mu_kinetic``: the twin's own friction model, ``physics.coulomb``),
  and a random height field (rms ``roughness_rms_mm``, correlation length ``correlation_mm``,
  fixed to the object) that moves the surface along its normal under the tip; together they
  make the sample-to-sample fluctuation real contacts show.
- ``[dynamics]`` (a table of its own, beside ``[nuisances]``): the wire's bending modes on top
  of its statics (``physics.dynamics``), off unless it asks for modes.
- ``[nuisances.robot]``: the pose the robot reports is late (``latency_s``) and noisy
  (``pose_noise_mm``, ``heading_noise_rad``); the loop runs at ``rate_hz`` (0: the follower's
  own rate) and each period lasts its nominal length plus a jitter (``jitter_s`` rms), while the
  stamps stay nominal.

The state classes below turn a table into what one run sees (seeded); ``twin.mobile`` applies
them all, and the stage rig (``twin.world``, the ``sim://`` ports) the drift and the creep,
which are the sensor's: on a stage the plane or rod is the scene's own (with its own friction),
and no robot reports a pose. A table whose levels are all 0 changes nothing, bit for bit.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections import deque
from pathlib import Path

import numpy as np
from pydantic import model_validator

from whiskercal.errors import UsageError
from whiskercal.tomlconfig import read_toml
from whiskercal.typedconfig import Table, integer, number, numbers, validate

__all__ = ["ContactTable", "DriftTable", "DynamicsTable", "NUISANCE_NAMES", "Nuisances",
           "PoseChannel", "REALISTIC", "RobotTable", "SOURCES", "SensorNuisances",
           "STAGE_RIG_NUISANCES", "ViscoelasticTable", "load_dynamics", "load_nuisances",
           "nuisances_named", "only", "stage_rig_part", "stage_rig_refusal"]

UT3 = numbers(3, says="a list of 3 numbers of µT (X, Y, Z)")
UT3_NONNEGATIVE = numbers(3, ge=0, says="a list of 3 numbers of µT >= 0 (X, Y, Z)")
NONNEGATIVE = number(ge=0)


class DriftTable(Table):
    """``[nuisances.drift]``: session offset (µT, its sign drawn from the seed), temperature
    ramp (K/min) scaling the whole field by ``field_per_K``, motor stray field (µT) while moving."""

    session_offset_uT: UT3_NONNEGATIVE = (0.0, 0.0, 0.0)
    temperature_K_per_min: number(ge=-10, le=10) = 0.0
    field_per_K: number(ge=-0.01, le=0.01) = -0.0012
    motor_step_uT: UT3 = (0.0, 0.0, 0.0)


class ViscoelasticTable(Table):
    """``[nuisances.viscoelastic]``: the suspension's creep share (0..1) and time constant (s)."""

    creep_share: number(ge=0, le=1) = 0.0
    tau_s: number(gt=0) = 3.0


class ContactTable(Table):
    """``[nuisances.contact]``: the surface's height field, rms and correlation length (mm), and
    Coulomb stick-slip at the tip (static, kinetic; 0: frictionless)."""

    roughness_rms_mm: number(ge=0, le=5) = 0.0
    correlation_mm: number(gt=0) = 0.05
    mu_static: number(ge=0, le=2) = 0.0
    mu_kinetic: number(ge=0, le=2) = 0.0

    @model_validator(mode="after")
    def _static_past_kinetic(self) -> "ContactTable":
        if self.mu_static < self.mu_kinetic:
            raise ValueError("mu_static must be at least mu_kinetic")
        return self


class RobotTable(Table):
    """``[nuisances.robot]``: pose latency (s), pose noise (mm, rad rms), loop rate (Hz; 0: the
    follower's), period jitter (s rms)."""

    latency_s: number(ge=0, le=2) = 0.0
    pose_noise_mm: NONNEGATIVE = 0.0
    heading_noise_rad: NONNEGATIVE = 0.0
    rate_hz: number(ge=0, le=2000) = 0.0
    jitter_s: number(ge=0, le=0.1) = 0.0


class DynamicsTable(Table):
    """``[dynamics]`` of a sensor file: the wire's lowest bending ``modes`` (0: quasi-static, the
    default; 1 or 2) with the damping ratio ``damping_ratio`` and the wire's density
    (``physics.dynamics``, docs/twin.md "Dynamics")."""

    modes: integer(ge=0, le=2) = 0
    damping_ratio: number(gt=0, lt=1) = 0.03
    density_kg_m3: number(gt=0) = 6450.0

    @property
    def off(self) -> bool:
        """True when the whisker is quasi-static (no mode)."""
        return self.modes == 0

    def modes_of(self, whisker):
        """The modes this table asks for, of ``whisker`` (``physics.dynamics.Mode``)."""
        from whiskercal.twin.physics.dynamics import modes

        return modes(whisker, self.modes, self.damping_ratio, self.density_kg_m3)


def load_dynamics(path: str | Path) -> DynamicsTable:
    """The ``[dynamics]`` table of a sensor file (quasi-static without)."""
    if not Path(path).is_file():
        raise UsageError(f"{path}: no such file")
    return validate(DynamicsTable, read_toml(path).get("dynamics", {}), f"{path} [dynamics]")


class Nuisances(Table):
    """The ``[nuisances]`` table of a sensor file (every level 0, off, unless given)."""

    drift: DriftTable = DriftTable()
    viscoelastic: ViscoelasticTable = ViscoelasticTable()
    contact: ContactTable = ContactTable()
    robot: RobotTable = RobotTable()

    @property
    def off(self) -> bool:
        """True when every level is 0: nothing differs from the ideal twin."""
        drift, robot = self.drift, self.robot
        levels = (*drift.session_offset_uT, drift.temperature_K_per_min, *drift.motor_step_uT,
                  self.viscoelastic.creep_share, self.contact.roughness_rms_mm,
                  self.contact.mu_static, self.contact.mu_kinetic, robot.latency_s,
                  robot.pose_noise_mm, robot.heading_noise_rad, robot.rate_hz, robot.jitter_s)
        return not any(levels)


# The realistic levels (docs/error-budget.md says where each comes from; the bench writes them
# with their sources into error-budget.json).
REALISTIC = Nuisances(
    drift=DriftTable(session_offset_uT=(713.0, 713.0, 713.0), temperature_K_per_min=0.05,
                     motor_step_uT=(15.0, 15.0, 15.0)),
    viscoelastic=ViscoelasticTable(creep_share=0.05, tau_s=3.0),
    contact=ContactTable(roughness_rms_mm=0.25, correlation_mm=0.02, mu_static=0.30, mu_kinetic=0.22),
    robot=RobotTable(latency_s=0.033, pose_noise_mm=0.03, heading_noise_rad=0.0005, rate_hz=30.0,
                     jitter_s=0.003))

SOURCES = {
    "drift.session_offset_uT": "measured: the authors' octagon session rested at 1160 µT raw Y, "
                               "their model at 447 µT (reference/README.md); X and Z assumed alike",
    "drift.temperature_K_per_min": "assumed: a lab warming 3 K an hour; the field scales by "
                                   "NdFeB's remanence coefficient, -0.12 %/K (a material figure)",
    "drift.field_per_K": "NdFeB's remanence temperature coefficient, -0.12 %/K (a material "
                         "figure)",
    "drift.motor_step_uT": "assumed: a stepper's stray field at the sensor, a third of the "
                           "Earth's field; not measured on the authors' rig",
    "viscoelastic.creep_share": "assumed: PLA flexures creep a few per cent within seconds; "
                                "not measured on the sensor",
    "viscoelastic.tau_s": "assumed: a PLA flexure creeps over seconds",
    "contact.correlation_mm": "assumed: finer than the 0.25 mm wire's tip, so that samples "
                              "0.03 mm apart (8 mm/s at 300 Hz) see heights apart",
    "contact.roughness_rms_mm": "set so that at the paper's deflection target (-8760 µT) the "
                                "twin's in-contact fluctuation (std of first differences / sqrt "
                                "2), with the friction below, reaches the authors' 45-64 µT "
                                "(reference/README.md); it stands in for every in-contact "
                                "fluctuation the twin lacks (the wire's vibration among them); "
                                "measured back by the error-budget bench",
    "contact.mu_static": "the twin's plane-study friction, 0.30 static and 0.22 kinetic (dry "
                         "polymer on metal is 0.2-0.4), whose stick-slip the twin already models",
    "contact.mu_kinetic": "as contact.mu_static",
    "robot.heading_noise_rad": "assumed: as robot.pose_noise_mm, over a 60 mm lever",
    "robot.latency_s": "assumed: one period of the authors' 30 Hz robot loop",
    "robot.pose_noise_mm": "assumed: a robot arm's pose repeatability, a few hundredths of a mm",
    "robot.rate_hz": "measured: the authors' robot sampled at 30 Hz (the paper)",
    "robot.jitter_s": "assumed: a tenth of the 30 Hz period",
}

NUISANCE_NAMES = ("drift", "viscoelastic", "contact", "robot")


def only(name: str, level: Nuisances = REALISTIC) -> Nuisances:
    """``level``'s table ``name`` alone (one of :data:`NUISANCE_NAMES`), the others off."""
    if name not in NUISANCE_NAMES:
        raise UsageError(f"unknown nuisance {name!r}; choose from {', '.join(NUISANCE_NAMES)}")
    return Nuisances(**{name: getattr(level, name)})


# the nuisances of the sensor itself, which a stage rig has as a robot does
STAGE_RIG_NUISANCES = ("drift", "viscoelastic")


def stage_rig_part(nuisances: Nuisances) -> Nuisances:
    """``nuisances``' drift and creep alone: what a stage rig (``sim://``) takes of them."""
    return Nuisances(**{name: getattr(nuisances, name) for name in STAGE_RIG_NUISANCES})


def stage_rig_refusal(nuisances: Nuisances) -> str:
    """Why a stage rig cannot take ``nuisances`` (a contact or robot level set), or ""."""
    if nuisances == stage_rig_part(nuisances):
        return ""
    return ("a stage rig (sim://) takes the nuisances [nuisances.drift] and "
            "[nuisances.viscoelastic] only: the scene on the stage has its own contact, and no "
            "robot reports a pose; give the contact and robot tables to contour run")


def load_nuisances(path: str | Path) -> Nuisances:
    """The ``[nuisances]`` table of a TOML file (a sensor file may carry one); all off without."""
    if not Path(path).is_file():
        raise UsageError(f"{path}: no such file")
    return validate(Nuisances, read_toml(path).get("nuisances", {}), f"{path} [nuisances]")


def nuisances_named(text: str | None) -> Nuisances:
    """``off`` (or None), ``realistic``, ``realistic:NAME`` (one nuisance alone), or a TOML file."""
    if text is None or text == "off":
        return Nuisances()
    if text == "realistic":
        return REALISTIC
    if text.startswith("realistic:"):
        return only(text.split(":", 1)[1])
    if text.endswith(".toml") or Path(text).is_file():
        return load_nuisances(text)
    raise UsageError(f"unknown nuisances {text!r}: give off, realistic, realistic:NAME "
                     f"({', '.join(NUISANCE_NAMES)}) or a .toml file with a [nuisances] table")


class SensorNuisances:
    """The sensor's side of one run (seeded): the field's drift, the suspension's creep and the
    surface's height under the tip."""

    MODES = 64  # cosines in the surface's height field

    def __init__(self, nuisances: Nuisances, seed: int) -> None:
        self.table = nuisances
        rng = np.random.default_rng([seed, 47])
        drift = nuisances.drift
        self.session_uT = np.asarray(drift.session_offset_uT) * rng.choice((-1.0, 1.0), 3)
        self.creep_rad = 0.0
        contact = nuisances.contact
        self._k = rng.normal(0.0, 1.0 / contact.correlation_mm, (self.MODES, 2))
        self._phase = rng.uniform(0.0, 2 * math.pi, self.MODES)
        self._height = contact.roughness_rms_mm * math.sqrt(2.0 / self.MODES)

    def field_uT(self, field_uT: np.ndarray, t_s: float, moving: bool) -> np.ndarray:
        """The field the chip reads (3,) µT for the true field, ``t_s`` s into the session."""
        drift = self.table.drift
        scale = 1.0 + drift.field_per_K * drift.temperature_K_per_min * t_s / 60.0
        offset = self.session_uT + (np.asarray(drift.motor_step_uT) if moving else 0.0)
        return field_uT * scale + offset

    def creep(self, rotation_rad: float, dt_s: float) -> float:
        """The creep rotation (rad) after ``dt_s`` s at the elastic ``rotation_rad``: the
        standard linear solid's internal variable, relaxing toward ``creep_share`` of it (exact
        for a rotation held over the step)."""
        visco = self.table.viscoelastic
        if visco.creep_share == 0.0:
            return 0.0
        relax = 1.0 - math.exp(-dt_s / visco.tau_s)
        self.creep_rad += (visco.creep_share * rotation_rad - self.creep_rad) * relax
        return self.creep_rad

    def height_mm(self, point_mm) -> float:
        """The surface's height (mm, outward) at a world point: a Gaussian random field with the
        table's rms and a Gaussian correlation of length ``correlation_mm``."""
        if self._height == 0.0:
            return 0.0
        point = np.asarray(point_mm, float)
        return float(self._height * np.sum(np.cos(self._k @ point + self._phase)))


class PoseChannel:
    """The robot's side: the pose it reports is the true one ``latency_s`` earlier (linearly
    interpolated), plus white noise; each period lasts its nominal length plus a jitter."""

    def __init__(self, robot: RobotTable, seed: int) -> None:
        self.table = robot
        self._rng = np.random.default_rng([seed, 48])
        keep = max(4, int(math.ceil(robot.latency_s * 2000)) + 4)
        self._times: deque = deque(maxlen=keep)
        self._poses: deque = deque(maxlen=keep)

    def period_s(self, nominal_s: float) -> float:
        """A period's true length (s): nominal plus the jitter, never below a fifth of it."""
        if self.table.jitter_s == 0.0 or nominal_s == 0.0:
            return nominal_s
        return max(0.2 * nominal_s, nominal_s + float(self._rng.normal(0.0, self.table.jitter_s)))

    def record(self, t_s: float, pose: np.ndarray) -> None:
        """The true pose at time ``t_s`` (s)."""
        self._times.append(float(t_s))
        self._poses.append(np.asarray(pose, float).copy())

    def reported(self, t_s: float) -> np.ndarray:
        """What the robot reports at ``t_s``: the true pose at ``t_s - latency_s``, noisy."""
        pose = self._at(t_s - self.table.latency_s)
        noise = self.table.pose_noise_mm, self.table.pose_noise_mm, self.table.heading_noise_rad
        if any(noise):
            pose = pose + self._rng.normal(0.0, 1.0, 3) * np.asarray(noise)
        return pose

    def _at(self, t_s: float) -> np.ndarray:
        times = self._times
        if t_s <= times[0]:
            return self._poses[0].copy()
        index = bisect_left(times, t_s)
        if index >= len(times):
            return self._poses[-1].copy()
        t0, t1 = times[index - 1], times[index]
        share = 0.0 if t1 == t0 else (t_s - t0) / (t1 - t0)
        return self._poses[index - 1] + share * (self._poses[index] - self._poses[index - 1])
