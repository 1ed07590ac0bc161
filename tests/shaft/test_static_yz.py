"""A static contact from Y and Z together: exact on synthetic axes whose ratio names the point."""

from types import SimpleNamespace

import numpy as np

from shaft_synthetic import AngleSurface

from whiskercal.shaftstudy.static_yz import StaticLocalizer


def _z_axis(points):
    """A second axis whose share of Y falls with the reach (the suspension's shift against its
    turn): z = y (30 / r), µT."""
    points = np.asarray(points, float)
    return AngleSurface()(points) * 30.0 / np.hypot(points[..., 0], points[..., 1])


def _grid():
    x, y = np.meshgrid(np.arange(22.0, 72.0, 3.0), np.arange(-1.0, -25.0, -3.0))
    centres = np.column_stack([x.ravel(), y.ravel()])
    centres = centres[np.degrees(np.arctan2(-centres[:, 1], centres[:, 0])) < 30.0]
    y_axis, z_axis = AngleSurface()(centres), _z_axis(centres)
    field = np.column_stack([np.zeros(len(centres)), y_axis, z_axis])
    # rod radius 0: the grid's points are the contact points themselves
    return SimpleNamespace(field_mean_uT=field, baseline_before_uT=np.zeros(3),
                           z_sem_uT=np.full(len(centres), 0.5), rod_center_mm=centres,
                           rod_radius_mm=0.0)


def test_one_noise_free_sample_names_the_contact_point():
    localizer = StaticLocalizer(_grid(), 78.0)
    for point in ([30.0, -3.0], [45.0, -6.0], [60.0, -8.0]):
        y, z = float(AngleSurface()(point)), float(_z_axis(point))
        found = localizer.locate(y, z)
        assert np.hypot(*(found - point)) < 0.2, (point, found)


def test_y_alone_cannot_but_y_and_z_can():
    """Two points with the same Y (a level set of the Y surface) differ in Z: Z decides."""
    surface, localizer = AngleSurface(), StaticLocalizer(_grid(), 78.0)
    near = np.array([30.0, -2.0])
    angle, reach = np.arctan2(2.0, 30.0), np.hypot(30.0, 2.0)
    far = 2.0 * reach * np.array([np.cos(2.0 * angle), -np.sin(2.0 * angle)])  # same θ / r
    assert abs(float(surface(near)) - float(surface(far))) < 1e-6 * abs(float(surface(near)))
    assert abs(float(_z_axis(near)) - float(_z_axis(far))) > 0.3 * abs(float(_z_axis(near)))
    for point in (near, far):
        found = localizer.locate(float(surface(point)), float(_z_axis(point)))
        assert np.hypot(*(found - point)) < 0.5, (point, found)
