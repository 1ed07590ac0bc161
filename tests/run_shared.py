"""Files made once per test run and read by every process of it.

Under pytest-xdist each worker is a process of its own, so a per-process cache makes an
expensive input once per worker; a file made here is made by the first worker that asks while
the others wait for it, then read by all. The folder is the run's: pytest's base temporary
folder, which the workers of one run share (nothing outlives the run's temporary files).
"""

from __future__ import annotations

import fcntl
import os
import tempfile
from pathlib import Path
from typing import Callable

_folder: Path | None = None


def share_in(folder: Path) -> None:
    """Make the files of this run in ``folder`` (tests/conftest.py, once per process)."""
    global _folder
    folder.mkdir(parents=True, exist_ok=True)
    _folder = folder


def made_once(name: str, make: Callable[[Path], object]) -> Path:
    """The file ``name`` of this run, made by ``make(path)`` if no process of the run has made it
    yet (outside pytest: in a folder of this process)."""
    if _folder is None:
        share_in(Path(tempfile.mkdtemp(prefix="whiskercal-tests-")))
    path = _folder / name
    with open(_folder / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not path.exists():
            partial = Path(tempfile.mkdtemp(dir=_folder)) / name
            make(partial)
            os.replace(partial, path)  # whole or not there, should a worker die making it
    return path
