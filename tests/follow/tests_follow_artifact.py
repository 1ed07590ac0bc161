"""A calibration artifact with a target for the follow and contour tests (made once per process)."""

import functools
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DATASET = REPO / "data" / "twin-paper-75mm"


@functools.lru_cache(maxsize=1)
def calibration_path() -> Path:
    """The recorded default grid fitted (the level set, Y only), with the recorded study's target
    written into it."""
    from recorded_fits import recorded_fit
    from whiskercal import runtime
    from whiskercal.fit import FitOptions
    from whiskercal.study.artifact_target import write_target
    from whiskercal.study.report import build_report

    folder = Path(tempfile.mkdtemp(prefix="whiskercal-follow-"))
    # The paper's Y-only calibration, which these tests' bounds were measured with: the level
    # set is the closer z lookup for contacts with friction (docs/calibration.md), and fit's
    # default (Y, Z) table would add about a minute to every process that runs them.
    options = FitOptions(tip_model="level-set", field_table=False)
    plain = recorded_fit(DATASET.name, options)  # the replay tests' calibration too
    report = build_report(DATASET / "plane_study.h5", runtime.load(plain))
    return write_target(plain, folder / "calibration-target.h5", report.choice, report.study.sha256)
