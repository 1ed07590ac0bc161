"""The shaft localizer on synthetic surfaces where the contact point is known exactly."""

import time
from pathlib import Path

import numpy as np

from shaft_synthetic import AngleSurface, contact_path as _path

from whiskercal.model.shaft import REASON_SIGNAL, REASON_TRAVEL, ShaftLocalizer, ShaftParams


def _run(start, noise_uT=5.0, seed=0, **path_kw):
    surface = AngleSurface()
    localizer = ShaftLocalizer(surface, ShaftParams(noise_uT=noise_uT, search_x_mm=(10.0, 80.0)))
    rng = np.random.default_rng(seed)
    path = _path(start, **path_kw)
    object_offset = np.array([123.0, -45.0])  # the object's position is known up to a constant
    states = []
    for contact in path:
        z = float(surface(contact)) + rng.normal(0.0, noise_uT)
        states.append(localizer.update(z, contact + object_offset))
    return path, states


def test_recovers_the_contact_point_within_a_quarter_millimetre():
    for start in ([25.0, 0.0], [45.0, 0.0], [70.0, 0.0]):
        path, states = _run(start)
        late = [np.hypot(*(s.contact_mm - p)) for p, s in zip(path, states) if s.travel_mm > 5.0]
        assert all(s.localized for s in states if s.travel_mm > 5.0)
        assert np.median(late) < 0.25, (start, np.median(late))


def test_uncertainty_covers_the_error():
    path, states = _run([50.0, 0.0], noise_uT=20.0, seed=3)
    final = states[-1]
    error = np.abs(final.contact_mm - path[-1])
    assert np.all(error < 4.0 * final.sd_mm + 0.02), (error, final.sd_mm)


def test_withholds_an_estimate_before_enough_travel():
    _, states = _run([40.0, 0.0])
    assert not states[0].localized
    assert states[3].reason in (REASON_TRAVEL, REASON_SIGNAL)
    assert all(np.isnan(s.contact_mm).all() for s in states if not s.localized)


def test_withholds_an_estimate_when_z_stays_in_the_noise():
    surface = AngleSurface()
    localizer = ShaftLocalizer(surface, ShaftParams(noise_uT=5.0))
    rng = np.random.default_rng(1)
    for k in range(200):
        state = localizer.update(float(rng.normal(0.0, 5.0)), [0.05 * k, 0.0])
    assert not state.localized and state.reason == REASON_SIGNAL


def test_costs_well_under_a_millisecond_per_sample():
    path = _path([40.0, 0.0], push_mm=5.0, slide=(-20.0, 0.0))
    surface = AngleSurface()
    localizer = ShaftLocalizer(surface, ShaftParams(noise_uT=5.0))
    z = surface(path)
    start = time.process_time()  # CPU time: what the sample costs, whatever else runs
    for point, value in zip(path, z):
        localizer.update(float(value), point)
    per_sample_s = (time.process_time() - start) / len(path)
    assert per_sample_s < 1e-3, per_sample_s


def test_the_shipped_shaft_study_fixture_reads():
    from pathlib import Path

    from whiskercal.artifacts.shaft_study import read_shaft_study

    study = read_shaft_study(Path(__file__).parents[1] / "fixtures" / "shaft_study-1.0.0.h5")
    assert study.complete and [t.name for t in study.trials] == ["r039.0mm_a00deg"]
    trial = study.trials[0]
    assert trial.stream["z_uT"].shape == trial.stream["t_s"].shape
    assert trial.truth["contact_mm"].shape == (len(trial.stream["t_s"]), 2)
