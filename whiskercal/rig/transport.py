"""What both clients share: opening a port, waiting by reading, turning serial failures into
``DeviceError``.

A port is a URL or device name (``/dev/ttyUSB0``, ``sim://lab/stage``) or an already open
pyserial object (a byte-pair test transport, a ``loop://``). Nothing here sleeps: waiting is
reading with a timeout, measured on the port's own clock when it has one (a simulated port's
``now_s``), so a simulated rig can run faster than real time.
"""

from __future__ import annotations

import time
from typing import Callable

import serial

from whiskercal.errors import DeviceError

BAUD = 115200


class DeviceTimeout(DeviceError):
    """A device did not answer in time (it may still be booting)."""


def open_port(port, baud: int = BAUD) -> serial.SerialBase:
    """Return an open pyserial object for a name/URL, or the object itself when already open."""
    if not isinstance(port, (str, bytes)):
        return port
    try:
        return serial.serial_for_url(port, baudrate=baud, timeout=1.0)
    except (serial.SerialException, OSError, ValueError) as error:
        raise DeviceError(f"cannot open serial port {port}: {error}") from error


def port_name(port) -> str:
    """A readable name for messages."""
    return str(getattr(port, "portstr", None) or getattr(port, "port", None) or port)


def port_clock(port) -> Callable[[], float]:
    """The clock that timeouts on this port run on, in s: simulated time for a sim port."""
    return getattr(port, "now_s", time.monotonic)


class Transport:
    """Reads and writes on one port with deadlines and clear errors.

    Parameters
    ----------
    port
        An open pyserial object.
    device
        What is on the port, for messages ("stage", "sensor").
    """

    def __init__(self, port, device: str) -> None:
        self.port = port
        self.device = device
        self.name = port_name(port)
        self.now_s = port_clock(port)

    def write(self, data: bytes) -> None:
        """Send bytes; an unplugged port raises ``DeviceError``."""
        try:
            self.port.write(data)
        except (serial.SerialException, OSError) as error:
            raise self.lost(error) from error

    def read_some(self, max_bytes: int, timeout_s: float) -> bytes:
        """Up to ``max_bytes`` bytes, waiting at most ``timeout_s`` for the first of them."""
        try:
            self.port.timeout = max(timeout_s, 0.0)
            data = self.port.read(1)
            if data:
                waiting = min(self.port.in_waiting, max_bytes - 1)
                if waiting > 0:
                    data += self.port.read(waiting)
            return data
        except (serial.SerialException, OSError) as error:
            raise self.lost(error) from error

    def read_exactly(self, count: int, timeout_s: float) -> bytes:
        """Exactly ``count`` bytes or fewer if ``timeout_s`` passed first."""
        try:
            self.port.timeout = max(timeout_s, 0.0)
            return self.port.read(count)
        except (serial.SerialException, OSError) as error:
            raise self.lost(error) from error

    def close(self) -> None:
        """Close the port (a port that is already closed or cannot be closed is left alone)."""
        close = getattr(self.port, "close", None)
        if close is not None:
            try:
                close()
            except (serial.SerialException, OSError):
                pass  # an unplugged device: nothing left to release

    def lost(self, error: Exception) -> DeviceError:
        """The error for a port that stopped working (unplugged cable, closed pty)."""
        return DeviceError(f"{self.device} on {self.name} is disconnected or not responding "
                           f"({error}); check the USB cable and power")

    def timed_out(self, what: str, timeout_s: float) -> DeviceTimeout:
        """The error for a device that did not answer in time."""
        return DeviceTimeout(f"{self.device} on {self.name} did not answer {what} within "
                           f"{timeout_s:g} s; is it the right port and powered?")
