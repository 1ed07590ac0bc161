"""Replays a recorded grbl transcript's steps on another board and lists where it differs in what
must match: the kinds of its lines per step (ok, error and alarm codes, messages, banner, setting
numbers, status states), and the machine position of the steps marked ``check_mpos``."""

from __future__ import annotations

import uuid

import numpy as np
import serial

from grbl_transcript import Recorder, last_mpos, step_kinds

STEP_MM = 1 / 80  # one motor step of the twin's belt ($100 = $101 = 80 steps/mm)


def replay(header: dict, url_base: str) -> list[dict]:
    """Run the transcript's steps on a fresh board: ``url_base`` is ``sim://NAME/stage`` without
    NAME (made unique here) and takes the query."""
    port = serial.serial_for_url(url_base.replace("NAME", f"replay{uuid.uuid4().hex[:8]}"), timeout=1)
    try:
        return Recorder(port).run(header["steps"])
    finally:
        port.close()


def differences(header: dict, recorded: list[dict], replayed: list[dict]) -> list[str]:
    """What the replay does not repeat, one line per step."""
    found = []
    for index, step in enumerate(header["steps"]):
        what = step.get("send", step.get("poll_until", step.get("poll", step.get("wait_s"))))
        every = bool(step.get("count_reports"))
        grbl, other = step_kinds(recorded, index, every), step_kinds(replayed, index, every)
        if grbl != other:
            found.append(f"{header['name']} step {index} ({what!r}): grbl {grbl}, replay {other}")
        if step.get("check_mpos"):
            want, got = last_mpos(recorded, index), last_mpos(replayed, index)
            if got is None or np.max(np.abs(np.asarray(want) - got)) > STEP_MM:
                found.append(f"{header['name']} step {index} ({what!r}): grbl MPos {want}, replay {got}")
    return found
