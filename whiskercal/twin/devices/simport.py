"""pyserial's ``sim://`` handler: the twin's boards as serial ports, in-process.

``serial.serial_for_url("sim://NAME/stage")`` and ``.../sensor`` open the two boards of the
world NAME (made on first use from the URL's options, or beforehand with
``twin.world.create_world``). Reading with a timeout advances the world's simulated clock to
the moment the requested bytes exist, or by the timeout, so code that waits by reading runs
as fast as the CPU allows. Each port exposes ``.world`` (ground truth) and ``now_s()``.

Opening a port resets its board, as opening an Arduino's USB port does (the banner again; the
stage forgets its homing). The host side has a 4 KiB receive buffer: bytes that arrive while it
is full are lost, as with a real OS driver.

URL options are documented in docs/twin.md ("Simulated rig and sim:// URLs").
"""

from __future__ import annotations

import math
import os
import select
import urllib.parse

import serial
from serial.serialutil import PortNotOpenError, SerialBase, SerialException

from whiskercal.checks import number
from whiskercal.checks import seed as seed_value
from whiskercal.errors import UsageError
from whiskercal.twin.world import World, create_world, get_world

RECEIVE_BUFFER_BYTES = 4096
_MIN_STEP_S = 1e-7
# The longest span (in wall seconds at the bridge's speed) one pump of a paced bridge simulates:
# host bytes wait at most this long for the boards, however slow the simulation runs.
PACED_STEP_WALL_S = 0.02
_WORLD_OPTIONS = ("scene", "rod_radius", "seed", "stock", "homing", "origin", "corrupt", "drop", "speed", "sensor",
                  "backlash", "drift_ppm", "fault", "firmware", "nuisances")
_STAGE_FAULTS = {"missed_steps": "missed_steps_at_s", "stall": "stall_at_s",
                 "encoder_magnet": "encoder_magnet_at_s", "encoder_bus": "encoder_bus_at_s"}


def parse_sim_url(url: str) -> tuple[str, str, dict[str, list[str]]]:
    """``sim://NAME/BOARD?options`` -> (NAME, BOARD, options); raises ``SerialException``."""
    parts = urllib.parse.urlsplit(url)
    board = parts.path.strip("/")
    if parts.scheme != "sim" or not parts.netloc or board not in ("stage", "sensor"):
        raise SerialException(f"expected sim://NAME/stage or sim://NAME/sensor, got {url!r}")
    options = urllib.parse.parse_qs(parts.query, keep_blank_values=True)
    unknown = set(options) - set(_WORLD_OPTIONS)
    if unknown:
        raise SerialException(f"unknown sim:// option(s) {', '.join(sorted(unknown))}; "
                              f"known: {', '.join(_WORLD_OPTIONS)}")
    return parts.netloc, board, options


def _faults(options: dict[str, list[str]]) -> list[tuple[str, float, str]]:
    """``fault=name@time[:argument]`` entries (comma-separated or repeated)."""
    faults = []
    for entry in ",".join(options.get("fault", [])).split(","):
        if not entry:
            continue
        name, _, rest = entry.partition("@")
        when, _, argument = rest.partition(":")
        if name not in (*_STAGE_FAULTS, "disconnect") or not when:
            raise UsageError(f"bad fault {entry!r}; use NAME@SECONDS with NAME one of "
                             f"{', '.join((*_STAGE_FAULTS, 'disconnect'))}")
        faults.append((name, number(when, f"the time of fault {entry!r}", low=0, unit="s"), argument))
    return faults


