"""Fits of the recorded datasets (data/) that several test directories read, made once per test
run: the replay, follow, contour and robot tests all start from the same fit of the default
grid, which takes seconds (tests/run_shared.py shares it between the run's workers)."""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

from run_shared import made_once
from whiskercal.fit import FitOptions

DATA = Path(__file__).resolve().parents[1] / "data"


@functools.lru_cache(maxsize=4)
def recorded_fit(dataset: str, options: FitOptions) -> Path:
    """data/``dataset``/raw_grid.h5 fitted with ``options`` (read it, never write next to it)."""
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.fit import fit

    def make(path: Path) -> None:
        fit(read_raw_grid(DATA / dataset / "raw_grid.h5"), options).write(path)

    key = hashlib.sha256(repr(options).encode()).hexdigest()[:16]
    return made_once(f"fit-{dataset}-{key}.h5", make)
