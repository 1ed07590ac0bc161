"""The tip sweep: its plan from the trace length, its place in the dataset, and a run on the twin."""

from __future__ import annotations

import uuid

import numpy as np
import pytest

from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.collect.config import load_config
from whiskercal.collect.plan import build_plan
from whiskercal.collect.run import collect
from whiskercal.collect.sweep import sweep_points
from whiskercal.fit.field_table import table_contacts
from whiskercal.fit.run import level_set_points
from whiskercal.model.calibrate import contact_mask

from fast_collect import FAST_DWELL, SMALL_BAND

ON = "[sweep]\nenabled = true\n"
# a few dozen grid points and a three-ray sweep: a run of seconds on the twin
SMALL_WITH_SWEEP = FAST_DWELL + SMALL_BAND + """
[sensor]
rate_hz = 100
[sweep]
enabled = true
angles = 3
angle_first_deg = -10.0
angle_last_deg = -30.0
offsets_mm = [-1.5, 0.0]
"""


def _config(tmp_path, text):
    path = tmp_path / "collect.toml"
    path.write_text(text)
    return load_config(path)


def test_the_sweep_follows_the_grid_on_rays_at_the_trace_length(tmp_path):
    plan = build_plan(_config(tmp_path, ON))
    sweep = plan.config.sweep
    assert plan.sweep_from == 180 and plan.sweep_count == sweep.angles * len(sweep.offsets_mm)
    points = plan.rod_center_mm[plan.sweep_from:]
    radius = np.hypot(*points.T) - plan.config.rig.trace_length_mm
    angle = np.degrees(np.arctan2(points[:, 1], points[:, 0]))
    np.testing.assert_allclose(np.unique(radius.round(9)), sorted(sweep.offsets_mm), atol=1e-9)
    assert angle.max() == pytest.approx(-5.0) and angle.min() == pytest.approx(-40.0)
    # the grid's 180 points are unchanged, in front
    off = build_plan(_config(tmp_path, "[sweep]\nenabled = false\n"))
    np.testing.assert_array_equal(plan.rod_center_mm[:180], off.rod_center_mm)


def test_the_default_plan_is_the_papers_grid_then_the_sweep(tmp_path):
    plan = build_plan(load_config())
    assert plan.sweep_from == 180 and plan.sweep_count == 28 and len(plan) == 208
    off = build_plan(_config(tmp_path, "[sweep]\nenabled = false\n"))
    assert len(off) == off.sweep_from == 180


def test_the_sweep_follows_another_trace_length(tmp_path):
    config = _config(tmp_path, "[rig]\ntrace_length_mm = 113.0\n" + ON)
    points = sweep_points(config.sweep, config.rig.trace_length_mm)
    # the offsets scale as the reach band does: -6 mm for 78 mm is -8.69 mm for 113 mm
    assert config.sweep.offsets_mm == (-8.69, -4.35, -2.17, 0.0)
    assert np.hypot(*points.T).max() == pytest.approx(113.0)
    assert np.hypot(*points.T).min() == pytest.approx(113.0 - 8.69)
    given = _config(tmp_path, "[rig]\ntrace_length_mm = 113.0\n" + ON + "offsets_mm = [-1.0]\n")
    assert given.sweep.offsets_mm == (-1.0,)  # a key the file gives wins


@pytest.mark.parametrize("text, words", [
    ("offsets_mm = [1.5]", "sweep.offsets_mm must lie in"),
    ("offsets_mm = [-30.0]", "sweep.offsets_mm must lie in"),
    ("offsets_mm = []", "[sweep] offsets_mm: must be a list of 1 to 16 numbers, not []"),
    ("angle_last_deg = 10.0", "[sweep] angle_last_deg: must be a number of deg in -90..0 (the rod pushes the whisker to -y)"),
    ("angles = 0", "[sweep] angles: must be an integer in 1..90, not 0"),
])
def test_a_sweep_that_cannot_touch_the_tip_from_above_is_refused(tmp_path, text, words):
    from whiskercal.errors import UsageError

    with pytest.raises(UsageError) as error:
        _config(tmp_path, f"[sweep]\nenabled = true\n{text}\n")
    assert words in str(error.value) and "\n" not in str(error.value)


def test_after_a_sweep_point_the_rod_leaves_past_the_tip_before_it_rises(tmp_path):
    plan = build_plan(_config(tmp_path, ON))
    rig = plan.config.rig
    for index in range(plan.sweep_from, len(plan) - 1):
        start = plan.rod_center_mm[index]
        first = plan.moves_to(start, plan.rod_center_mm[index + 1])[0]
        if start[1] < -rig.rod_radius_mm:  # below the wire's rest line: it may have sprung back
            assert first.end_mm[0] == pytest.approx(rig.whisker_reach_mm + rig.rod_radius_mm)
            assert first.end_mm[1] == pytest.approx(start[1])


@pytest.mark.slow
def test_a_sweep_run_on_the_twin_records_its_points_apart_from_the_grid(tmp_path):
    name = f"s{uuid.uuid4().hex[:10]}"
    plan = build_plan(_config(tmp_path, SMALL_WITH_SWEEP))
    summary = collect(f"sim://{name}/stage", f"sim://{name}/sensor", tmp_path / "raw.h5", plan)
    grid = read_raw_grid(tmp_path / "raw.h5")
    assert summary.complete and len(grid) == len(plan)
    assert grid.config["plan"]["tip_sweep"] == {"first_index": plan.sweep_from, "points": 6}
    assert grid.sweep.sum() == 6 and not grid.sweep[:plan.sweep_from].any()
    kinds = set(grid.truth["kind"][grid.sweep])
    assert "tip" in kinds and set(grid.truth["kind"][~grid.sweep]) == {"shaft"}
    # never a push from below: leaving a sweep point, the rod goes out past the tip first
    sigma = np.median(grid.z_std_uT)
    assert np.all(grid.z_uT < 5.0 * sigma)
    level_set = level_set_points(grid)
    assert len(level_set) == plan.sweep_from and not level_set.sweep.any()
    assert level_set.truth["kind"].tolist() == grid.truth["kind"][:plan.sweep_from].tolist()
    # the (Y, Z) table's joint fit reads the sweep's contacts too, marked as the sweep's
    contacts = table_contacts(grid)
    touched = contact_mask(grid.z_uT, grid.z_sem_uT)
    np.testing.assert_array_equal(contacts.sweep, grid.sweep[touched])
    assert contacts.sweep.any() and contacts.fields_uT.shape == (touched.sum(), 2)


def test_a_dataset_without_a_sweep_is_all_grid():
    from whiskercal.artifacts.raw_grid import tip_sweep_first_index

    assert tip_sweep_first_index({"plan": {"points": 180}}) is None
    assert tip_sweep_first_index({}) is None
    assert tip_sweep_first_index({"plan": {"tip_sweep": {"first_index": 180}}}) == 180
