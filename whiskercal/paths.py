"""Paths: one place that turns "cannot create that directory" into a clear error, and one that
tells a regular file from what would block a reader (a FIFO, a device)."""

from __future__ import annotations

import stat
from pathlib import Path

from whiskercal.errors import UsageError


def ensure_dir(directory: str | Path) -> Path:
    """Create ``directory`` (and its parents) if missing; one clear error when that is impossible."""
    directory = Path(directory)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise UsageError(f"cannot create the directory {directory}: {error.strerror or error}") from None
    return directory


def not_regular_reason(path: str | Path) -> str | None:
    """Why ``path`` (links followed) cannot be read as a file, or None when it is a regular file
    or does not exist. A FIFO, socket or device would block or stream forever in ``open()``."""
    try:
        mode = Path(path).stat().st_mode
    except FileNotFoundError:
        return None
    except OSError as error:
        return f"cannot be read ({error.strerror or error})"
    if stat.S_ISREG(mode):
        return None
    kinds = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"),
             (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"))
    kind = next((name for test, name in kinds if test(mode)), "not a file")
    return f"is {kind}, not a regular file"
