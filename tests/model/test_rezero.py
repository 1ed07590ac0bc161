"""Re-zeroing a drifting rest (``model.collision.RestTracker``, ``runtime`` trackers made with
``rezero``): the rest follows a drift out of contact and the contact threshold follows it."""

from pathlib import Path

import numpy as np
import pytest

from whiskercal.model.collision import RestTracker, RezeroParams
from whiskercal.model.errors import ModelError

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "calibration-1.3.0-target.h5"


def _drifting_stream(seed: int = 0):
    """Y (µT): a session offset of +713 µT, a drift of 30 µT/min, 5.6 µT of noise, at 300 Hz
    over 60 s, with a contact of -3000 µT from 20 to 30 s; and the contact mask."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, 60, 1 / 300)
    contact = (t >= 20) & (t < 30)
    y = 713.0 + 30.0 * t / 60 + rng.normal(0.0, 5.6, t.size) - 3000.0 * contact
    return t, y, contact


def test_the_rest_tracks_a_drift_out_of_contact_and_holds_through_a_contact():
    t, y, contact = _drifting_stream()
    rest = RestTracker(RezeroParams(), axes=1)
    trace = []
    for value, touching in zip(y, contact):
        rest.observe([value], bool(touching))
        trace.append(rest.rest_uT[0])
    trace = np.array(trace)
    truth = 713.0 + 30.0 * t / 60
    # settled, and not within 4 s (4 time constants) of the contact's end, when it has to catch
    # up with the 5 µT drifted during the contact
    free = ~contact & (t > 5) & ~((t >= 30) & (t < 34))
    # an exponential average over 1 s lags a 0.5 µT/s drift by 0.5 µT; the noise adds ~0.3
    assert np.max(np.abs(trace[free] - truth[free])) < 3.0
    assert np.ptp(trace[contact]) < 1.0  # nothing learnt from the contact
    released = np.argmax(t >= 30)
    assert truth[released] - trace[released] == pytest.approx(5.0, abs=1.5)


def test_a_tracker_that_rezeroes_sees_the_contact_where_a_plain_one_sees_only_contact():
    from whiskercal import runtime

    calibration = runtime.load(FIXTURE)
    t, y, contact = _drifting_stream(1)
    plain, zeroed = calibration.tracker("clip"), calibration.tracker("clip", rezero=True)
    plain_contact = np.array([plain.update(float(v)).contact for v in y])
    states = [zeroed.update(float(v)) for v in y]
    seen = np.array([s.contact for s in states])
    assert plain_contact.mean() > 0.99  # 713 µT off its rest reads as a contact throughout
    assert np.array_equal(seen, contact)
    free = ~contact
    assert np.abs(np.mean([s.z_uT for s, f in zip(states, free) if f])) < 3.0
    assert zeroed.rest_uT[0] == pytest.approx(713.0 + 30.0, abs=3.0)


def test_a_tracker_without_rezero_is_the_tracker_it_was():
    from whiskercal import runtime

    calibration = runtime.load(FIXTURE)
    _, y, _ = _drifting_stream(2)
    y = y - 713.0
    first, second = calibration.tracker("clip"), calibration.tracker("clip", rezero=False)
    for value in y[::7]:
        a, b = first.update(float(value)), second.update(float(value))
        assert a.contact == b.contact and np.isnan(b.z_uT)
        assert (a.raw_tip_mm is None) == (b.raw_tip_mm is None)


def test_bad_rezero_settings_are_refused():
    with pytest.raises(ModelError, match="settle_samples"):
        RezeroParams(settle_samples=0)
    with pytest.raises(ModelError, match="quiet_uT"):
        RezeroParams(quiet_uT=float("nan"))
