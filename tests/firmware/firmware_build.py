"""Builds the firmware's host programs (unit tests, conformance simulators) with g++ through
``make -C firmware``, once per test session and safely when pytest-xdist runs workers in
parallel. Builds go to ``build/firmware/`` (ignored by git)."""

from __future__ import annotations

import fcntl
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
FIRMWARE = REPO / "firmware"
BUILD = REPO / "build" / "firmware"
HOST = BUILD / "host"
BOARDS = ("stage_stepper", "whisker_nano")


def make(target: str, tool: str) -> str:
    """Run ``make -C firmware target`` under a lock; skip the test when ``tool`` is missing.

    Returns make's output; a failed build fails the test with that output.
    """
    if shutil.which(tool) is None or shutil.which("make") is None:
        pytest.skip(f"{tool} (or make) is not installed: cannot build the firmware ({target})")
    BUILD.mkdir(parents=True, exist_ok=True)
    with open(BUILD / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # xdist workers must not run make on the same files at once
        result = subprocess.run(["make", "-C", str(FIRMWARE), target], capture_output=True, text=True,
                                timeout=600)
    if result.returncode != 0:
        pytest.fail(f"make {target} failed:\n{result.stdout[-4000:]}\n{result.stderr[-4000:]}")
    return result.stdout


def host_program(board: str, kind: str) -> Path:
    """Path of a built host program: ``kind`` is ``test`` or ``sim``."""
    make("host", "g++")
    return HOST / f"{board}_{kind}"
