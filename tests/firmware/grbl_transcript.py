"""Transcripts of a grbl board's serial exchanges: run a scenario's steps on a port, keep every
byte each way with its time, and reduce a transcript to what a faithful board must repeat.

A transcript (tests/data/grbl_transcripts/*.jsonl, README there) is JSON lines: a header with the
scenario's steps, then one entry per host write and per board line,
``{"t": s since the port opened, "dir": "host"|"board", "bytes": text, "step": index}``. The
steps are data, so the same scenario is replayed on any port (the twin's stock mode, the image).

Steps (each a dict):

- ``{"send": TEXT, "until": REGEX, "timeout_s": S}``: write TEXT, read lines until one matches;
- ``{"send": TEXT, "wait_s": S}``: write TEXT (a realtime byte), read for S seconds;
- ``{"poll_until": REGEX, "every_s": S, "timeout_s": S}``: ``?`` every S s until the state matches;
- ``{"poll": N, "every_s": S}``: ``?`` N times;
- ``{"wait_s": S}``: read for S seconds.

Any step may add ``"after_s"`` (read that much longer), ``"check_mpos": true`` (the step's last
MPos is compared, not only its line kinds) and ``"count_reports": true`` (every status report of
the step counts, not only changes of state).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import serial

from whiskercal.rig.stage import parse_status

TRANSCRIPTS = Path(__file__).resolve().parents[1] / "data" / "grbl_transcripts"
DEFAULT_TIMEOUT_S = 5.0
_STATUS_STATE = re.compile(r"^<([^|>]+)")
BANNER = re.compile(r"^Grbl 1\.1\w* \['\$' for help\]$")


class Recorder:
    """Runs steps on an open port and keeps the exchange, timed on the port's clock (s)."""

    def __init__(self, port: serial.SerialBase) -> None:
        self.port = port
        self.t0 = port.now_s()
        self.entries: list[dict] = []
        self.step = 0
        self._partial = bytearray()

    def _now(self) -> float:
        return round(self.port.now_s() - self.t0, 6)

    def send(self, text: str) -> None:
        self.port.write(text.encode("latin-1"))
        self.entries.append({"t": self._now(), "dir": "host", "bytes": text, "step": self.step})

    def read_line(self, deadline_s: float) -> str | None:
        """The next whole line (without CR LF) arriving before ``deadline_s`` (port time)."""
        while b"\n" not in self._partial:
            remaining = deadline_s - self.port.now_s()
            if remaining <= 0:
                return None
            self.port.timeout = remaining
            chunk = self.port.read(1)
            if not chunk:
                return None
            self._partial += chunk
        raw, _, rest = bytes(self._partial).partition(b"\n")
        self._partial = bytearray(rest)
        self.entries.append({"t": self._now(), "dir": "board", "bytes": raw.decode("latin-1") + "\n",
                             "step": self.step})
        return raw.decode("latin-1").rstrip("\r")

    def read_for(self, seconds: float) -> list[str]:
        deadline, lines = self.port.now_s() + seconds, []
        while (line := self.read_line(deadline)) is not None:
            lines.append(line)
        return lines

    def read_until(self, pattern: str, timeout_s: float) -> str | None:
        deadline = self.port.now_s() + timeout_s
        while (line := self.read_line(deadline)) is not None:
            if re.search(pattern, line):
                return line
        return None

    def poll(self, every_s: float, until: str | None, count: int, timeout_s: float) -> None:
        deadline = self.port.now_s() + timeout_s
        for _ in range(count):
            self.send("?")
            for line in self.read_for(every_s):
                match = _STATUS_STATE.match(line)
                if until is not None and match and re.search(until, match.group(1)):
                    return
            if self.port.now_s() > deadline:
                return

    def run_step(self, step: dict) -> None:
        timeout_s = step.get("timeout_s", DEFAULT_TIMEOUT_S)
        if "send" in step:
            self.send(step["send"])
            if "until" in step:
                self.read_until(step["until"], timeout_s)
            else:
                self.read_for(step.get("wait_s", 0.0))
        elif "poll_until" in step:
            every = step.get("every_s", 0.02)
            self.poll(every, step["poll_until"], int(timeout_s / every) + 1, timeout_s)
        elif "poll" in step:
            self.poll(step.get("every_s", 0.02), None, step["poll"], timeout_s)
        else:
            self.read_for(step["wait_s"])
        self.read_for(step.get("after_s", 0.0))

    def run(self, steps: list[dict]) -> list[dict]:
        for index, step in enumerate(steps):
            self.step = index
            self.run_step(step)
        return self.entries


def write_transcript(path: Path, header: dict, entries: list[dict]) -> None:
    lines = [json.dumps({"header": header})] + [json.dumps(entry) for entry in entries]
    path.write_text("\n".join(lines) + "\n")


def read_transcript(path: Path) -> tuple[dict, list[dict]]:
    lines = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return lines[0]["header"], lines[1:]


def transcripts() -> list[Path]:
    return sorted(TRANSCRIPTS.glob("*.jsonl"))


def kind(line: str) -> str | None:
    """What a faithful board must repeat of a line: its kind, codes, message text, state."""
    line = line.rstrip("\r\n")
    if not line:
        return None
    if line in ("ok",) or re.fullmatch(r"(error|ALARM):\d+", line):
        return line
    if BANNER.match(line):
        return "banner"
    if line.startswith("[MSG:"):
        return line
    if line.startswith(("[VER:", "[OPT:")):
        return line[:4]
    if (setting := re.match(r"\$(\d+)=", line)) is not None:
        return f"${setting.group(1)}"
    if (state := _STATUS_STATE.match(line)) is not None:
        return f"status:{state.group(1)}"
    return f"other:{line}"


def step_kinds(entries: list[dict], step: int, every_report: bool = False) -> list[str]:
    """The kinds of the board's lines in one step, repeated status states counted once (unless
    ``every_report``)."""
    kinds: list[str] = []
    for entry in entries:
        if entry["dir"] != "board" or entry["step"] != step:
            continue
        k = kind(entry["bytes"])
        repeated = k is not None and k.startswith("status:") and kinds and kinds[-1] == k
        if k is not None and (every_report or not repeated):
            kinds.append(k)
    return kinds


def last_mpos(entries: list[dict], step: int) -> np.ndarray | None:
    """The machine position (x, y, mm) of the last status report in a step (WCO followed)."""
    wco, mpos = None, None
    for entry in entries:
        if entry["dir"] == "board" and entry["bytes"].startswith("<"):
            status = parse_status(entry["bytes"].strip(), wco)
            wco = status.wco_mm
            if entry["step"] == step:
                mpos = status.mpos_mm
    return mpos
