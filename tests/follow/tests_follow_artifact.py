"""A calibration artifact with a target for the follow and contour tests (made once per process)."""

import functools
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DATASET = REPO / "data" / "twin-paper-75mm"


@functools.lru_cache(maxsize=1)
def calibration_path() -> Path:
    """The recorded default grid fitted, with the recorded study's target written into it."""
    from whiskercal import runtime
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.fit import fit
    from whiskercal.study.artifact_target import write_target
    from whiskercal.study.report import build_report

    folder = Path(tempfile.mkdtemp(prefix="whiskercal-follow-"))
    plain = fit(read_raw_grid(DATASET / "raw_grid.h5")).write(folder / "calibration.h5")
    report = build_report(DATASET / "plane_study.h5", runtime.load(plain))
    return write_target(plain, folder / "calibration-target.h5", report.choice, report.study.sha256)
