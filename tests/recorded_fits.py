"""Fits of the recorded datasets (data/) that several test directories read, made once per test
process: the replay, follow, contour and robot tests all start from the same fit of the default
grid, which takes seconds."""

from __future__ import annotations

import functools
import tempfile
from pathlib import Path

from whiskercal.fit import FitOptions

DATA = Path(__file__).resolve().parents[1] / "data"


@functools.lru_cache(maxsize=4)
def recorded_fit(dataset: str, options: FitOptions) -> Path:
    """data/``dataset``/raw_grid.h5 fitted with ``options``, written to a folder of its own
    (read it, never write next to it)."""
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.fit import fit

    folder = Path(tempfile.mkdtemp(prefix=f"whiskercal-fit-{dataset}-"))
    return fit(read_raw_grid(DATA / dataset / "raw_grid.h5"), options).write(folder / "calibration.h5")
