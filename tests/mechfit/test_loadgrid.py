"""Space-fixed tip loads of the forward model against the twin's plane contacts.

A plane tilted 20° with friction 0.4, sliding toward the tip, pushes the tip 1.8° past the wire's
axis; the twin holds the wire bent toward -y there (the contact the (Y, Z) table must answer).
"""

import math

import numpy as np
import pytest

from whiskercal.testing.fields import true_suspension
from whiskercal.mechfit.loadgrid import load_grid, past_axis_loads
from whiskercal.twin.params import DEFAULT_SENSOR
from whiskercal.twin.physics import mechanics


def _twin_contact(depth_fraction):
    whisker = DEFAULT_SENSOR.whisker
    plane = mechanics.plane_for_depth(whisker, depth_fraction * whisker.length_mm, 0.0,
                                      math.radians(20.0), mu_static=0.4, mu_kinetic=0.4,
                                      motion_sign=-1)
    return mechanics.solve_plane(whisker, plane)


def test_past_the_axis_the_twins_plane_contact_is_found():
    eq = _twin_contact(0.07)
    force = eq.force_n
    whisker = DEFAULT_SENSOR.whisker
    alpha = math.degrees(math.atan2(-force[0], -force[1]))
    size = np.linalg.norm(force) * whisker.length_mm ** 2 / whisker.bending_stiffness_n_mm2
    assert alpha > 90.0  # past the axis
    loads = past_axis_loads(true_suspension(DEFAULT_SENSOR), (alpha,), (size,))
    distance = np.linalg.norm(loads.tip_mm - eq.tip_mm, axis=1)
    assert distance.min() < 1e-3  # mm
    assert np.all(loads.pose[:, 0] < 0)  # every solution bent toward -y


def test_the_load_grid_starts_at_rest_and_turns_both_ways():
    grid = load_grid(true_suspension(DEFAULT_SENSOR), magnitudes=(0.1, 0.2), alphas_deg=(0, 45, 90))
    assert set(np.round(np.degrees(grid.alpha_rad))) == {0.0, 45.0, 90.0}
    assert np.all(grid.tip_mm[:, 0] < 78.0) and np.all(grid.pose[:, 0] < 0)


def test_a_model_with_no_tip_load_family_gets_a_usage_error_not_a_traceback(monkeypatch):
    """A fitted suspension whose tip loads cannot be solved at any tilt (a drawn long build's
    session met one) is refused as a usage error, which ``fit`` turns into a withheld table."""
    from types import SimpleNamespace

    from whiskercal.errors import UsageError
    from whiskercal.mechfit import tables

    def no_family(*args, **kwargs):
        raise UsageError("no tip family")

    monkeypatch.setattr(tables, "tip_family", no_family)
    fit = SimpleNamespace(suspension=None, pose_map=SimpleNamespace(coefficients=np.zeros((3, 2))))
    with pytest.raises(UsageError, match="no tip-load family at any tilt"):
        tables.table_load_points(fit, (-100.0, 0.0), space_fixed=False)


def test_the_tables_loads_solved_side_by_side_are_those_solved_in_turn(monkeypatch):
    from functools import partial

    from whiskercal.mechfit import tables, workers
    from whiskercal.mechfit.tipcurve import tip_family

    suspension = true_suspension(DEFAULT_SENSOR)
    alphas = (88.0, 90.0, 92.0, 95.0, 100.0, 105.0)
    few_sizes = partial(load_grid, magnitudes=(0.5, 1.0, 2.0))  # the test's time, not its point
    monkeypatch.setattr(tables, "PAST_AXIS_ALPHAS_DEG", alphas)
    monkeypatch.setattr(tables, "load_grid", few_sizes)
    monkeypatch.setattr(workers, "available_cpus", lambda: 2)
    families, grids = tables._solved_loads(suspension, (-20, 30), True)
    for family, beta in zip(families, (-20, 30)):
        expected = tip_family(suspension, math.radians(beta))
        np.testing.assert_array_equal(family.tip_mm, expected.tip_mm)
    np.testing.assert_array_equal(grids[0].tip_mm, few_sizes(suspension).tip_mm)
    parts = np.concatenate([g.tip_mm for g in grids[1:] if len(g.pose)])
    np.testing.assert_array_equal(parts, past_axis_loads(suspension, alphas).tip_mm)
    assert len(grids) == 1 + tables.PAST_AXIS_PARTS