def world_from_options(name: str, options: dict[str, list[str]]) -> World:
    """Create the world ``name`` from URL options (see docs/twin.md)."""
    from whiskercal.twin.devices.stage import StageFaults
    from whiskercal.twin.devices.virtual_sensor import SensorFaults

    def value(key, default):
        """The last value given for ``key``."""
        return options.get(key, [default])[-1]

    def fraction(key):
        return number(value(key, 0), f"sim:// option {key} (a fraction of frames)", low=0, high=1)

    stage_faults, sensor_faults = StageFaults(), SensorFaults(fraction("corrupt"), fraction("drop"))
    for fault, when, argument in _faults(options):
        if fault == "disconnect":
            continue  # a property of the port that names it, see Serial.open
        setattr(stage_faults, _STAGE_FAULTS[fault], when)
        if fault == "missed_steps" and argument:
            stage_faults.missed_steps_mm = number(argument, "the missed_steps fault's size", unit="mm")
    sensor, dynamics, nuisances = None, None, None
    if "sensor" in options:  # a shipped id or the path of a .toml sensor file (percent-decoded)
        from whiskercal.twin.nuisances import load_dynamics, load_nuisances, stage_rig_part
        from whiskercal.twin.params import SENSORS
        from whiskercal.twin.sensor_file import resolve_sensor

        path = value("sensor", "")
        sensor = resolve_sensor(path)
        if path not in SENSORS:
            # a file's [dynamics] (the wire's bending modes) and the drift and creep of its
            # [nuisances]; its contact and robot tables are contour run's
            dynamics, nuisances = load_dynamics(path), stage_rig_part(load_nuisances(path))
    if "nuisances" in options:
        nuisances = _nuisances(value("nuisances", ""))
    world = create_world(
        name, scene=value("scene", "rod"), sensor=sensor,
        seed=seed_value(value("seed", 0), "sim:// option seed"),
        rod_radius_mm=number(value("rod_radius", 1.5), "sim:// option rod_radius", low=0, unit="mm"),
        stock=_flag(value("stock", "0"), "stock"), homing=_homing(value("homing", "")),
        origin=_origin(value("origin", "")),
        speed=number(value("speed", 0), "sim:// option speed (0: as fast as the host allows)", low=0),
        backlash_mm=number(value("backlash", 0.02), "sim:// option backlash", low=0, unit="mm"),
        clock_drift_ppm=number(value("drift_ppm", 0), "sim:// option drift_ppm", low=-1e4, high=1e4),
        stage_faults=stage_faults, sensor_faults=sensor_faults, dynamics=dynamics,
        nuisances=nuisances)
    world.url_options = _world_level(options)
    return world


def _nuisances(text: str):
    """The ``nuisances=`` option: off, realistic (the drift and creep at their realistic
    levels), realistic:drift, realistic:viscoelastic, or a .toml file's [nuisances] table."""
    from whiskercal.twin.nuisances import nuisances_named, stage_rig_part, stage_rig_refusal

    nuisances = nuisances_named(text)
    if text == "realistic":
        return stage_rig_part(nuisances)
    refusal = stage_rig_refusal(nuisances)
    if refusal:
        raise UsageError(f"sim:// option nuisances={text}: {refusal}")
    return nuisances


def _firmware(options: dict[str, list[str]], board: str) -> str:
    """The port's ``firmware=`` option: ``""`` (the Python board), ``avr`` (whiskercal's .hex on
    simavr) or, for the stage, ``grbl`` (stock grbl 1.1h on simavr, built by ``make grbl-sim``)."""
    firmware = options.get("firmware", [""])[-1]
    if firmware not in ("", "avr", "grbl"):
        raise UsageError(f"sim:// option firmware must be avr (the compiled image on simavr) or, for the "
                         f"stage, grbl (stock grbl 1.1h on simavr), not {firmware!r}")
    if firmware == "grbl" and board != "stage":
        raise UsageError("sim:// option firmware=grbl is for the stage port (grbl is a stage firmware)")
    return firmware


def _homing(text: str) -> str:
    if text not in ("", "xy"):
        raise UsageError(f"sim:// option homing must be xy (the board homes X and Y), not {text!r}")
    return text


def _origin(text: str) -> str:
    if text not in ("", "set"):
        raise UsageError(f"sim:// option origin must be set (a HOMING_FORCE_SET_ORIGIN build), "
                         f"not {text!r}")
    return text


