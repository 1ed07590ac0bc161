"""The runtime API under arbitrary input: a valid result or the package's own error, nothing else.

Short derandomized hypothesis runs: the same examples on every run, a few seconds in all.
"""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from whiskercal import runtime
from whiskercal.errors import UsageError, WhiskercalError

FIXTURE = Path(__file__).parents[1] / "fixtures" / "calibration-1.0.0.h5"
FUZZ = settings(max_examples=300, derandomize=True, deadline=None,
                suppress_health_check=[HealthCheck.too_slow,
                                       HealthCheck.function_scoped_fixture])
CALIBRATION = runtime.load(FIXTURE)
LOW, HIGH = CALIBRATION.z_range_uT

_NUMBERS = st.one_of(st.floats(), st.floats(LOW, HIGH), st.integers(-10**6, 10**6))
_SHAPES = hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=4)
_ARRAYS = st.one_of(
    hnp.arrays(np.float64, _SHAPES, elements=st.one_of(st.floats(LOW, HIGH), st.floats())),
    hnp.arrays(st.sampled_from([np.float32, np.int32, np.uint8, np.bool_, np.complex128,
                                np.dtype("U3"), np.dtype("O")]), _SHAPES))
_JUNK = st.one_of(st.none(), st.text(max_size=5), st.booleans(), st.complex_numbers(),
                  st.binary(max_size=3), st.dictionaries(st.text(max_size=2), st.integers(), max_size=2),
                  st.lists(st.one_of(st.floats(), st.lists(st.floats(), max_size=2)), max_size=3))
_ANY_Z = st.one_of(_NUMBERS, _ARRAYS, _JUNK)
_POLICIES = st.one_of(st.sampled_from(["raise", "nan", "clip"]), st.text(max_size=5), st.none(),
                      st.integers())


def _quiet(call):
    """Run ``call``: a package error or a result, never another exception."""
    try:
        return call()
    except WhiskercalError:
        return None


@FUZZ
@given(_ANY_Z, _POLICIES)
def test_tip_gives_tips_or_a_package_error(z, policy):
    tips = _quiet(lambda: CALIBRATION.tip(z, policy))
    if tips is not None:
        assert tips.shape == np.shape(z) + (2,)
        finite = np.isfinite(tips).all(axis=-1)
        inside = (np.asarray(z, float) >= LOW) & (np.asarray(z, float) <= HIGH)
        assert np.all(finite[inside])
        if policy == "clip":
            assert np.all(finite)


@FUZZ
@given(_ANY_Z)
def test_extrapolated_gives_flags_or_a_package_error(z):
    flags = _quiet(lambda: CALIBRATION.extrapolated(z))
    if flags is not None:
        assert flags.shape == np.shape(z) and flags.dtype == bool


@FUZZ
@given(_POLICIES, st.lists(_ANY_Z, max_size=20))
def test_tracker_updates_give_states_or_a_package_error(policy, samples):
    tracker = _quiet(lambda: CALIBRATION.tracker(policy))
    if tracker is None:
        return
    for z in samples:
        state = _quiet(lambda: tracker.update(z))
        if state is not None and state.raw_tip_mm is not None:
            assert state.contact and np.all(np.isfinite(state.raw_tip_mm))
            assert np.all(np.isfinite(state.filtered_tip_mm))


@pytest.mark.parametrize("z", [None, "1.0", b"1", [1.0], np.array([1.0, 2.0]), 1j, True, {}])
def test_tracker_refuses_what_is_not_one_number_and_stays_usable(z):
    tracker = CALIBRATION.tracker()
    middle = float(np.mean(CALIBRATION.z_range_uT))
    first = tracker.update(middle)
    with pytest.raises(UsageError, match="z must be one real number"):
        tracker.update(z)
    again = tracker.update(middle)
    assert first.contact and again.contact and again.filtered_tip_mm is not None


@pytest.mark.parametrize("z", ["abc", None, {}, [[1.0], [2.0, 3.0]], np.array([1j]), True])
def test_tip_and_extrapolated_refuse_non_numbers(z):
    with pytest.raises(UsageError, match="z must be"):
        CALIBRATION.tip(z)
    with pytest.raises(UsageError, match="z must be"):
        CALIBRATION.extrapolated(z)


@pytest.mark.parametrize("z", [float("nan"), float("inf"), -float("inf"), np.float32(1e30)])
def test_trace_of_a_non_finite_or_huge_z_is_a_package_error(z):
    with pytest.raises(WhiskercalError):
        CALIBRATION.trace(z)


@pytest.mark.parametrize("path, allow", [(None, False), (3, False), (FIXTURE, "yes"),
                                         (FIXTURE, None)])
def test_load_refuses_wrong_types(path, allow):
    with pytest.raises(UsageError):
        runtime.load(path, allow_extrapolated=allow)
