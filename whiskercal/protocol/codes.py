"""The protocol code table shared with the firmwares, read from ``protocol_codes.def``.

Each line of the table is ``X(KIND, NUMBER, NAME, "human text")``. The host reads it at import
time, so an edit to the table reaches the host and both firmwares at once.
"""

from __future__ import annotations

import enum
import re
from importlib import resources

_LINE = re.compile(r'^X\(\s*(\w+)\s*,\s*(\d+)\s*,\s*(\w+)\s*,\s*"((?:[^"\\]|\\.)*)"\s*\)\s*$')
KINDS = ("STAGE_ERROR", "STAGE_ALARM", "SENSOR_ERROR", "SENSOR_STATUS")


def parse_code_table(text: str) -> dict[str, list[tuple[int, str, str]]]:
    """Parse the code table's text into ``{kind: [(number, name, human text), ...]}``.

    Comment lines (``//``) and blank lines are skipped; any other line that does not match the
    ``X(...)`` form raises ``ValueError``, so a typo in the table cannot go unnoticed.
    """
    table: dict[str, list[tuple[int, str, str]]] = {kind: [] for kind in KINDS}
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("//"):
            continue
        match = _LINE.match(stripped)
        if match is None or match.group(1) not in table:
            raise ValueError(f"protocol_codes.def line {number} is not X(KIND, N, NAME, \"text\")")
        kind, code, name, text_value = match.groups()
        table[kind].append((int(code), name, text_value))
    return table


def _load_table() -> dict[str, list[tuple[int, str, str]]]:
    text = resources.files("whiskercal.protocol").joinpath("protocol_codes.def").read_text("utf-8")
    return parse_code_table(text)


_TABLE = _load_table()

StageError = enum.IntEnum("StageError", [(n, c) for c, n, _ in _TABLE["STAGE_ERROR"]])
StageAlarm = enum.IntEnum("StageAlarm", [(n, c) for c, n, _ in _TABLE["STAGE_ALARM"]])
SensorError = enum.IntEnum("SensorError", [(n, c) for c, n, _ in _TABLE["SENSOR_ERROR"]])
SensorStatus = enum.IntFlag("SensorStatus", [(n, c) for c, n, _ in _TABLE["SENSOR_STATUS"]])

STAGE_ERROR_TEXT = {c: t for c, _, t in _TABLE["STAGE_ERROR"]}
STAGE_ALARM_TEXT = {c: t for c, _, t in _TABLE["STAGE_ALARM"]}
SENSOR_ERROR_TEXT = {c: t for c, _, t in _TABLE["SENSOR_ERROR"]}
SENSOR_STATUS_TEXT = {c: t for c, _, t in _TABLE["SENSOR_STATUS"]}


def describe(kind: str, code: int) -> str:
    """Human text for a code, e.g. ``describe("STAGE_ALARM", 9)``; unknown codes say so."""
    texts = {"STAGE_ERROR": STAGE_ERROR_TEXT, "STAGE_ALARM": STAGE_ALARM_TEXT,
             "SENSOR_ERROR": SENSOR_ERROR_TEXT, "SENSOR_STATUS": SENSOR_STATUS_TEXT}[kind]
    return texts.get(code, f"unknown code {code} (not in protocol_codes.def)")
