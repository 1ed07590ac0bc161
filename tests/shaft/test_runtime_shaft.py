"""The runtime shaft tracker: contact onset and release, the contact's kind, on a known surface."""


import numpy as np

from shaft_synthetic import AngleSurface, contact_path as _path

from whiskercal.model.shaft import ShaftParams
from whiskercal.runtime_shaft import KIND_SHAFT, KIND_TIP, KIND_UNKNOWN, ShaftTracker

TRACE_MM = 78.0


def _tracker():
    return ShaftTracker(AngleSurface(), ShaftParams(noise_uT=5.0, search_x_mm=(5.0, TRACE_MM)),
                        TRACE_MM)


def _feed(tracker, contacts, seed=0):
    rng = np.random.default_rng(seed)
    surface = AngleSurface()
    return [tracker.update(float(surface(c)) + rng.normal(0.0, 5.0), c) for c in contacts]


def test_a_shaft_contact_is_called_shaft_and_localized():
    path = _path([45.0, 0.0])
    states = _feed(_tracker(), path)
    in_contact = [s for s in states if s.contact]
    kinds = [s.kind for s in in_contact]
    assert kinds.count(KIND_SHAFT) / len(kinds) > 0.97
    assert KIND_TIP not in kinds and not any(s.tip_valid for s in states)
    assert np.hypot(*(states[-1].localizer.contact_mm - path[-1])) < 0.25


def test_release_forgets_the_contact():
    tracker = _tracker()
    _feed(tracker, _path([45.0, 0.0]))
    free = tracker.update(0.0, [0.0, 0.0])
    assert not free.contact and free.kind == KIND_UNKNOWN and free.localizer is None
    again = _feed(tracker, _path([30.0, 0.0]), seed=1)
    assert np.hypot(*(again[-1].localizer.contact_mm - _path([30.0, 0.0])[-1])) < 0.25


def test_a_contact_at_the_tip_is_not_called_shaft():
    # the contact starts 1 mm from the trace's end and slides toward the root
    # (in its first millimetre of travel the rough estimate may still call it shaft)
    states = [s for s in _feed(_tracker(), _path([TRACE_MM - 1.0, 0.0], push_mm=8.0,
                                                  slide=(-1.0, 0.0))) if s.contact]
    assert all(s.kind != KIND_SHAFT for s in states if s.localizer.travel_mm > 1.0)
    assert sum(s.kind == KIND_TIP for s in states) > 2 * len(states) / 3
    assert states[-1].tip_valid


def test_a_non_finite_sample_changes_nothing():
    tracker = _tracker()
    _feed(tracker, _path([45.0, 0.0])[:50])
    state = tracker.update(float("nan"), [45.0, -2.5])
    assert state.contact and state.localizer is None
