"""One simulated rig, wired: a stage, what rides on it, a whisker sensor, a clock, faults and
the ground truth.

A `World` puts together the parts that each live in their own module: the rig geometry
(``geometry``), the scene on the end effector (``scenes``), the sensor's physics
(``physics.sensor``), the equilibrium along the stage's path (``contact_path``), the emulated
boards on one simulated clock with their faults (``devices``), and the ground-truth record
(``truth_record``) of every sample the sensor board converts, which in-process users read as
``port.world.truth``.

Worlds are named: ``sim://NAME/stage`` and ``sim://NAME/sensor`` open the two boards of the
world NAME. :func:`create_world` configures one in code before its ports are opened.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field, replace

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.protocol.sensor_config import SensorConfig
from whiskercal.twin.contact_path import ContactPath
from whiskercal.twin.devices.boards import Boards
from whiskercal.twin.devices.clock import SimClock
from whiskercal.twin.devices.stage import StageFaults, StageMechanics
from whiskercal.twin.devices.virtual_sensor import SensorFaults, VirtualSensor
from whiskercal.twin.devices.virtual_stage import VirtualStage
from whiskercal.twin.geometry import RigGeometry
from whiskercal.twin.physics.sensor import SensorPhysics, TwinPhysics
from whiskercal.twin.scenes import DEFAULT_ROD_RADIUS_MM, RodFixture, Scene, fixture_for_scene
from whiskercal.twin.truth_record import TruthRecord


@dataclass
class WorldConfig:
    """Everything that makes a world (see :func:`create_world`).

    Positions and lengths in mm (``stage_start_mm``: the carriage's physical position at
    power-up); ``fixture`` the scene on the end effector (the world works on its own
    ``fresh()`` copy); ``speed`` is simulated seconds per real second (0: as fast as the CPU
    allows); ``max_step_mm`` the longest move of the end effector between two warm-started
    solves; ``clock_drift_ppm`` the sensor board's clock error; ``stock`` a plain grbl stage;
    ``dynamics`` a ``twin.nuisances.DynamicsTable`` (None or no modes: the quasi-static
    whisker; with modes the field follows the suspension's ringing, ``physics.dynamics``);
    ``nuisances`` a ``twin.nuisances.Nuisances`` (None or all off: the ideal rig): the reading's
    drift (its stray field while the stage moves) and the suspension's creep act here; the
    contact's roughness and the robot's nuisances belong to the moving-base twin
    (``twin.mobile``) and are refused;
    ``homing`` its homing cycle: ``"xy"`` (X and Y together, whiskercal's firmware always), or
    ``""`` for the board's default, which on stock grbl 1.1 homes Z first (ALARM:9 on a two-axis
    stage, which has no Z switch); ``origin`` ``"set"`` for a stock build with
    HOMING_FORCE_SET_ORIGIN (machine zero where homing ends, not stock grbl's -$130+$27).
    """

    sensor: object = None
    fixture: Scene = field(default_factory=RodFixture)
    geometry: RigGeometry = field(default_factory=RigGeometry)
    stage_start_mm: tuple[float, float] = (20.0, 180.0)
    backlash_mm: float = 0.02
    stage_faults: StageFaults = field(default_factory=StageFaults)
    sensor_faults: SensorFaults = field(default_factory=SensorFaults)
    stock: bool = False
    homing: str = ""
    origin: str = ""
    seed: int = 0
    speed: float = 0.0
    max_step_mm: float = 0.05
    clock_drift_ppm: float = 0.0
    dynamics: object = None
    nuisances: object = None


class World:
    """A simulated rig (see the module docstring). Thread-safe through ``lock``."""

    def __init__(self, name: str, config: WorldConfig | None = None,
                 physics: SensorPhysics | None = None) -> None:
        self.name = name
        self.config = config or WorldConfig()
        if self.config.sensor is None:
            from whiskercal.twin.params import DEFAULT_SENSOR

            self.config.sensor = DEFAULT_SENSOR
        self.sensor = self.config.sensor
        self.physics = physics or TwinPhysics(self.sensor)
        self.lock = threading.RLock()
        self.url_options: dict | None = None  # set when a sim:// URL made the world
        self.truth = TruthRecord()
        self._wire_devices()
        self.scene = self.config.fixture.fresh()
        self.contact = ContactPath(self.scene, self.physics, self.tool_mm,
                                   self.stage.path_length_mm, self.config.max_step_mm)
        self._static_uT = self.physics.field_uT(self.contact.equilibrium)
        self._field_of = (self.contact.equilibrium, self._static_uT)
        self._magnetometers: dict[SensorConfig, object] = {}
        self._ringing = self._ringing_root()
        self._nuisances = self._rig_nuisances()
        self._last_sample_s = 0.0

    def _ringing_root(self):
        """The suspension's modal response when the config asks for modes, else None."""
        dynamics = self.config.dynamics
        if dynamics is None or dynamics.off:
            return None
        from whiskercal.twin.physics.dynamics import RingingRoot

        rest = self.contact.equilibrium
        return RingingRoot(dynamics.modes_of(self.sensor.whisker), rest.root_rotation_rad,
                           getattr(rest, "root_shift_mm", (0.0, 0.0)))

    def _rig_nuisances(self):
        """The sensor's nuisances of this session (seeded) when the config asks for any, else None."""
        nuisances = self.config.nuisances
        if nuisances is None or nuisances.off:
            return None
        from whiskercal.twin.nuisances import SensorNuisances, stage_rig_refusal

        refusal = stage_rig_refusal(nuisances)
        if refusal:
            raise UsageError(refusal)
        return SensorNuisances(nuisances, self.config.seed)

    def _wire_devices(self) -> None:
        """The stage, both boards and the clock; seeds: magnetometer noise, then link faults."""
        config = self.config
        seeds = np.random.SeedSequence(config.seed).spawn(2)
        self.rng = np.random.default_rng(seeds[0])  # magnetometer noise
        self.clock = SimClock(speed=config.speed)
        self.stage = StageMechanics(config.stage_start_mm, config.backlash_mm, faults=config.stage_faults)
        self.stage_board = VirtualStage(self.stage, stock=config.stock, homing=config.homing,
                                        origin=config.origin)
        self.sensor_board = VirtualSensor(self.reading, config.sensor_faults,
                                          np.random.default_rng(seeds[1]), config.clock_drift_ppm)
        self._boards = Boards(self.clock, self.stage_board, self.sensor_board)

    # -- time and the boards' ports ----------------------------------------------------------
    @property
    def now_s(self) -> float:
        """Simulated time, s."""
        return self.clock.now_s

    def advance_to(self, t: float) -> None:
        """Run both boards and the physics up to simulated time ``t`` (s)."""
        with self.lock:
            self._boards.advance_to(t)

    def attach(self, board, receiver) -> None:
        """Let ``receiver()`` take what ``board`` sends (an open port; one per board)."""
        with self.lock:
            self._boards.attach(board, receiver)

    def detach(self, board) -> None:
        """The board's port was closed: what it sends from now on goes nowhere."""
        with self.lock:
            self._boards.detach(board)

    def use_emulated_sensor_board(self):
        """Put the compiled firmware on simavr in place of the Python sensor board (once);
        the board in use. Raises ``SerialException`` when the emulation is not built."""
        from whiskercal.twin.devices.avr_board import AvrSensorBoard

        with self.lock:
            if not isinstance(self.sensor_board, AvrSensorBoard):
                board = AvrSensorBoard(self.reading, self.now_s, self.config.clock_drift_ppm)
                self._boards.detach(self.sensor_board)
                self.sensor_board = self._boards.sensor = board
            return self.sensor_board

    def use_emulated_stage_board(self, firmware: str = "avr"):
        """Put the compiled stage firmware on simavr in place of the Python stage board (once):
        its step counters move the carriage from now on. ``firmware``: ``avr`` (whiskercal's
        stage_stepper) or ``grbl`` (stock grbl 1.1h, homing as ``config.homing``). The board in use."""
        from whiskercal.twin.devices.avr_stage import AvrStageBoard
        from whiskercal.twin.devices.grbl_stage import GrblStageBoard

        with self.lock:
            if not isinstance(self.stage_board, AvrStageBoard):
                start = (self.stage.carriage_mm(self.now_s), self.now_s, self.config.backlash_mm,
                         self.config.stage_faults)
                board = GrblStageBoard(*start, homing=self.config.homing, origin=self.config.origin) \
                    if firmware == "grbl" \
                    else AvrStageBoard(*start)
                self._boards.detach(self.stage_board)
                self.stage_board = self._boards.stage = board
                self.stage = board.trace
                self.contact.use_path_length(board.trace.path_length_mm)
            return self.stage_board

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

    # -- the sensor's view ------------------------------------------------------------------
    def equilibrium_at(self, t: float, tool_mm: np.ndarray | None = None):
        """The whisker's equilibrium at time ``t`` (call with non-decreasing times), followed
        along the path (``contact_path``); ``tool_mm``: the end effector at ``t`` if known."""
        return self.contact.at(t, tool_mm)

    @property
    def solver_failures(self) -> int:
        """Solves that raised so far (their samples are recorded as ``failed``)."""
        return self.contact.failures

    def reading(self, times_s: np.ndarray, config: SensorConfig) -> tuple[np.ndarray, np.ndarray]:
        """Raw counts (n, 3) and saturation flags (n,) the sensor converts at ``times_s``
        (in order) with the board's settings; records the ground truth of each."""
        from whiskercal.twin.physics.magnetometer import is_saturated, to_counts

        fields = np.empty((len(times_s), 3))
        rows = np.empty((len(times_s), TruthRecord.width()))
        kinds = [self._sample(t, fields[index], rows[index]) for index, t in enumerate(times_s)]
        self.truth.extend(rows, kinds)
        params = self._magnetometer(config)
        counts = to_counts(fields, params, self.rng)
        return counts, is_saturated(counts, params)

    def _sample(self, t: float, field_out: np.ndarray, row_out: np.ndarray) -> str:
        """The noise-free field and the truth row at time ``t``, filled in place; the kind."""
        stage_mm = self.stage_true_mm(t)
        tool_mm = self.config.geometry.to_whisker(stage_mm)
        equilibrium = self.contact.at(t, tool_mm)
        if self._ringing is not None or self._nuisances is not None:
            self._field_of = (None, self._real_field(t, equilibrium))
        elif self._field_of[0] is not equilibrium:  # standing still: the field is the same
            self._field_of = (equilibrium, self.physics.field_uT(equilibrium))
        field_out[:] = self._field_of[1]
        TruthRecord.fill_row(row_out, t, stage_mm, tool_mm, equilibrium, field_out,
                             field_out[1] - self._static_uT[1], self.contact.take_slips())
        return "failed" if self.contact.last_solve_failed else equilibrium.kind

    def _real_field(self, t: float, equilibrium) -> np.ndarray:
        """The field the chip reads at ``t`` as a real rig has it, µT (3,): the magnet's at the
        suspension's pose ringing with the modes (their response to the quasi-static
        ``equilibrium``) and crept, the reading drifting (``twin.nuisances``)."""
        rotation = equilibrium.root_rotation_rad
        shift = getattr(equilibrium, "root_shift_mm", None)
        if self._ringing is not None:
            rotation, moved = self._ringing.at(t, rotation, (0.0, 0.0) if shift is None else shift)
            shift = None if shift is None else moved
        if self._nuisances is not None:
            rotation += self._nuisances.creep(rotation, t - self._last_sample_s)
            self._last_sample_s = t
        pose = {"root_rotation_rad": rotation} if shift is None else \
            {"root_rotation_rad": rotation, "root_shift_mm": shift}
        field = self.physics.field_uT(replace(equilibrium, **pose))
        if self._nuisances is None:
            return field
        return self._nuisances.field_uT(np.asarray(field, float), t, self.stage.busy(t))

    def _magnetometer(self, config: SensorConfig):
        """The sensor's magnetometer with the board's settings (made once per setting)."""
        params = self._magnetometers.get(config)
        if params is None:
            params = self.sensor.magnetometer.with_settings(
                gain=config.gain, res=config.res, osr=config.osr, filt=config.filt,
                rate_hz=float(config.rate_hz))
            self._magnetometers[config] = params
        return params

    @property
    def static_field_uT(self) -> np.ndarray:
        """Noise-free field with the whisker free, sensor axes, µT (3,)."""
        return self._static_uT.copy()


# -- the registry of named worlds --------------------------------------------------------------
_WORLDS: dict[str, World] = {}
_REGISTRY_LOCK = threading.Lock()


def create_world(name: str, scene: str = "rod", sensor=None, seed: int = 0,
                 physics: SensorPhysics | None = None, **options) -> World:
    """Make (or replace) the world ``name`` before its ``sim://`` ports are opened.

    Parameters
    ----------
    name
        The NAME in ``sim://NAME/stage`` and ``sim://NAME/sensor``.
    scene
        What rides on the stage, by name (``twin.scenes.registry``: ``"rod"``, ``"plane"``,
        ``"none"``); or pass a scene as ``fixture=``.
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


def get_world(name: str) -> World | None:
    """The world called ``name``, if one exists."""
    with _REGISTRY_LOCK:
        return _WORLDS.get(name)


def drop_world(name: str) -> None:
    """Forget the world ``name`` (its open ports keep working on their own copy)."""
    with _REGISTRY_LOCK:
        _WORLDS.pop(name, None)
