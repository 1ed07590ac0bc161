"""The particle filter over the first contact point, on a synthetic surface where the contact
point is known exactly (the candidate ``bench --only shaft-localizer`` charts)."""

import numpy as np

from shaft_synthetic import AngleSurface, contact_path

from whiskercal.model.shaft import REASON_SIGNAL, REASON_TRAVEL, ShaftParams
from whiskercal.model.shaft_pf import ParticleLocalizer

OFFSET_MM = np.array([123.0, -45.0])  # the object's position is known up to a constant


def _localizer(seed=0, **params):
    # likelihoods tempered well past the 5 µT sample noise: the filter's weights stay spread
    # enough for 1000 particles to keep the true point among them
    settings = {"noise_uT": 50.0, "search_x_mm": (10.0, 80.0), "max_sd_mm": 2.0, **params}
    return ParticleLocalizer(AngleSurface(), ShaftParams(**settings), particles=1000, seed=seed)


def _track(localizer, start, noise_uT=5.0, seed=0, scale=1.0):
    surface, rng = AngleSurface(), np.random.default_rng(seed)
    path = contact_path(start)
    states = [localizer.update(scale * float(surface(p)) + rng.normal(0.0, noise_uT), p + OFFSET_MM)
              for p in path]
    return path, states


def test_localizes_the_contact_point_to_half_a_millimetre_after_travel():
    for start in ([25.0, 0.0], [45.0, 0.0]):
        path, states = _track(_localizer(), start)
        late = [(p, s) for p, s in zip(path, states) if s.travel_mm > 5.0]
        assert all(s.localized for _, s in late), start
        errors = [np.hypot(*(s.contact_mm - p)) for p, s in late]
        assert np.median(errors) < 0.5, (start, np.median(errors))


def test_rough_point_follows_the_contact_and_its_spread_covers_the_error():
    localizer = _localizer()
    assert localizer.rough() is None  # no contact yet
    path, _ = _track(localizer, [45.0, 0.0])
    point, sd_mm = localizer.rough()
    assert np.hypot(*(point - path[-1])) < 3.0 * sd_mm + 0.05


def test_withholds_the_estimate_before_travel_and_on_a_weak_signal():
    path, states = _track(_localizer(), [45.0, 0.0])
    early = [s for s in states if s.travel_mm < 3.0]
    assert early and all(not s.localized and s.reason == REASON_TRAVEL for s in early)
    assert all(np.isnan(s.contact_mm).all() for s in early)
    # a signal a hundredth of the surface's: under min_signal noise levels throughout
    _, weak = _track(_localizer(), [45.0, 0.0], noise_uT=0.0, scale=0.01)
    travelled = [s for s in weak if s.travel_mm >= 3.0]
    assert travelled and all(s.reason == REASON_SIGNAL for s in travelled)


def test_seeded_and_reset_runs_repeat_exactly():
    localizer = _localizer(seed=4)
    _, first = _track(localizer, [45.0, 0.0])
    localizer.reset()
    assert localizer.rough() is None
    _, again = _track(localizer, [45.0, 0.0])
    np.testing.assert_array_equal(first[-1].contact_mm, again[-1].contact_mm)
    _, other = _track(_localizer(seed=5), [45.0, 0.0])
    assert not np.array_equal(first[-1].contact_mm, other[-1].contact_mm)
