"""The (Y, Z) -> tip table in the calibration artifact and the runtime's tracker.

An artifact without ``/field_table`` (every older one) loads and tracks exactly as before; one
with it reads the tip from the table when the tracker gets the Z axis too, and falls back to the
z lookup where the table has no tip, except past every load the table was made from.
"""

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from whiskercal import runtime
from whiskercal.artifacts.calibration import SCHEMA_VERSION, read_calibration, write_calibration
from whiskercal.errors import ArtifactError
from whiskercal.model.errors import ZOutOfRangeError
from whiskercal.model.field_table import FieldTipTable

FIXTURE = Path(__file__).parents[1] / "fixtures" / "calibration-1.0.0.h5"


def _table(data):
    """A bilinear table over the lookup's range whose tip is known in closed form; NaN for
    Z above 100 µT (where a real table has no tip loads)."""
    y = np.linspace(data.lookup_z_uT[0], data.lookup_z_uT[-1], 11)
    z = np.linspace(-200.0, 200.0, 9)
    yy, zz = np.meshgrid(y, z, indexing="ij")
    tips = np.stack([78.0 + 0.001 * yy, 0.002 * yy + 0.01 * zz], axis=-1)
    tips[:, z > 100.0] = np.nan
    return {"y_uT": y, "axial_uT": z, "tip_mm": tips}


@pytest.fixture(scope="module")
def with_table(tmp_path_factory):
    data = read_calibration(FIXTURE)
    path = tmp_path_factory.mktemp("ft") / "cal-table.h5"
    write_calibration(path, replace(data, field_table=_table(data)))
    return path


def test_an_old_artifact_has_no_table_and_tracks_on_z_alone(tmp_path):
    calibration = runtime.load(FIXTURE)
    assert calibration.field_table is None
    z = float(np.mean(calibration.z_range_uT))
    with_z = calibration.tracker().update(z, 50.0)
    alone = calibration.tracker().update(z)
    np.testing.assert_array_equal(with_z.raw_tip_mm, alone.raw_tip_mm)


def test_the_table_round_trips_and_bumps_the_minor_version(with_table):
    data = read_calibration(with_table)
    assert data.schema_version == SCHEMA_VERSION
    expected = _table(read_calibration(FIXTURE))
    for key in ("y_uT", "axial_uT"):
        np.testing.assert_array_equal(data.field_table[key], expected[key])
    np.testing.assert_array_equal(np.isnan(data.field_table["tip_mm"]),
                                  np.isnan(expected["tip_mm"]))


def test_the_tracker_reads_the_table_and_falls_back_to_the_lookup(with_table):
    calibration = runtime.load(with_table)
    z = float(np.mean(calibration.z_range_uT))
    state = calibration.tracker().update(z, -60.0)
    np.testing.assert_allclose(state.raw_tip_mm, [78.0 + 0.001 * z, 0.002 * z - 0.6], atol=1e-9)
    outside = calibration.tracker().update(z, 150.0)  # the table has no tip there
    np.testing.assert_allclose(outside.raw_tip_mm, calibration.tip(z), atol=1e-12)
    without = calibration.tracker().update(z)
    np.testing.assert_allclose(without.raw_tip_mm, calibration.tip(z), atol=1e-12)


def test_at_the_edge_of_the_loads_the_corners_with_a_tip_answer(with_table):
    # Z 120 µT: the cell's corners at 100 µT have tips, those at 150 µT none; the reading is
    # within a cell of tabulated loads, so their tips answer (renormalized), not the z lookup
    calibration = runtime.load(with_table)
    z = float(np.mean(calibration.z_range_uT))
    state = calibration.tracker().update(z, 120.0)
    np.testing.assert_allclose(state.raw_tip_mm, [78.0 + 0.001 * z, 0.002 * z + 1.0], atol=1e-9)
    assert math.isnan(calibration.field_table.tip_scalar(z, 160.0)[0])  # no corner has one


def test_a_reading_beyond_every_tabulated_load_gets_no_tip_under_any_policy(with_table):
    # Z 300 µT lies more than one cell (50 µT) above the highest Z the table answers at this Y
    # (100 µT): a load past any the model tabulated, which the z lookup would place on the
    # frictionless tip curve (a soft root's deep plane contacts: 20-50 mm off)
    calibration = runtime.load(with_table)
    z = float(np.mean(calibration.z_range_uT))
    with pytest.raises(ZOutOfRangeError, match="beyond every tip load"):
        calibration.tracker().update(z, 300.0)
    for policy in ("clip", "nan"):
        tracker = calibration.tracker(policy)
        tracker.update(z, -60.0)
        state = tracker.update(z, -300.0)
        assert state.raw_tip_mm is None and state.out_of_range == -1
        assert state.filtered_tip_mm is not None  # the filter keeps its state
    table = calibration.field_table
    assert table.beyond_loads(z, 300.0) == 1 and table.beyond_loads(z, 150.0) == 0
    assert table.beyond_loads(calibration.z_range_uT[1] + 1.0, 300.0) == 0  # past Y's span
    assert table.beyond_loads(float("nan"), 300.0) == 0


@pytest.mark.parametrize("policy", ["raise", "clip", "nan"])
def test_a_non_finite_z_axis_reads_y_alone_and_never_crashes(with_table, policy):
    # a dropped Z sample (NaN) used to raise ValueError inside the table's read
    calibration = runtime.load(with_table)
    z = float(np.mean(calibration.z_range_uT))
    state = calibration.tracker(policy).update(z, float("nan"))
    np.testing.assert_allclose(state.raw_tip_mm, calibration.tip(z), atol=1e-12)
    table = calibration.field_table
    for y, axial in ((float("nan"), 0.0), (float("inf"), 0.0), (z, float("-inf"))):
        assert math.isnan(table.tip_scalar(y, axial)[0])


def test_a_table_of_the_wrong_shape_is_refused(tmp_path):
    data = read_calibration(FIXTURE)
    table = _table(data)
    table["tip_mm"] = table["tip_mm"][:, :-1]
    path = tmp_path / "bad.h5"
    write_calibration(path, replace(data, field_table=table))
    with pytest.raises(ArtifactError, match="field table"):
        runtime.load(path)


def test_the_bilinear_table_is_exact_on_a_bilinear_function():
    y, z = np.linspace(-100, 0, 11), np.linspace(-50, 50, 21)
    yy, zz = np.meshgrid(y, z, indexing="ij")
    table = FieldTipTable(y, z, np.stack([yy + 2 * zz, yy * zz], axis=-1))
    assert table.tip_scalar(-33.0, 7.5) == pytest.approx((-33.0 + 15.0, -33.0 * 7.5))
    assert all(math.isnan(v) for v in table.tip_scalar(10.0, 0.0))
