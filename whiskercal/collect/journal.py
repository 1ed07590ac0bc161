"""An append-only side journal: the crash-proof checkpoint of a collection run.

An HDF5 file killed in the middle of a write (kill -9, power loss) can be left with metadata
that no longer opens. The journal next to it (``RAW.h5.journal``) is plain text, one record per
line, each line carrying a CRC-32 of its JSON body. Lines are only ever appended and every
line is flushed and fsync'ed before the HDF5 file sees the same record, so after any crash the
journal holds every point the HDF5 file holds, and at most its last line is torn. Replaying the
journal (dropping a torn tail) rebuilds the dataset exactly.

Line format: ``<crc32 as 8 hex digits> <json>\\n``. No pickle: only JSON is ever parsed.
"""

from __future__ import annotations

import fcntl
import json
import os
import zlib
from pathlib import Path
from typing import Any, Iterator

from whiskercal.errors import ArtifactError, UsageError
from whiskercal.jsontools import jsonable


def journal_path(h5_path: str | Path) -> Path:
    """The journal that belongs to a raw dataset file."""
    h5_path = Path(h5_path)
    return h5_path.with_name(h5_path.name + ".journal")


def encode_line(record: dict[str, Any]) -> bytes:
    """One journal line for a record (JSON with its CRC-32 in front)."""
    body = json.dumps(record, default=jsonable, separators=(",", ":")).encode()
    return b"%08x " % zlib.crc32(body) + body + b"\n"


def decode_line(line: bytes) -> dict[str, Any] | None:
    """The record on one line, or None when the line is torn or fails its CRC."""
    if not line.endswith(b"\n") or len(line) < 10 or line[8:9] != b" ":
        return None
    body = line[9:-1]
    try:
        if int(line[:8], 16) != zlib.crc32(body):
            return None
        return json.loads(body)
    except ValueError:
        return None


class Journal:
    """Append records to a journal file, each one durable before ``append`` returns.

    Parameters
    ----------
    path : str or Path
        The journal file; created if missing, appended to otherwise.
    fsync : bool
        Force each line to the disk (survives power loss, not only a killed process).
    """

    def __init__(self, path: str | Path, fsync: bool = True) -> None:
        self.path = Path(path)
        self._fsync = fsync
        self._handle = open(self.path, "ab")
        self._lock()

    def _lock(self) -> None:
        """Hold the journal for this run alone: a second run on the same file (two ``collect
        --resume`` at once) is refused before it reads or rebuilds anything. The lock ends with
        the process, however it ends."""
        try:
            fcntl.flock(self._handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self._handle.close()
            raise UsageError(f"{self.path} is held by another collect run on the same file: "
                             "wait for it to end (or stop it), then --resume") from None

    def append(self, record: dict[str, Any]) -> None:
        """Write one record and make it durable."""
        self._handle.write(encode_line(record))
        self._handle.flush()
        if self._fsync:
            os.fsync(self._handle.fileno())

    def close(self) -> None:
        """Close the file (records are already durable)."""
        self._handle.close()


def _valid_lines(raw: bytes) -> Iterator[tuple[int, dict[str, Any]]]:
    """(end offset, record) for each good line until the first bad one."""
    offset = 0
    for line in raw.splitlines(keepends=True):
        record = decode_line(line)
        if record is None:
            return
        offset += len(line)
        yield offset, record


def replay(path: str | Path, truncate: bool = True) -> list[dict[str, Any]]:
    """Read every intact record of a journal, in order.

    A torn or corrupt line ends the journal: it and anything after it cannot be trusted,
    because records are written strictly one after another. With ``truncate`` the bad tail is
    cut off the file so that new records follow the last good one.

    Raises
    ------
    ArtifactError
        When the file is missing or its first line (the header) is unreadable.
    """
    path = Path(path)
    if not path.exists():
        raise ArtifactError(f"{path}: no such journal")
    raw = path.read_bytes()
    good = list(_valid_lines(raw))
    if not good:
        raise ArtifactError(f"{path}: journal has no readable header line")
    end = good[-1][0]
    if truncate and end < len(raw):
        with open(path, "r+b") as handle:
            handle.truncate(end)
    return [record for _, record in good]
