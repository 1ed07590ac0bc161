"""The shaft localizer's own surface: radial patches blended smoothly, stored in the artifact,
and the localizer on it where the contact point is known exactly."""

from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from shaft_synthetic import AngleSurface, contact_path

from whiskercal.artifacts import shaft_surface as group
from whiskercal.artifacts.calibration import SCHEMA_VERSION, read_calibration, surface_of
from whiskercal.fit.shaft_surface import fit_shaft_surface
from whiskercal.model.grid_contacts import degree_for
from whiskercal.model.patched_surface import PatchedSurface
from whiskercal.model.shaft import ShaftLocalizer, ShaftParams
from whiskercal.model.surface import fit_fixed
from whiskercal.runtime_shaft import shaft_surface_of

FIXTURES = Path(__file__).parents[1] / "fixtures"


def _band_points(low, high, seed=0):
    """Contact points (mm) spread over a radial band and down to 30° below the whisker."""
    rng = np.random.default_rng(seed)
    r, theta = rng.uniform(low, high, 600), rng.uniform(np.radians(-30.0), 0.0, 600)
    return np.column_stack([r * np.cos(theta), r * np.sin(theta)])


@pytest.fixture(scope="module")
def patched():
    """AngleSurface fitted in three bands meeting at 30 and 60 mm (degree 6 each)."""
    truth = AngleSurface()
    patches = []
    for low, high in ((8.0, 34.0), (26.0, 64.0), (56.0, 82.0)):
        points = _band_points(low, high)
        patches.append(fit_fixed(points, truth(points), 6)[0])
    return PatchedSurface(patches, [30.0, 60.0], 4.0)


def test_value_and_gradient_are_continuous_and_consistent(patched):
    rng = np.random.default_rng(1)
    points = _band_points(10.0, 80.0, seed=2)
    points = np.vstack([points, [[28.0, -1.0], [30.0, -3.0], [32.0, -2.0], [61.9, -5.0]]])
    h = 1e-5
    numeric = np.stack([(patched(points + [h, 0.0]) - patched(points - [h, 0.0])) / (2 * h),
                        (patched(points + [0.0, h]) - patched(points - [0.0, h])) / (2 * h)], -1)
    np.testing.assert_allclose(patched.gradient(points), numeric, rtol=1e-5, atol=1e-3)
    # no step across an edge: value at r = edge ± 1 µm differs by no more than the slope allows
    for edge in (30.0, 60.0):
        angle = rng.uniform(-0.4, 0.0)
        inner = (edge - 1e-3) * np.array([np.cos(angle), np.sin(angle)])
        outer = (edge + 1e-3) * np.array([np.cos(angle), np.sin(angle)])
        assert abs(patched(outer) - patched(inner)) < 2e-3 * 1e3


def test_one_patch_alone_is_that_patch(patched):
    points = np.array([[45.0, -4.0], [50.0, -9.0]])
    single = PatchedSurface([patched.patches[1]], np.zeros(0))
    np.testing.assert_array_equal(single(points), patched.patches[1](points))
    # inside a patch, far from every blend, the patched surface is exactly that patch
    np.testing.assert_array_equal(patched(points), patched.patches[1](points))


def test_localizes_across_the_patches_within_a_quarter_millimetre(patched):
    truth = AngleSurface()
    localizer = ShaftLocalizer(patched, ShaftParams(noise_uT=5.0, search_x_mm=(10.0, 80.0)))
    rng = np.random.default_rng(4)
    for start in ([20.0, 0.0], [31.0, 0.0], [58.0, 0.0], [74.0, 0.0]):
        localizer.reset()
        slide = (10.0, 0.0) if start[0] < 40 else (-10.0, 0.0)
        path = contact_path(start, slide=slide)
        late = []
        for contact in path:
            state = localizer.update(float(truth(contact)) + rng.normal(0.0, 5.0), contact)
            if state.travel_mm > 5.0:
                assert state.localized, (start, state.reason)
                late.append(np.hypot(*(state.contact_mm - contact)))
        assert np.median(late) < 0.25, (start, np.median(late))


def test_round_trip_through_the_artifact(tmp_path, patched):
    fixture = read_calibration(FIXTURES / "calibration-1.2.0-extrapolated.h5")
    assert fixture.shaft_surface is None  # an artifact from before 1.4 has none
    data = replace(fixture, shaft_surface=group.data_of(patched, 2.5, "grid+mechanics", 7))
    from whiskercal.artifacts.calibration import write_calibration

    back = read_calibration(write_calibration(tmp_path / "cal.h5", data))
    assert back.schema_version == SCHEMA_VERSION  # written as the current version
    assert (back.shaft_surface.rmse_uT, back.shaft_surface.source) == (2.5, "grid+mechanics")
    probe = _band_points(10.0, 80.0, seed=5)
    loaded, misfit, _ = shaft_surface_of(SimpleNamespace(data=back))
    np.testing.assert_array_equal(loaded(probe), patched(probe))
    assert misfit == 2.5
    # without the group the localizer falls back to the tip model's surface and its RMSE
    old, old_misfit, _ = shaft_surface_of(SimpleNamespace(data=fixture))
    np.testing.assert_array_equal(old(probe), surface_of(fixture)(probe))
    assert old_misfit == fixture.metrics["rmse_uT"]


def test_grid_only_surface_without_mechanics():
    truth = AngleSurface()
    centres = _band_points(22.0, 72.0, seed=6)[:180]
    z = truth(centres)
    fitted = fit_shaft_surface(centres, z, np.full(len(z), 1.0), 0.0, 78.0, mechanics=None)
    assert fitted.source == "grid" and len(fitted.surface.patches) == 1
    assert fitted.rmse_uT < 0.05 * np.std(z)
    assert degree_for(180, 8) == 8 and degree_for(60, 8) == 6 and degree_for(5, 8) == 1
