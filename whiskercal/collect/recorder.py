"""Reading the sensor stream during a run: every sample kept, labelled, counted, and guarded.

The recorder is the only reader of the sensor during collection. It keeps each sample (with the
plan index it was averaged for, or -1) until the next checkpoint record takes it, counts dropped
and corrupt frames since that record, shifts device time to continue a resumed run, and applies
the overload guard to every sample it sees.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from whiskercal.artifacts.raw_grid import StreamChunk
from whiskercal.errors import DeviceError
from whiskercal.rig.overload import check_overload, saturated_axes, valid_samples

@dataclass
class Block:
    """Samples read in one go, device time already shifted to the run's clock (s, µT)."""

    t_s: np.ndarray
    field_uT: np.ndarray
    status: np.ndarray
    counts: np.ndarray

    @property
    def valid(self) -> np.ndarray:
        """Mask of samples whose axes are a measurement."""
        return valid_samples(self.status)


class StreamRecorder:
    """Reads ``sensor`` (a ``SensorClient``) and keeps what it reads for the checkpoint.

    Parameters
    ----------
    sensor
        A started sensor client.
    rate_hz
        The configured sample rate, Hz (sets read timeouts).
    res
        The configured MLX90393 resolution code (sets the axes' saturation count).
    resume_from
        (device time s, wall time s) of the last record of a resumed run, or None.
    """

    def __init__(self, sensor, rate_hz: float, res: int = 2,
                 resume_from: tuple[float, float] | None = None) -> None:
        self.sensor = sensor
        self.rate_hz = float(rate_hz)
        self.res = res
        self._resume_from = resume_from
        self._offset_s: float | None = None
        self._parts: list[StreamChunk] = []
        self.dropped = self.corrupt = 0
        self.total_dropped = self.total_corrupt = 0
        self.total_frames = 0  # frames received whole, every sample of this session
        self.static_y_uT: float | None = None
        self.overload_z_uT = np.inf

    def read(self, n: int, label: int = -1, guard: bool = True) -> Block:
        """Read the next ``n`` samples (waiting on the sensor's clock), label and keep them."""
        block = self.sensor.read(n, timeout_s=n / self.rate_hz + 1.0)
        return self.keep(block, label, guard)

    def read_for(self, seconds: float, label: int = -1, guard: bool = True) -> Block:
        """Read the samples of ``seconds`` s of sensor time (at least one)."""
        return self.read(max(1, int(round(seconds * self.rate_hz))), label, guard)

    def keep(self, block, label: int = -1, guard: bool = True) -> Block:
        """Keep a block read elsewhere (a ``SampleBlock``), labelled with a plan index or -1."""
        t_s = block.t_s + self._shift(block)
        self.dropped += block.dropped
        self.corrupt += block.corrupt
        self.total_dropped += block.dropped
        self.total_corrupt += block.corrupt
        self.total_frames += len(block.t_s)
        self._parts.append(StreamChunk(seq=np.asarray(block.seq) & 0xFFFF, t_s=t_s,
                                       counts=np.asarray(block.counts), status=np.asarray(block.status),
                                       point=np.full(len(block.seq), label)))
        kept = Block(t_s, np.asarray(block.field_uT, float), np.asarray(block.status),
                     np.asarray(block.counts))
        if guard:
            self.check_overload(kept)
        return kept

    def _shift(self, block) -> float:
        """Device-time offset, s: zero for a new run; a resumed run continues its old clock."""
        if self._offset_s is None and len(block.t_s):
            if self._resume_from is None:
                self._offset_s = 0.0
            else:
                last_t_s, last_wall_s = self._resume_from
                gap_s = max(time.time() - (last_wall_s or time.time()), 0.0)
                self._offset_s = last_t_s + gap_s - float(block.t_s[0])
        return self._offset_s or 0.0

    def saturated_axes(self, block: Block) -> str:
        """Names of the axes at an end of their output range in a valid sample ("" if none)."""
        return saturated_axes(block.counts, block.status, self.res)

    def check_overload(self, block: Block) -> None:
        """Raise ``OverloadError`` when any axis saturates or a sample's |z| exceeds the limit.

        Armed once the static reading is known (``static_y_uT``); the static reading itself is
        checked for saturation by the loop, which can say that the settings are at fault.
        """
        if self.static_y_uT is None:
            return
        check_overload(block.field_uT, block.counts, block.status, res=self.res,
                       static_y_uT=self.static_y_uT, limit_uT=self.overload_z_uT, moved="rod")

    def take_chunk(self) -> StreamChunk:
        """Every sample kept since the last take, as one chunk (possibly empty)."""
        parts, self._parts = self._parts, []
        if not parts:
            return StreamChunk(np.zeros(0, np.int32), np.zeros(0), np.zeros((0, 3), np.int16),
                               np.zeros(0, np.uint8), np.zeros(0, np.int32))
        return StreamChunk(*(np.concatenate([getattr(p, name) for p in parts])
                             for name in ("seq", "t_s", "counts", "status", "point")))

    def take_counts(self) -> tuple[int, int]:
        """(dropped, corrupt) frames since the last take."""
        counts = (self.dropped, self.corrupt)
        self.dropped = self.corrupt = 0
        return counts


def field_stats(block: Block) -> tuple[np.ndarray, np.ndarray, int]:
    """Mean and standard deviation (µT, X Y Z) of the valid samples, and how many there were.

    Raises
    ------
    DeviceError
        When fewer than half the samples are valid (the MLX90393 is not answering).
    """
    valid = block.valid
    if valid.sum() < max(1, len(valid) // 2):
        raise DeviceError(f"sensor marked {int((~valid).sum())} of {len(valid)} samples invalid "
                          "(MLX90393 error or not answering); check its I2C wiring")
    good = block.field_uT[valid]
    std = good.std(axis=0, ddof=1) if len(good) > 1 else np.zeros(3)
    return good.mean(axis=0), std, int(valid.sum())
