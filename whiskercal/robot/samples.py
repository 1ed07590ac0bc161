"""The sensor's stream on a robot run: a sensor_msgs/MagneticField topic over the rosbridge link
(:class:`FieldTopic`), or whiskercal's sensor board on a serial port (:class:`SerialSamples`).
Either hands the run one :class:`FieldSample` at a time, or None when none came within the wait
(the watchdog's business)."""

from __future__ import annotations

import queue
import time
from collections import deque
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FieldSample:
    """One reading: the field (x, y, z) in µT, its stamp (s, the sender's clock), when it
    arrived here (s, ``time.monotonic``) and how long after its stamp (s, by this machine's
    wall clock: meaningful when the sender shares it, as on one machine)."""

    field_uT: tuple[float, float, float]
    stamp_s: float
    received_s: float
    transit_s: float = float("nan")


class FieldTopic:
    """The field samples the rosbridge link queues (``RosbridgeLink.samples``)."""

    def __init__(self, link) -> None:
        self.link = link

    def next(self, timeout_s: float) -> FieldSample | None:
        """The oldest sample not yet taken, waiting up to ``timeout_s`` s."""
        try:
            return self.link.samples.get(timeout=timeout_s)
        except queue.Empty:
            return None

    def backlog(self) -> int:
        """Samples waiting (a loop that keeps up leaves none)."""
        return self.link.samples.qsize()

    def close(self) -> None:
        """Nothing of its own: the link closes the subscription."""


class SerialSamples:
    """whiskercal's sensor board on a serial port (``rig.SensorClient``), streaming at its
    configured rate; stamps are the board's clock."""

    def __init__(self, port: str) -> None:
        from whiskercal.rig.sensor import SensorClient

        self.client = SensorClient(port)
        self.client.identify()
        self.client.config()
        self.client.start()
        self._waiting: deque[FieldSample] = deque()

    def next(self, timeout_s: float) -> FieldSample | None:
        """The oldest sample not yet taken, waiting up to ``timeout_s`` s (by the port's clock)."""
        from whiskercal.errors import DeviceError

        if not self._waiting:
            self._keep(self.client.read_available())
        if not self._waiting:
            try:
                self._keep(self.client.read(1, timeout_s))
            except DeviceError:  # nothing within the wait: the watchdog's to report
                return None
        return self._waiting.popleft()

    def _keep(self, block) -> None:
        now = time.monotonic()
        for field, stamp in zip(np.asarray(block.field_uT, float), block.t_s):
            self._waiting.append(FieldSample(tuple(float(v) for v in field), float(stamp), now))

    def backlog(self) -> int:
        """Samples read from the port and not yet taken."""
        return len(self._waiting)

    def close(self) -> None:
        """Stop the stream and close the port."""
        try:
            self.client.stop()
        finally:
            self.client.close()
