"""Which reader a recording needs, told from its first bytes and its name; nothing but regular
files (and a rosbag2 folder of them) is opened, so a FIFO or a device never blocks a read."""

from __future__ import annotations

import os
import stat
from pathlib import Path

from whiskercal.errors import UsageError

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
MCAP_MAGIC = b"\x89MCAP0\r\n"
SQLITE_MAGIC = b"SQLite format 3\x00"
ROSBAG1_MAGIC = b"#ROSBAG V2.0"
BAG_METADATA = "metadata.yaml"


def regular_file(path: str | Path, what: str = "the stream") -> Path:
    """``path`` when it is a regular file (links followed), else one UsageError saying what it
    is: missing, a folder, a FIFO, a device or a socket."""
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except OSError as error:
        raise UsageError(f"{path}: cannot read {what}: {error.strerror or error}") from None
    if stat.S_ISREG(mode):
        return path
    kind = ("a folder" if stat.S_ISDIR(mode) else "a FIFO" if stat.S_ISFIFO(mode)
            else "a socket" if stat.S_ISSOCK(mode) else "a device" if stat.S_ISCHR(mode)
            or stat.S_ISBLK(mode) else "not a regular file")
    raise UsageError(f"{path}: {what} must be a regular file, not {kind}")


def bag_folder(path: str | Path) -> Path | None:
    """The rosbag2 folder ``path`` is, or holds as one of its storage files; else None."""
    path = Path(path)
    if path.is_dir():
        if not (path / BAG_METADATA).exists():
            raise UsageError(f"{path}: a folder without {BAG_METADATA} is not a rosbag2 bag")
        regular_file(path / BAG_METADATA, "a bag's metadata")
        return path
    if path.suffix in (".mcap", ".db3") and (path.parent / BAG_METADATA).is_file():
        return path.parent
    return None


def kind_of(path: str | Path) -> str:
    """"bag2", "bag1", "mcap" (an MCAP file alone, without a bag's metadata), "hdf5", "echo"
    (``rostopic echo`` / ``ros2 topic echo`` YAML) or "table"; a bare sqlite3 storage file
    without its bag's metadata is refused."""
    if bag_folder(path) is not None:
        return "bag2"
    path = regular_file(path)
    with path.open("rb") as handle:
        head = handle.read(4096)
    if head.startswith(ROSBAG1_MAGIC):
        return "bag1"
    if head.startswith(HDF5_SIGNATURE):
        return "hdf5"
    if head.startswith(MCAP_MAGIC):
        return "mcap"
    if head.startswith(SQLITE_MAGIC):
        raise UsageError(f"{path}: a rosbag2 sqlite3 file without its bag's {BAG_METADATA}: give "
                         "the bag's folder (ros2 bag record writes both)")
    return "echo" if _looks_like_echo(head) else "table"


def _looks_like_echo(head: bytes) -> bool:
    """An echo log's first document opens with ``key:`` lines and is separated by ``---``."""
    text = head.decode("utf-8", "replace").lstrip("\ufeff")
    lines = [line for line in text.splitlines() if line.strip() and not line.startswith("#")]
    if not lines:
        return False
    first = lines[0].rstrip()
    return first.endswith(":") or (": " in first and "," not in first and "\t" not in first)
