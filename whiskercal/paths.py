"""Output locations: one place that turns "cannot create that directory" into a clear error."""

from __future__ import annotations

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
