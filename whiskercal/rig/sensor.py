"""Client for the whisker sensor board's framed stream (docs/protocol.md, "Sensor").

Commands are ASCII lines; every answer and every sample comes back as a frame. Samples that
arrive while a command waits for its answer are kept, so commands can be sent mid-stream.
Sequence numbers and board times are unwrapped; gaps in ``seq`` count as dropped samples and
frames that fail their CRC as corrupt ones.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from whiskercal.errors import DeviceError
from whiskercal.protocol.codes import describe
from whiskercal.protocol.frames import SAMPLE_FRAME_BYTES, FrameDecoder, Sample
from whiskercal.protocol.sensor_config import SensorConfig
from whiskercal.rig.transport import DeviceTimeout, Transport, open_port

_CONFIG_FIELD = re.compile(r"(\w+)=(-?\d+)")
_READ_CHUNK_BYTES = 4096
# Answered "OK" by a streaming board without changing anything: the sync marker (see sync()).
SYNC_COMMAND = "START"
# How long a sync may wait (s) once the host has read all that arrived: the board answers at
# once, but a host or a simulated board starved of CPU may take seconds. A client given a longer
# timeout waits that long instead (``SensorClient.sync_timeout_s``).
SYNC_TIMEOUT_S = 5.0


class SensorCommandError(DeviceError):
    """The sensor answered ``ERR:N``; ``code`` is N (see ``codes.SensorError``)."""

    def __init__(self, code: int, command: str, where: str) -> None:
        self.code = code
        super().__init__(f"sensor on {where} refused {command!r} with ERR:{code}: "
                         f"{describe('SENSOR_ERROR', code)}")


@dataclass
class SampleBlock:
    """Consecutive samples as arrays.

    ``seq`` (n,) int64 unwrapped; ``t_s`` (n,) board time in s, unwrapped; ``counts`` (n, 3)
    raw int; ``field_uT`` (n, 3) float in µT; ``status`` (n,) bit mask (``codes.SensorStatus``);
    ``dropped`` samples missing in or just before this block; ``corrupt`` frames rejected since
    the previous block.
    """

    seq: np.ndarray
    t_s: np.ndarray
    counts: np.ndarray
    field_uT: np.ndarray
    status: np.ndarray
    dropped: int = 0
    corrupt: int = 0

    def __len__(self) -> int:
        return len(self.seq)

    def split(self, index: int) -> tuple["SampleBlock", "SampleBlock"]:
        """The samples before ``index`` and those from it on; the frame counts go with the first."""
        def part(sl: slice, dropped: int, corrupt: int) -> SampleBlock:
            return SampleBlock(self.seq[sl], self.t_s[sl], self.counts[sl], self.field_uT[sl],
                               self.status[sl], dropped, corrupt)

        return (part(slice(None, index), self.dropped, self.corrupt),
                part(slice(index, None), 0, 0))

    @classmethod
    def join(cls, blocks: list["SampleBlock"]) -> "SampleBlock":
        """Consecutive blocks as one (frame counts added up); no blocks give an empty one."""
        if not blocks:
            return cls(np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 3), np.int64),
                       np.zeros((0, 3)), np.zeros(0, np.uint8))
        return cls(*(np.concatenate([getattr(b, name) for b in blocks])
                     for name in ("seq", "t_s", "counts", "field_uT", "status")),
                   dropped=sum(int(b.dropped) for b in blocks),
                   corrupt=sum(int(b.corrupt) for b in blocks))


@dataclass
class _Unwrapper:
    """Turns wrapping u16 sequence numbers and u32 µs times into monotonic ones."""

    last_seq: int | None = None
    last_t_us: int = 0
    seq: int = 0
    t_us: int = 0
    dropped: int = 0
    rows: list = field(default_factory=list)

    def add(self, sample: Sample) -> None:
        """Append one sample; a gap in ``seq`` counts the missing samples as dropped."""
        if self.last_seq is None:
            self.seq, self.t_us = sample.seq, sample.t_us
        else:
            step = (sample.seq - self.last_seq) & 0xFFFF
            self.dropped += max(step - 1, 0)
            self.seq += step
            self.t_us += (sample.t_us - self.last_t_us) & 0xFFFFFFFF
        self.last_seq, self.last_t_us = sample.seq, sample.t_us
        self.rows.append((self.seq, self.t_us, sample.x, sample.y, sample.z, sample.status))


class SensorClient:
    """Talk to the sensor board on ``port`` (a name/URL or an open pyserial object).

    Parameters
    ----------
    port
        ``/dev/ttyUSB0``, ``sim://NAME/sensor`` or an open pyserial object.
    timeout_s
        How long a command may take to be answered, s.
    """

    def __init__(self, port, timeout_s: float = 1.0) -> None:
        self.transport = Transport(open_port(port), "sensor")
        self.timeout_s = timeout_s
        self._decoder = FrameDecoder()
        self._unwrapper = _Unwrapper()
        self._frames: list = []  # decoded, not yet consumed (samples after a command's answer)
        self._config: SensorConfig | None = None
        self.dropped = 0
        self._corrupt_reported = 0
        self.streaming = False

    def close(self) -> None:
        """Close the port. Nothing is sent: a streaming board keeps streaming (see
        ``whiskercal.session.RigSession``, which stops it first)."""
        self.transport.close()

    def __enter__(self) -> "SensorClient":
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    @property
    def corrupt(self) -> int:
        """Frames rejected (CRC or header) and resynchronizations since the port was opened."""
        return self._decoder.corrupt

    # -- commands ---------------------------------------------------------------------------
    @property
    def sync_timeout_s(self) -> float:
        """How long START and a sync may wait for their answer (s): :data:`SYNC_TIMEOUT_S`, or
        the client's own timeout when that is longer."""
        return max(SYNC_TIMEOUT_S, self.timeout_s)

    def command(self, line: str, timeout_s: float | None = None) -> str:
        """Send one command line and return the text after ``OK``; ``ERR:N`` raises.

        The answer may take ``timeout_s`` (default: the client's) once the host has read all
        that arrived before it; samples meanwhile are kept.
        """
        timeout_s = self.timeout_s if timeout_s is None else timeout_s
        self.transport.write(line.encode("ascii") + b"\n")
        deadline = self.transport.now_s() + timeout_s
        while True:
            if not self._frames:
                self._receive(deadline, repr(line), timeout_s)
                continue
            frame = self._frames.pop(0)
            if isinstance(frame, Sample):
                self._unwrapper.add(frame)
            elif frame.startswith("ERR:"):
                raise SensorCommandError(_code(frame), line, self.transport.name)
            elif frame == "OK" or frame.startswith("OK "):
                return frame[3:]

    def _receive(self, deadline: float, what: str, timeout_s: float) -> None:
        remaining = deadline - self.transport.now_s()
        data = self.transport.read_some(_READ_CHUNK_BYTES, max(remaining, 0.0))
        if not data and remaining <= 0:
            raise self.transport.timed_out(what, timeout_s)
        self._frames += self._decoder.feed(data)

    def identify(self, attempts: int = 3) -> str:
        """The board's identity, e.g. ``whisker_nano fw=0.1.0 proto=1``.

        Opening an Arduino's port resets it; its bootloader swallows the first command, so
        ``ID`` is repeated up to ``attempts`` times before giving up.
        """
        for _ in range(attempts - 1):
            try:
                return self.command("ID")
            except DeviceTimeout:
                continue
        return self.command("ID")

    def config(self) -> SensorConfig:
        """Ask the board for its current settings (``CFG?``)."""
        values = dict((k, int(v)) for k, v in _CONFIG_FIELD.findall(self.command("CFG?")))
        try:
            self._config = SensorConfig(values["rate"], values["gain"], values["res"],
                                        values["osr"], values["filt"])
        except KeyError as error:
            raise DeviceError(f"sensor on {self.transport.name} sent a CFG? answer without "
                              f"{error.args[0]}") from None
        return self._config

    def configure(self, rate_hz: int | None = None, gain: int | None = None, res: int | None = None,
                  osr: int | None = None, filt: int | None = None) -> SensorConfig:
        """Change the given settings (only while stopped) and return the board's new settings."""
        wanted = {"RATE": rate_hz, "GAIN": gain, "RES": res, "OSR": osr, "FILT": filt}
        for name, value in wanted.items():
            if value is not None:
                self.command(f"{name} {int(value)}")
        return self.config()

    def start(self) -> None:
        """Start the sample stream; sequence and time unwrapping start afresh (unread samples
        of an earlier stream are discarded). The answer may take as long as a sync's: a board
        simulated in real time (``whiskercal sim serve``) on a busy machine sends it only after
        computing its first conversions."""
        if self._config is None:
            self.config()
        self._unwrapper = _Unwrapper()
        self.command("START", self.sync_timeout_s)
        self.streaming = True

    def stop(self) -> None:
        """Stop the sample stream; samples that arrived before the answer stay readable."""
        self.command("STOP")
        self.streaming = False

    def sync(self, attempts: int = 3) -> float:
        """The board time (s) from which every sample was converted after this call began.

        The host cannot see how many samples wait in the OS's and the USB bridge's buffers, so
        "what has arrived" says nothing about when a sample was taken. The board's answer to a
        command does: it travels in the stream behind every sample converted before the board
        read the command, and ahead of every later one. ``START`` while streaming is answered
        ``OK`` and changes nothing (docs/protocol.md), the shortest answer there is. The first
        sample behind the answer may have been triggered up to one period before the board read
        the command (its conversion was under way), so the time returned is one period after
        it. Samples read on the way stay readable.

        An answer lost with other frames on the way (a full OS buffer, a corrupted frame) is
        asked for again, up to ``attempts`` times; without such a loss a missing answer means
        the board does not answer, and a repeat could only leave a late answer behind to be
        mistaken for the next one's.

        Raises
        ------
        DeviceError
            When the board is not streaming or does not answer.
        """
        if not self.streaming:
            raise DeviceError(f"sensor on {self.transport.name} is not streaming; nothing to sync on")
        for attempt in range(1, attempts + 1):
            lost = self._frames_lost()
            try:
                self.command(SYNC_COMMAND, self.sync_timeout_s)
                break
            except DeviceTimeout:
                if attempt == attempts or self._frames_lost() == lost:
                    raise
        ahead = len(self._unwrapper.rows)  # samples kept up to the answer
        self._take([])  # samples decoded behind the answer
        return self._first_sample_after(ahead) + 1.0 / self._rate_hz()

    def _first_sample_after(self, behind: int) -> float:
        """Board time (s) of the first sample after the first ``behind`` kept ones, waiting for it."""
        deadline = self.transport.now_s() + self.sync_timeout_s
        while len(self._unwrapper.rows) <= behind:
            remaining = deadline - self.transport.now_s()
            data = self.transport.read_some(_READ_CHUNK_BYTES, max(remaining, 0.0))
            if not data and remaining <= 0:
                raise self.transport.timed_out("a sample after the sync answer",
                                               self.sync_timeout_s)
            self._take(self._decoder.feed(data))
        return self._unwrapper.rows[behind][1] * 1e-6

    def _frames_lost(self) -> int:
        """Corruption events and dropped samples seen so far (counted or not yet reported)."""
        return self._decoder.corrupt + self.dropped + self._unwrapper.dropped

    def _rate_hz(self) -> float:
        return float((self._config or SensorConfig()).rate_hz)

    # -- samples ----------------------------------------------------------------------------
    def read(self, n: int, timeout_s: float = 1.0) -> SampleBlock:
        """The next ``n`` samples; fewer within ``timeout_s`` (s, port clock) raise ``DeviceError``."""
        deadline = self.transport.now_s() + timeout_s
        self._take([])
        while len(self._unwrapper.rows) < n:
            missing_bytes = (n - len(self._unwrapper.rows)) * SAMPLE_FRAME_BYTES
            remaining = deadline - self.transport.now_s()
            data = self.transport.read_exactly(min(missing_bytes, _READ_CHUNK_BYTES), max(remaining, 0.0))
            if not data and remaining <= 0:
                raise DeviceError(f"sensor on {self.transport.name} delivered "
                                  f"{len(self._unwrapper.rows)} of {n} samples within {timeout_s:g} s; "
                                  "is it streaming (START)?")
            self._take(self._decoder.feed(data))
        return self._block(n)

    def read_available(self) -> SampleBlock:
        """Every sample already received, without waiting (possibly none)."""
        self._take(self._decoder.feed(self.transport.read_some(1 << 16, 0.0)))
        return self._block(len(self._unwrapper.rows))

    def _take(self, frames: list) -> None:
        """Move decoded samples into the unwrapper; a stray text frame is not a sample."""
        self._frames += frames
        for frame in self._frames:
            if isinstance(frame, Sample):
                self._unwrapper.add(frame)
        self._frames.clear()

    def _block(self, n: int) -> SampleBlock:
        rows = np.array(self._unwrapper.rows[:n], dtype=np.int64).reshape(-1, 6)
        del self._unwrapper.rows[:n]
        dropped, self._unwrapper.dropped = self._unwrapper.dropped, 0
        self.dropped += dropped
        corrupt, self._corrupt_reported = self.corrupt - self._corrupt_reported, self.corrupt
        counts = rows[:, 2:5]
        config = self._config or SensorConfig()
        return SampleBlock(seq=rows[:, 0], t_s=rows[:, 1] * 1e-6, counts=counts,
                           field_uT=counts * config.lsb_uT, status=rows[:, 5].astype(np.uint8),
                           dropped=dropped, corrupt=corrupt)


def _code(text: str) -> int:
    try:
        return int(text.split(":", 1)[1].split()[0])
    except (IndexError, ValueError):
        raise DeviceError(f"sensor sent an unreadable error answer: {text!r}") from None
