"""Recording the sensor stream and the stage's status while the stage moves.

The recorder reads the sensor between the stage's status polls, so the board's buffer never
overflows, tags every sample with the phase of the trial (approach, slide, retract), keeps every
status report with the number of samples received before it (a clock-free alignment of the two
devices), and applies the overload guard (whiskercal/rig/overload.py) to every sample.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from whiskercal.rig.overload import check_overload

POLL_PERIOD_S = 0.02
"""Sensor time read between two stage polls (s): ~50 status reports a second."""


@dataclass
class _Chunks:
    """Growing lists of per-sample arrays, joined on demand."""

    seq: list = field(default_factory=list)
    t_s: list = field(default_factory=list)
    counts: list = field(default_factory=list)
    field_uT: list = field(default_factory=list)
    status: list = field(default_factory=list)
    phase: list = field(default_factory=list)


class StreamRecorder:
    """Everything the sensor and stage report during one trial.

    Parameters
    ----------
    sensor
        A started ``SensorClient`` (or anything with ``read(n, timeout_s)``, ``read_available()``).
    rate_hz
        The sensor's sample rate (Hz), to size the reads between polls.
    static_y_uT
        The static (no contact) Y reading, µT.
    overload_uT
        Stop when |Y - static| exceeds this, µT (or when an axis saturates).
    clock
        The stage port's clock (s): simulated time on the twin.
    res
        The configured MLX90393 resolution code (sets the axes' saturation count).
    fresh_from_s
        Board time (s) of the first sample to record (``RigSession.sync``): older samples still
        queued when the trial starts are guarded and counted, not recorded.
    """

    def __init__(self, sensor, rate_hz: float, static_y_uT: float, overload_uT: float, clock,
                 res: int = 2, fresh_from_s: float = -np.inf):
        self.sensor = sensor
        self.chunk = max(1, int(round(rate_hz * POLL_PERIOD_S)))
        self.static_y_uT = float(static_y_uT)
        self.overload_uT = float(overload_uT)
        self.res = res
        self.clock = clock
        self.fresh_from_s = fresh_from_s
        self.phase = 0
        self.samples = 0
        self._stream = _Chunks()
        self._polls: dict[str, list] = {"sample_index": [], "t_host_s": [], "mpos_mm": [],
                                        "enc_mm": [], "phase": []}
        self.dropped = 0
        self.corrupt = 0

    def pump(self, wait: bool = True) -> None:
        """Read the samples that arrived (waiting for one poll period's worth when ``wait``)."""
        blocks = [self.sensor.read(self.chunk, timeout_s=1.0)] if wait else []
        blocks.append(self.sensor.read_available())
        for block in blocks:
            self._append(block)

    def _append(self, block) -> None:
        if len(block) == 0:
            return
        self.dropped += int(block.dropped)
        self.corrupt += int(block.corrupt)
        check_overload(block.field_uT, block.counts, block.status, res=self.res,
                       static_y_uT=self.static_y_uT, limit_uT=self.overload_uT, moved="plane")
        _, block = block.split(int(np.searchsorted(block.t_s, self.fresh_from_s)))
        n = len(block)
        if n == 0:
            return
        stream = self._stream
        stream.seq.append(block.seq)
        stream.t_s.append(block.t_s)
        stream.counts.append(block.counts)
        stream.field_uT.append(block.field_uT)
        stream.status.append(block.status)
        stream.phase.append(np.full(n, self.phase, np.int8))
        self.samples += n

    def on_poll(self, status) -> None:
        """``StageClient.wait_idle`` callback: keep the status, then read the sensor meanwhile."""
        polls = self._polls
        polls["sample_index"].append(self.samples)
        polls["t_host_s"].append(self.clock())
        polls["mpos_mm"].append(np.asarray(status.mpos_mm, float)[:2])
        enc = status.enc_mm if status.enc_mm is not None else np.full(2, np.nan)
        polls["enc_mm"].append(np.asarray(enc, float)[:2])
        polls["phase"].append(self.phase)
        if not status.idle:
            self.pump()

    def stream_arrays(self) -> dict[str, np.ndarray]:
        """The recorded samples: seq, t_s, counts, field_uT, status, phase."""
        stream = self._stream
        if not stream.seq:
            return {"seq": np.zeros(0, np.int64), "t_s": np.zeros(0), "counts": np.zeros((0, 3), np.int64),
                    "field_uT": np.zeros((0, 3)), "status": np.zeros(0, np.uint8),
                    "phase": np.zeros(0, np.int8)}
        return {name: np.concatenate(getattr(stream, name)) for name in
                ("seq", "t_s", "counts", "field_uT", "status", "phase")}

    def stage_arrays(self) -> dict[str, np.ndarray]:
        """The recorded status polls: sample_index, t_host_s, mpos_mm, enc_mm, phase."""
        polls = self._polls
        return {"sample_index": np.asarray(polls["sample_index"], np.int64),
                "t_host_s": np.asarray(polls["t_host_s"], float),
                "mpos_mm": np.asarray(polls["mpos_mm"], float).reshape(-1, 2),
                "enc_mm": np.asarray(polls["enc_mm"], float).reshape(-1, 2),
                "phase": np.asarray(polls["phase"], np.int8)}


def measured_positions_mm(stage: dict[str, np.ndarray]) -> np.ndarray:
    """The stage's position at each status poll (M, 2) mm.

    The encoder position where the stage reports one (it measures where the stage is), else the
    commanded machine position.
    """
    return stage["enc_mm"] if np.all(np.isfinite(stage["enc_mm"])) else stage["mpos_mm"]


def stage_position_per_sample(stage: dict[str, np.ndarray], n_samples: int) -> np.ndarray:
    """The stage position (mm) at each sample, interpolated between status polls.

    Positions as :func:`measured_positions_mm`; samples before the first poll take its position.
    """
    positions = measured_positions_mm(stage)
    if positions.shape[0] == 0:
        return np.full((n_samples, 2), np.nan)
    index = stage["sample_index"].astype(float)
    samples = np.arange(n_samples, dtype=float)
    return np.column_stack([np.interp(samples, index, positions[:, axis]) for axis in range(2)])
