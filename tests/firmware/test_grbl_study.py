"""One study depth through stock grbl 1.1h on simavr (``sim://NAME/stage?firmware=grbl&homing=xy``),
judged against the twin's ground truth. Marked ``grbl``: skipped unless WHISKERCAL_GRBL_SRC names
a checkout of gnea/grbl v1.1h."""

import time
import uuid

import numpy as np
import pytest

from grbl_emulation import grbl_or_skip
from whiskercal.artifacts.plane_study import PHASE_SLIDE, read_study

from short_study import short_study

pytestmark = [pytest.mark.grbl, pytest.mark.slow]
STEP_MM = 1 / 80  # the twin's belt: 80 steps/mm
BACKLASH_MM = 0.02  # the twin's default belt dead band
DEPTH_MM = 20.0


def test_one_study_depth_through_stock_grbl_keeps_the_plane_on_the_true_tip(tmp_path):
    from whiskercal.study.config import load_config
    from whiskercal.study.run import run_study
    from whiskercal.twin.devices import simport

    grbl_or_skip("xy")
    (tmp_path / "study.toml").write_text(short_study([DEPTH_MM]))
    config = load_config(tmp_path / "study.toml")
    world = f"grbl-study-{uuid.uuid4().hex[:8]}"
    stage = simport.Serial(f"sim://{world}/stage?scene=plane&seed=7&firmware=grbl&homing=xy", timeout=1.0)
    sensor = simport.Serial(f"sim://{world}/sensor", timeout=1.0)
    started = time.perf_counter()
    run_study(stage, sensor, tmp_path / "STUDY.h5", config)
    print(f"one depth through grbl: {time.perf_counter() - started:.1f} s wall")
    study = read_study(tmp_path / "STUDY.h5")
    assert study.complete and [t.depth_mm for t in study.trials] == [DEPTH_MM]
    trial = study.trials[0]
    slide = trial.stream["phase"] == PHASE_SLIDE
    assert slide.sum() > 250 and trial.truth is not None
    tip = slide & (trial.truth["kind"] == "tip")
    assert tip.sum() > 250  # the twin's truth: the tip touched the plane through the slide
    # without encoders the plane's line comes from grbl's step counters: within a step and the
    # belt's dead band of the true tip
    offset = trial.truth["tip_mm"][tip] - trial.plane["point_mm"][tip]
    distance = np.abs(np.sum(offset * trial.plane["normal"][tip], axis=1))
    print(f"plane line vs true tip: max {np.max(distance):.4f} mm")
    assert np.max(distance) < STEP_MM + BACKLASH_MM