def _flag(text: str, key: str) -> bool:
    if text not in ("0", "1"):
        raise UsageError(f"sim:// option {key} must be 0 or 1, not {text!r}")
    return text == "1"


def _world_level(options: dict[str, list[str]]) -> dict[str, list[str]]:
    kept = {k: v for k, v in options.items() if k not in ("fault", "firmware")}
    world_faults = [f"{n}@{w}:{a}" for n, w, a in _faults(options) if n != "disconnect"]
    if world_faults:
        kept["fault"] = world_faults
    return kept


class Serial(SerialBase):
    """A serial port onto one board of a simulated world."""

    def open(self) -> None:
        """Join (or create) the URL's world and reset the board, as opening a USB port does."""
        if self._port is None:
            raise SerialException("port must be configured before it can be used")
        if self.is_open:
            raise SerialException("port is already open")
        name, board, options = parse_sim_url(self.portstr)
        world = get_world(name)
        if world is None:
            world = world_from_options(name, options)
        elif _world_level(options) and _world_level(options) != world.url_options:
            raise SerialException(f"sim world {name!r} already exists with other options; "
                                  "give the options on the first port only")
        self.world = world
        self.board_kind = board
        firmware = _firmware(options, board)
        if firmware and board == "stage":
            world.use_emulated_stage_board(firmware)
        elif firmware:
            world.use_emulated_sensor_board()
        self.board = world.stage_board if board == "stage" else world.sensor_board
        self.disconnect_at_s = next((w for n, w, _ in _faults(options) if n == "disconnect"), math.inf)
        if board == "sensor" and self.disconnect_at_s < math.inf:
            world.sensor_board.faults.disconnect_at_s = self.disconnect_at_s
        self._rx = bytearray()
        self.overrun_bytes = 0
        with world.lock:
            if getattr(self.board, "opened_before", False):
                self.board.power_up(world.now_s)  # opening the USB port resets an Arduino
            self.board.opened_before = True
            world.attach(self.board, self._deliver)
        self.is_open = True

    def from_url(self, url: str) -> str:
        """Check the URL (pyserial's hook)."""
        parse_sim_url(url)
        return url

    def close(self) -> None:
        """Close the port; the world and its board keep running."""
        if self.is_open:
            self.world.detach(self.board)
        self.is_open = False

    def _reconfigure_port(self) -> None:
        """Baud rate and framing do not matter to a simulated line."""

    # -- time and bytes ---------------------------------------------------------------------
    def now_s(self) -> float:
        """The world's simulated time, s (clients measure their timeouts on it)."""
        return self.world.now_s

    def _check(self) -> None:
        if not self.is_open:
            raise PortNotOpenError()
        if self.world.now_s >= self.disconnect_at_s:
            raise SerialException(f"device reports readiness to read but returned no data "
                                  f"(device disconnected or multiple access on port?) "
                                  f"[sim: {self.board_kind} unplugged at t={self.disconnect_at_s:g} s]")

    def _deliver(self) -> None:
        arrived = self.board.line.receive(self.world.now_s)
        room = RECEIVE_BUFFER_BYTES - len(self._rx)
        self._rx += arrived[:room]
        self.overrun_bytes += max(len(arrived) - room, 0)

    def _next_arrival_s(self) -> float | None:
        times = [x for x in (self.board.line.next_arrival_s(), self.board.next_event_s()) if x is not None]
        return min(times) if times else None

    @property
    def in_waiting(self) -> int:
        """Bytes that have arrived by now and wait to be read."""
        with self.world.lock:
            self._check()
            self._deliver()
            return len(self._rx)

    def read(self, size: int = 1) -> bytes:
        """Up to ``size`` bytes; waits (in simulated time) up to ``timeout`` s for all of them.

        With ``timeout=None`` a read that nothing could ever satisfy returns what there is
        rather than hang.
        """
        with self.world.lock:
            self._check()
            deadline = math.inf if self.timeout is None else self.world.now_s + self.timeout
            data = bytearray()
            while True:
                # a blocked read takes bytes as they come, so only an idle host overruns
                self._deliver()
                chunk = self._rx[:size - len(data)]
                data += chunk
                del self._rx[:len(chunk)]
                if len(data) >= size:
                    break
                target = min(self._next_arrival_s() or math.inf, deadline, self.disconnect_at_s)
                if target == math.inf:
                    break  # nothing will ever arrive: do not hang a blocking read
                if target <= self.world.now_s and target == deadline:
                    break
                self.world.advance_to(max(target, self.world.now_s + _MIN_STEP_S))
                self._check()
            return bytes(data)

    def write(self, data: bytes) -> int:
        """Hand bytes to the board at the current simulated time."""
        with self.world.lock:
            self._check()
            self.board.receive(bytes(data), self.world.now_s)
            return len(data)

    def reset_input_buffer(self) -> None:
        """Discard what has arrived."""
        with self.world.lock:
            self._check()
            self._deliver()
            self._rx.clear()

    def reset_output_buffer(self) -> None:
        """Writes reach the board at once: nothing to flush."""

    def flush(self) -> None:
        """Writes reach the board at once: nothing to wait for."""


