"""Followed tip loads (``/load_branches``) in the calibration artifact and the runtime's tracker.

The loads here fan out from rest in closed form: direction a in [0, 1], size m; (Y, Z) =
-100 m (1, a) µT (one sample's noise 5.6 / 9 µT), tip (78 - 0.2 m, -m (1 + a)) mm. A tracker
given the Z axis follows them through every sample and reads the tip there; without the Z axis
it reads the z lookup, as before; a reading no load near the followed one explains gets no tip.
"""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from whiskercal import runtime
from whiskercal.artifacts.calibration import SCHEMA_VERSION, read_calibration, write_calibration
from whiskercal.errors import ArtifactError
from whiskercal.model.errors import ZOutOfRangeError

FIXTURE = Path(__file__).parents[1] / "fixtures" / "calibration-1.0.0.h5"
DIRECTIONS = np.linspace(0.0, 1.0, 21)
SIZES = np.linspace(0.0, 80.0, 161)
NOISE = np.array([5.6, 9.0])


def _reading(a, m):
    return np.stack(np.broadcast_arrays(-100.0 * m, -100.0 * m * a), axis=-1)


def _tip(a, m):
    a, m = np.broadcast_arrays(np.asarray(a, float), np.asarray(m, float))
    return np.stack([78.0 - 0.2 * m, -m * (1.0 + a)], axis=-1)


def _branches():
    a, m = np.meshgrid(DIRECTIONS, SIZES, indexing="ij")
    return {"fields_uT": _reading(a, m), "tip_mm": _tip(a, m), "noise_uT": NOISE,
            "y_range_uT": np.array([-8000.0, 0.0])}


@pytest.fixture(scope="module")
def with_branches(tmp_path_factory):
    data = read_calibration(FIXTURE)
    path = tmp_path_factory.mktemp("lb") / "cal-branches.h5"
    write_calibration(path, replace(data, load_branches=_branches()))
    return path


def _press(tracker, a, to_size, seed=0, axial=True):
    """Feed a press along direction ``a`` from rest to ``to_size`` (noisy, seeded); the last
    state."""
    rng = np.random.default_rng(seed)
    state = None
    for m in np.concatenate([np.zeros(5), np.arange(0.05, to_size + 1e-9, 0.05)]):
        y, z = _reading(a, m) + rng.normal(0.0, 1.0, 2) * NOISE
        state = tracker.update(float(y), float(z) if axial else None)
    return state


def test_the_loads_round_trip_as_float32_and_bump_the_version(with_branches):
    data = read_calibration(with_branches)
    assert data.schema_version == SCHEMA_VERSION == "1.5.0"
    expected = _branches()
    for key in expected:
        np.testing.assert_allclose(data.load_branches[key], expected[key], rtol=1e-6)


def test_an_artifact_without_loads_has_none():
    assert runtime.load(FIXTURE).load_branches is None


@pytest.mark.parametrize("a", [0.0, 0.5, 1.0])
def test_a_press_is_read_on_its_own_load(with_branches, a):
    state = _press(runtime.load(with_branches).tracker(), a, 60.0, seed=int(10 * a))
    assert state.contact
    assert np.linalg.norm(state.raw_tip_mm - _tip(a, 60.0)) < 0.5


def test_without_the_z_axis_the_tracker_reads_the_z_lookup(with_branches):
    calibration = runtime.load(with_branches)
    state = _press(calibration.tracker(out_of_range="clip"), 0.5, 60.0, axial=False)
    lookup_tip = calibration.tip(float(_reading(0.5, 60.0)[0]))
    assert np.linalg.norm(state.raw_tip_mm - lookup_tip) < 0.5
    assert np.linalg.norm(lookup_tip - _tip(0.5, 60.0)) > 5.0  # not the followed load's


def test_a_reading_past_the_loads_gets_no_tip(with_branches):
    tracker = runtime.load(with_branches).tracker(out_of_range="nan")
    _press(tracker, 0.0, 30.0)
    state = tracker.update(-3000.0, 4000.0)  # Z of the wrong sign: no load reads it
    assert state.contact and state.raw_tip_mm is None and state.out_of_range == 1
    strict = runtime.load(with_branches).tracker()
    _press(strict, 0.0, 30.0)
    with pytest.raises(ZOutOfRangeError, match="beyond every tip load"):
        strict.update(-3000.0, 4000.0)


def test_each_contact_is_followed_from_rest(with_branches):
    tracker = runtime.load(with_branches).tracker()
    _press(tracker, 0.0, 60.0)
    for _ in range(5):  # released: back at rest
        assert not tracker.update(0.0, 0.0).contact
    state = _press(tracker, 1.0, 60.0, seed=3)
    assert np.linalg.norm(state.raw_tip_mm - _tip(1.0, 60.0)) < 0.5


def test_loads_of_mismatched_shapes_are_refused(tmp_path):
    data = read_calibration(FIXTURE)
    bad = {**_branches(), "tip_mm": np.zeros((3, 3, 2))}
    path = tmp_path / "bad.h5"
    write_calibration(path, replace(data, load_branches=bad))
    with pytest.raises(ArtifactError, match="load branches"):
        read_calibration(path)
