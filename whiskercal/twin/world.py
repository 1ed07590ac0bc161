"""One simulated rig: a stage, what rides on it, a whisker sensor, a clock, and the ground truth.

A `World` owns the stage mechanics and board, the sensor board, the simulated clock and a
seeded generator. At any simulated time it knows where the carriage really is, where the
object on it sits in the whisker frame, the whisker's equilibrium (advanced in small steps in
time order, because the plane's stick-slip depends on the path), the field at the
magnetometer and its raw counts. It keeps a ground-truth record of every sample the sensor
board converts, which in-process users read as ``port.world.truth``.

Worlds are named: ``sim://NAME/stage`` and ``sim://NAME/sensor`` open the two boards of the
world NAME. :func:`create_world` configures one in code before its ports are opened.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field
from functools import cached_property
from typing import Protocol

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.protocol.sensor_config import SensorConfig
from whiskercal.twin.devices.clock import SimClock
from whiskercal.twin.devices.stage import StageFaults, StageMechanics
from whiskercal.twin.devices.virtual_sensor import SensorFaults, VirtualSensor
from whiskercal.twin.devices.virtual_stage import VirtualStage
from whiskercal.twin.physics.whisker import EQUILIBRIUM_KINDS

DEFAULT_ROD_RADIUS_MM = 1.5
# Plane fixture's outward normal in the whisker frame: back toward the root, tilted 20° to -y
# (the study's plane, reference/README.md).
DEFAULT_PLANE_NORMAL_RAD = math.pi + math.radians(20.0)
_KINDS = (*EQUILIBRIUM_KINDS, "failed")


@dataclass(frozen=True)
class RigGeometry:
    """Where the whisker frame sits in the stage's machine coordinates (mm, rad).

    The defaults put the calibration grid (whisker x 20..75, y -40..+10) at stage x 60..115,
    y 60..110, with room above it for the rod's approach from +y and around it for the plane's
    slide; see docs/twin.md.
    """

    origin_stage_mm: tuple[float, float] = (40.0, 100.0)
    angle_rad: float = 0.0  # direction of the whisker's +x axis in stage coordinates

    @cached_property
    def _rotation(self) -> np.ndarray:
        # cached: the world converts the carriage position at every sample
        c, s = math.cos(self.angle_rad), math.sin(self.angle_rad)
        return np.array([[c, -s], [s, c]])

    @cached_property
    def _origin(self) -> np.ndarray:
        return np.asarray(self.origin_stage_mm, float)

    def to_whisker(self, stage_mm) -> np.ndarray:
        """Stage (machine) coordinates -> whisker frame, mm; works on (..., 2)."""
        return (np.asarray(stage_mm, float) - self._origin) @ self._rotation

    def to_stage(self, whisker_mm) -> np.ndarray:
        """Whisker frame -> stage (machine) coordinates, mm; works on (..., 2)."""
        return np.asarray(whisker_mm, float) @ self._rotation.T + self._origin


@dataclass(frozen=True)
class RodFixture:
    """The vertical touch rod; its axis is the end effector's point.

    The rod pushes the whisker away from the side it comes from (``side`` +1: from +y).
    """

    radius_mm: float = DEFAULT_ROD_RADIUS_MM

    def __post_init__(self) -> None:
        # checked here, not at the first solve: the world turns solver errors into "failed"
        # samples, and a negative radius would never touch at all
        from whiskercal.twin.physics.obstacles import finite_number

        finite_number("rod radius (mm)", self.radius_mm, 0.0)

    def obstacle(self, tool_mm: np.ndarray, motion_sign: int, side: int = 1):
        """The rod as a ``Circle`` in the whisker frame, on ``side`` of the whisker."""
        from whiskercal.twin.physics.obstacles import Circle

        return Circle(tool_mm, self.radius_mm, side=side)

    def touches(self, points_mm: np.ndarray, tool_mm: np.ndarray) -> bool:
        """True when the rod reaches any of the points (mm)."""
        return bool(np.min(np.hypot(*(points_mm - tool_mm).T)) <= self.radius_mm)


@dataclass(frozen=True)
class PlaneFixture:
    """A flat plate whose surface passes through the end effector's point.

    Moving the stage along the plate's normal changes the contact depth; moving it along the
    plate slides the surface under the whisker's tip (``Plane.slide_mm``). The plate is
    ``2 * half_length_mm`` long and ``thickness_mm`` thick behind its surface: only a whisker
    inside that box touches it (the mechanics then treat the surface as an infinite plane).
    """

    normal_rad: float = DEFAULT_PLANE_NORMAL_RAD
    mu_static: float | None = None
    mu_kinetic: float | None = None
    slip_rebound: float | None = None  # None: the mechanics' defaults (twin.scenes)
    half_length_mm: float = 60.0
    thickness_mm: float = 10.0

    def touches(self, points_mm: np.ndarray, tool_mm: np.ndarray) -> bool:
        """True when any of the points (mm) lies inside the plate."""
        depth = (tool_mm - points_mm) @ self._normal
        along = (points_mm - tool_mm) @ self._tangent
        inside = (depth >= 0) & (depth <= self.thickness_mm) & (np.abs(along) <= self.half_length_mm)
        return bool(np.any(inside))

    def obstacle(self, tool_mm: np.ndarray, motion_sign: int, side: int = 1):
        """The plate as a ``Plane`` (slid by the tool's position along it) moving ``motion_sign``."""
        from whiskercal.twin.physics.obstacles import Plane

        normal, tangent = self._normal, self._tangent
        offset = normal[0] * tool_mm[0] + normal[1] * tool_mm[1]
        along = tangent[0] * tool_mm[0] + tangent[1] * tool_mm[1]
        return Plane(offset * normal, self.normal_rad, along, motion_sign=motion_sign,
                     **self._friction)

    def tangent(self) -> np.ndarray:
        """Unit vector the stage slides the surface along (whisker frame)."""
        return self._tangent.copy()

    # cached: the world asks at every step of a slide
    @cached_property
    def _normal(self) -> np.ndarray:
        return np.array([math.cos(self.normal_rad), math.sin(self.normal_rad)])

    @cached_property
    def _tangent(self) -> np.ndarray:
        return np.array([-math.sin(self.normal_rad), math.cos(self.normal_rad)])

    @cached_property
    def _friction(self) -> dict:
        given = (("mu_static", self.mu_static), ("mu_kinetic", self.mu_kinetic),
                 ("slip_rebound", self.slip_rebound))
        return {name: value for name, value in given if value is not None}


@dataclass(frozen=True)
class ShapeFixture:
    """A contour-scene shape (``Circle`` or ``Polygon`` from twin.scenes) given around the
    end effector's point, carried rigidly by the stage."""

    shape: object

    def touches(self, points_mm: np.ndarray, tool_mm: np.ndarray) -> bool:
        """True when the shape reaches any of the points (mm)."""
        shape = self.obstacle(tool_mm, 1)
        if hasattr(shape, "radius_mm"):
            return bool(np.min(np.hypot(*(points_mm - shape.center_mm).T)) <= shape.radius_mm)
        return bool(np.max(shape.depth_mm(points_mm)) >= 0)

    def obstacle(self, tool_mm: np.ndarray, motion_sign: int, side: int = 1):
        """The shape moved to the tool's position."""
        from dataclasses import replace

        from whiskercal.twin.physics.obstacles import Circle

        if isinstance(self.shape, Circle):
            return replace(self.shape, center_mm=self.shape.center_mm + tool_mm)
        return replace(self.shape, vertices_mm=self.shape.vertices_mm + tool_mm)


@dataclass(frozen=True)
class NoFixture:
    """Nothing on the stage: the whisker stays free."""

    def touches(self, points_mm: np.ndarray, tool_mm: np.ndarray) -> bool:
        """Nothing touches."""
        return False

    def obstacle(self, tool_mm: np.ndarray, motion_sign: int, side: int = 1):
        """No obstacle."""
        return None


class Physics(Protocol):
    """What the world needs from the sensor's physics (injectable for tests)."""

    def free(self):
        """The undeflected whisker's equilibrium."""

    def solve(self, obstacle, previous):
        """The equilibrium against ``obstacle``, warm-started from ``previous``."""

    def field_uT(self, equilibrium) -> np.ndarray:
        """Field at the magnetometer for an equilibrium, sensor axes, µT (3,)."""


class TwinPhysics:
    """The twin's physics for one sensor: whisker mechanics and the magnet's field."""

    def __init__(self, sensor) -> None:
        from whiskercal.twin.physics import mechanics

        self.sensor = sensor
        self._mechanics = mechanics

    def free(self):
        """The undeflected whisker."""
        return self._mechanics.free(self.sensor.whisker)

    def solve(self, obstacle, previous):
        """Equilibrium against ``obstacle`` (None: free), warm-started from ``previous``."""
        m = self._mechanics
        if obstacle is None:
            return m.free(self.sensor.whisker)
        if isinstance(obstacle, m.Plane):
            return m.solve_plane(self.sensor.whisker, obstacle, previous)
        return m.solve_shape(self.sensor.whisker, obstacle, previous)

    def field_uT(self, equilibrium) -> np.ndarray:
        """Field of the magnet at the suspension's pose, sensor axes, µT (3,)."""
        from whiskercal.twin.physics.magnet import field_uT

        return np.asarray(field_uT(self.sensor.magnet, equilibrium.root_rotation_rad,
                                   equilibrium.root_shift_mm), dtype=float)


class TruthRecord:
    """Ground truth of every converted sample, stored in growing numpy blocks.

    Columns: ``t_s``; ``stage_mm`` (2, true carriage position, machine coordinates);
    ``tool_mm`` (2, the end effector in the whisker frame); ``contact_mm`` (2, NaN when free);
    ``tip_mm`` (2); ``root_rotation_rad``; ``z_true_uT`` (noise-free Y minus static Y);
    ``field_true_uT`` (3, noise-free field in sensor axes); ``kind`` (``free``, ``shaft``,
    ``tip``, ``tangential``, or ``failed`` where the solver gave up and the previous
    equilibrium was kept); ``slips`` (stick-slip events of the plane's tip since the previous
    sample).
    """

    _COLUMNS = {"t_s": 1, "stage_mm": 2, "tool_mm": 2, "contact_mm": 2, "tip_mm": 2,
                "root_rotation_rad": 1, "z_true_uT": 1, "field_true_uT": 3, "slips": 1}
    _WIDTH = sum(_COLUMNS.values())

    def __init__(self, block_rows: int = 65536) -> None:
        self._block_rows = block_rows
        self._blocks: list[np.ndarray] = []
        self._kinds: list[np.ndarray] = []
        self._rows_in_last = block_rows

    def __len__(self) -> int:
        return max(len(self._blocks) - 1, 0) * self._block_rows + (self._rows_in_last if self._blocks else 0)

    @classmethod
    def width(cls) -> int:
        """Floats in one row."""
        return cls._WIDTH

    def extend(self, rows: np.ndarray, kinds: list[str]) -> None:
        """Rows of ``width()`` floats in column order, and their equilibrium kinds."""
        codes = np.array([_KINDS.index(k) if k in _KINDS else len(_KINDS) - 1 for k in kinds], dtype=np.int8)
        done = 0
        while done < len(rows):
            if self._rows_in_last == self._block_rows:
                self._blocks.append(np.empty((self._block_rows, self._WIDTH)))
                self._kinds.append(np.empty(self._block_rows, dtype=np.int8))
                self._rows_in_last = 0
            take = min(len(rows) - done, self._block_rows - self._rows_in_last)
            self._blocks[-1][self._rows_in_last:self._rows_in_last + take] = rows[done:done + take]
            self._kinds[-1][self._rows_in_last:self._rows_in_last + take] = codes[done:done + take]
            self._rows_in_last += take
            done += take

    def arrays(self) -> dict[str, np.ndarray]:
        """All records as named arrays (a copy)."""
        if not self._blocks:
            table, kinds = np.empty((0, self._WIDTH)), np.empty(0, dtype=np.int8)
        else:
            table = np.concatenate(self._blocks[:-1] + [self._blocks[-1][:self._rows_in_last]])
            kinds = np.concatenate(self._kinds[:-1] + [self._kinds[-1][:self._rows_in_last]])
        out, column = {}, 0
        for name, width in self._COLUMNS.items():
            values = table[:, column:column + width]
            out[name] = values[:, 0] if width == 1 else values
            column += width
        out["kind"] = np.array(_KINDS)[kinds] if len(kinds) else np.empty(0, dtype="<U10")
        return out

    def __getattr__(self, name: str) -> np.ndarray:
        if name in self._COLUMNS or name == "kind":
            return self.arrays()[name]
        raise AttributeError(name)


@dataclass
class WorldConfig:
    """Everything that makes a world (see :func:`create_world`).

    Positions and lengths in mm (``stage_start_mm``: the carriage's physical position at
    power-up); ``speed`` is simulated seconds per real second (0: as fast as the CPU allows);
    ``max_step_mm`` the longest move of the end effector between two warm-started solves;
    ``clock_drift_ppm`` the sensor board's clock error; ``stock`` a plain grbl stage.
    """

    sensor: object = None
    fixture: object = field(default_factory=RodFixture)
    geometry: RigGeometry = field(default_factory=RigGeometry)
    stage_start_mm: tuple[float, float] = (20.0, 180.0)
    backlash_mm: float = 0.02
    stage_faults: StageFaults = field(default_factory=StageFaults)
    sensor_faults: SensorFaults = field(default_factory=SensorFaults)
    stock: bool = False
    seed: int = 0
    speed: float = 0.0
    max_step_mm: float = 0.05
    clock_drift_ppm: float = 0.0


class World:
    """A simulated rig (see the module docstring). Thread-safe through ``lock``."""

    def __init__(self, name: str, config: WorldConfig | None = None, physics: Physics | None = None) -> None:
        self.name = name
        self.config = config or WorldConfig()
        if self.config.sensor is None:
            from whiskercal.twin.params import DEFAULT_SENSOR

            self.config.sensor = DEFAULT_SENSOR
        self.sensor = self.config.sensor
        self.physics = physics or TwinPhysics(self.sensor)
        self.lock = threading.RLock()
        self.clock = SimClock(speed=self.config.speed)
        seeds = np.random.SeedSequence(self.config.seed).spawn(2)
        self.rng = np.random.default_rng(seeds[0])  # magnetometer noise
        self.stage = StageMechanics(self.config.stage_start_mm, self.config.backlash_mm,
                                    faults=self.config.stage_faults)
        self.stage_board = VirtualStage(self.stage, stock=self.config.stock)
        self.sensor_board = VirtualSensor(self.reading, self.config.sensor_faults,
                                          np.random.default_rng(seeds[1]), self.config.clock_drift_ppm)
        self.truth = TruthRecord()
        self.url_options: dict | None = None  # set when a sim:// URL made the world
        self._receivers: dict[int, object] = {}
        self._equilibrium = self.physics.free()
        self._free_shape_mm = self._free_shape(self._equilibrium)
        self._static_uT = self.physics.field_uT(self._equilibrium)
        self._field_of = (self._equilibrium, self._static_uT)
        self._eq_time_s = 0.0
        self._eq_tool_mm = self.tool_mm(0.0)
        self._motion_sign = 1
        self._side = 1
        self._failed = False
        self._slips_since_sample = 0
        self._magnetometers: dict[SensorConfig, object] = {}
        self.solver_failures = 0

    @staticmethod
    def _free_shape(equilibrium) -> np.ndarray:
        """Points along the free whisker, densely enough for clearance tests (mm)."""
        shape = np.asarray(equilibrium.shape_mm(400), float)
        return np.vstack([np.linspace([0.0, 0.0], shape[1], 20), shape[1:]])

    @property
    def now_s(self) -> float:
        """Simulated time, s."""
        return self.clock.now_s

    def advance_to(self, t: float) -> None:
        """Run both boards and the physics up to simulated time ``t`` (s)."""
        with self.lock:
            if t <= self.clock.now_s:
                return
            self.stage_board.advance_to(t)
            self.sensor_board.advance_to(t)
            self.clock.advance_to(t)
            self._hand_over_bytes()

    def attach(self, board, receiver) -> None:
        """Let ``receiver()`` take what ``board`` sends (an open port; one per board)."""
        with self.lock:
            self._receivers[id(board)] = receiver

    def detach(self, board) -> None:
        """The board's port was closed: what it sends from now on goes nowhere."""
        with self.lock:
            self._receivers.pop(id(board), None)

    def _hand_over_bytes(self) -> None:
        # bytes reach the host's receive buffer as they arrive (where a full buffer drops
        # them), so a host that does not read cannot pile up memory here
        for board in (self.stage_board, self.sensor_board):
            receiver = self._receivers.get(id(board))
            if receiver is not None:
                receiver()
            else:
                board.line.receive(self.clock.now_s)

    # -- geometry ---------------------------------------------------------------------------
    def stage_true_mm(self, t: float) -> np.ndarray:
        """Where the carriage really is at time ``t``, in (homed) machine coordinates, mm."""
        return self.stage.carriage_mm(t)

    def tool_mm(self, t: float) -> np.ndarray:
        """The end effector's point in the whisker frame at time ``t``, mm."""
        return self.config.geometry.to_whisker(self.stage_true_mm(t))

    def stage_target_for(self, whisker_mm) -> np.ndarray:
        """Machine coordinates that put the end effector at a whisker-frame point, mm."""
        return self.config.geometry.to_stage(whisker_mm)

    # -- physics ----------------------------------------------------------------------------
    def equilibrium_at(self, t: float, tool_mm: np.ndarray | None = None):
        """The whisker's equilibrium at time ``t`` (call with non-decreasing times).

        The tool's path since the last call is followed in steps of at most ``max_step_mm``,
        each solve warm-started from the previous one, so friction sees the path. ``tool_mm``
        is the end effector at ``t`` (whisker frame, mm) when the caller already has it.
        """
        tool = self.tool_mm(t) if tool_mm is None else tool_mm
        # the stage may have gone somewhere and back since the last call: step along its path
        travel = max(float(np.hypot(*(tool - self._eq_tool_mm))),
                     self.stage.path_length_mm(self._eq_time_s, t))
        if travel < 1e-9 and t >= self._eq_time_s:
            self._eq_time_s = t
            return self._equilibrium
        steps = max(1, math.ceil(travel / self.config.max_step_mm))
        start_s, previous_tool = self._eq_time_s, self._eq_tool_mm
        for k in range(1, steps + 1):
            step_tool = tool if k == steps else self.tool_mm(start_s + (t - start_s) * k / steps)
            self._solve_step(step_tool, previous_tool)
            previous_tool = step_tool
        self._eq_time_s, self._eq_tool_mm = t, tool
        return self._equilibrium

    def _solve_step(self, tool: np.ndarray, previous_tool: np.ndarray) -> None:
        fixture = self.config.fixture
        if isinstance(fixture, PlaneFixture):
            along = float(fixture._tangent @ (tool - previous_tool))
            if abs(along) > 1e-12:
                self._motion_sign = 1 if along > 0 else -1
        if not self._equilibrium.in_contact:
            if not fixture.touches(self._free_shape_mm, tool):
                if getattr(self._equilibrium, "slipped_past", False):
                    self._equilibrium = self.physics.free()  # the obstacle has cleared the wire
                return  # nothing touches: no solve (the solver refuses far-off poses)
            # a rod pushes the whisker away from the side it arrives from
            self._side = 1 if tool[1] >= 0 else -1
        obstacle = fixture.obstacle(tool, self._motion_sign, self._side)
        try:
            self._equilibrium = self.physics.solve(obstacle, self._equilibrium)
            self._slips_since_sample += getattr(self._equilibrium, "slips", 0)
            self._failed = False
        except Exception:  # noqa: BLE001  (a solver failure must not take the rig down)
            # keep the last equilibrium; the truth record marks these samples "failed"
            self.solver_failures += 1
            self._failed = True

    def _magnetometer(self, config: SensorConfig):
        params = self._magnetometers.get(config)
        if params is None:
            params = self.sensor.magnetometer.with_settings(
                gain=config.gain, res=config.res, osr=config.osr, filt=config.filt,
                rate_hz=float(config.rate_hz))
            self._magnetometers[config] = params
        return params

    def reading(self, times_s: np.ndarray, config: SensorConfig) -> tuple[np.ndarray, np.ndarray]:
        """Raw counts (n, 3) and saturation flags (n,) the sensor converts at ``times_s``
        (in order) with the board's settings; records the ground truth of each."""
        from whiskercal.twin.physics.magnetometer import is_saturated, to_counts

        fields = np.empty((len(times_s), 3))
        rows = np.empty((len(times_s), TruthRecord.width()))
        kinds = []
        for index, t in enumerate(times_s):
            self._failed = False
            stage_mm = self.stage_true_mm(t)
            tool_mm = self.config.geometry.to_whisker(stage_mm)
            equilibrium = self.equilibrium_at(t, tool_mm)
            if self._field_of[0] is not equilibrium:  # standing still: the field is the same
                self._field_of = (equilibrium, self.physics.field_uT(equilibrium))
            fields[index] = self._field_of[1]
            self._truth_row(rows[index], t, stage_mm, tool_mm, equilibrium, fields[index])
            kinds.append("failed" if self._failed else equilibrium.kind)
        self.truth.extend(rows, kinds)
        params = self._magnetometer(config)
        counts = to_counts(fields, params, self.rng)
        return counts, is_saturated(counts, params)

    def _truth_row(self, row: np.ndarray, t: float, stage_mm: np.ndarray, tool_mm: np.ndarray,
                   equilibrium, field_uT: np.ndarray) -> None:
        """Fill one truth row in place (column order of ``TruthRecord``)."""
        row[0] = t
        row[1:3] = stage_mm
        row[3:5] = tool_mm
        row[5:7] = equilibrium.contact_mm
        row[7:9] = equilibrium.tip_mm
        row[9] = equilibrium.root_rotation_rad
        row[10] = field_uT[1] - self._static_uT[1]
        row[11:14] = field_uT
        row[14] = self._slips_since_sample
        self._slips_since_sample = 0

    @property
    def static_field_uT(self) -> np.ndarray:
        """Noise-free field with the whisker free, sensor axes, µT (3,)."""
        return self._static_uT.copy()


# -- the registry of named worlds --------------------------------------------------------------
_WORLDS: dict[str, World] = {}
_REGISTRY_LOCK = threading.Lock()


def create_world(name: str, scene: str = "rod", sensor=None, seed: int = 0, physics: Physics | None = None,
                 **options) -> World:
    """Make (or replace) the world ``name`` before its ``sim://`` ports are opened.

    Parameters
    ----------
    name
        The NAME in ``sim://NAME/stage`` and ``sim://NAME/sensor``.
    scene
        What rides on the stage: ``"rod"``, ``"plane"``, ``"none"``; or pass ``fixture=``.
    sensor
        A ``SensorParams`` (default: ``twin.params.DEFAULT_SENSOR``).
    seed
        Seeds the magnetometer noise and the link faults.
    physics
        Replace the twin's physics (tests).
    **options
        Any other :class:`WorldConfig` field (``rod_radius_mm=`` sets the rod's radius).
    """
    rod_radius = options.pop("rod_radius_mm", DEFAULT_ROD_RADIUS_MM)
    if "fixture" not in options:
        options["fixture"] = fixture_for_scene(scene, rod_radius)
    world = World(name, WorldConfig(sensor=sensor, seed=seed, **options), physics)
    with _REGISTRY_LOCK:
        _WORLDS[name] = world
    return world


def fixture_for_scene(scene: str, rod_radius_mm: float = DEFAULT_ROD_RADIUS_MM):
    """The fixture for a scene name: ``rod``, ``plane`` or ``none``."""
    fixtures = {"rod": RodFixture(rod_radius_mm), "plane": PlaneFixture(), "none": NoFixture()}
    if scene not in fixtures:
        raise UsageError(f"unknown scene {scene!r}; use one of {', '.join(fixtures)}.")
    return fixtures[scene]


def get_world(name: str) -> World | None:
    """The world called ``name``, if one exists."""
    with _REGISTRY_LOCK:
        return _WORLDS.get(name)


def drop_world(name: str) -> None:
    """Forget the world ``name`` (its open ports keep working on their own copy)."""
    with _REGISTRY_LOCK:
        _WORLDS.pop(name, None)