class PtyBridge:
    """A world's two boards on pseudo-terminals, paced against real time (``sim serve``).

    Any serial tool can open :attr:`paths` (``stage``, ``sensor``). The slave ends stay open
    here so that the terminals survive clients coming and going; they are in raw mode so that
    no byte is echoed or translated.
    """

    def __init__(self, world: World, speed: float = 1.0) -> None:
        import tty  # POSIX only, like the terminals themselves

        if speed <= 0:
            raise ValueError("a pty bridge runs against real time: speed must be > 0")
        self.world = world
        world.clock.speed = speed
        self._ends: dict[str, tuple[int, int]] = {}
        self.paths: dict[str, str] = {}
        for kind in ("stage", "sensor"):
            master, slave = os.openpty()
            tty.setraw(slave)
            os.set_blocking(master, False)
            self._ends[kind] = (master, slave)
            self.paths[kind] = os.ttyname(slave)
        self.dropped_bytes = 0
        for kind, board in self._boards():
            world.attach(board, lambda kind=kind, board=board: self._forward(kind, board))

    def _boards(self):
        return (("stage", self.world.stage_board), ("sensor", self.world.sensor_board))

    def pump_once(self, wait_s: float = 0.001) -> None:
        """Move simulated time to the wall clock's and carry bytes both ways."""
        masters = [self._ends[kind][0] for kind, _ in self._boards()]
        readable, _, _ = select.select(masters, [], [], wait_s)
        with self.world.lock:
            self.world.advance_to(self.world.clock.paced_now_s(max_step_s=PACED_STEP_WALL_S * self.world.clock.speed))
            now = self.world.now_s
            for kind, board in self._boards():
                master = self._ends[kind][0]
                if master in readable:
                    try:
                        board.receive(os.read(master, 4096), now)
                    except OSError:
                        pass  # no client on the other end right now
                self._forward(kind, board)

    def _forward(self, kind: str, board) -> None:
        """Write what the board has sent by now to its terminal."""
        data = board.line.receive(self.world.now_s)
        if not data or kind not in self._ends:
            return
        try:
            written = os.write(self._ends[kind][0], data)
        except OSError:
            written = 0
        self.dropped_bytes += len(data) - written  # a full pty buffer loses bytes, as a UART would

    def serve(self, stop) -> None:
        """Pump until ``stop()`` returns True."""
        while not stop():
            self.pump_once()

    def close(self) -> None:
        """Close both terminals."""
        for _, board in self._boards():
            self.world.detach(board)
        for master, slave in self._ends.values():
            for fd in (master, slave):
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._ends.clear()
