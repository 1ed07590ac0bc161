"""The tip sweep in the mechanics fit: solved as the rig reaches it, and what it buys (seed 0).

Measured on the twin (docs/calibration.md): with the sweep, the 110 mm build's tip curve comes
out within 0.25 mm RMS, where its grid alone does not pin the suspension down.
"""

import math
from dataclasses import replace

import numpy as np
import pytest

from whiskercal.bench import sensor_family
from whiskercal.bench.tip_accuracy import FAMILY
from whiskercal.testing.fields import (ROD_RADIUS_MM, simulate_fields, simulate_sweep,
                                       true_suspension, truth_tip_curve)
from whiskercal.testing.twin_grid import tip_error_mm
from whiskercal.mechfit.fit import _Objective
from whiskercal.mechfit.forward import pose_of, rod_equilibria
from whiskercal.mechfit.identify import _Problem, calibrate_mechanics
from whiskercal.twin.params import DEFAULT_SENSOR
from goals import TIP_CURVE_MAX_MM, TIP_CURVE_RMSE_MM, within

# the default build's tip sweep point at -20 deg on the trace length: a tip contact
AT_TIP = 78.0 * np.array([[math.cos(math.radians(-20.0)), math.sin(math.radians(-20.0))]])


def test_a_warm_start_can_land_a_tip_contact_on_another_equilibrium():
    own = true_suspension(DEFAULT_SENSOR)
    other = replace(own, rot_compliance=1.3 * own.rot_compliance)
    cold = rod_equilibria(own, AT_TIP, ROD_RADIUS_MM)[0]
    warm = rod_equilibria(own, AT_TIP, ROD_RADIUS_MM,
                          rod_equilibria(other, AT_TIP, ROD_RADIUS_MM))[0]
    assert cold.kind == "tip"
    assert np.abs(pose_of(warm) - pose_of(cold)).max() > 0.01  # the hazard the fit avoids


def test_the_fit_solves_sweep_points_along_the_approach_whatever_it_tried_before():
    own = true_suspension(DEFAULT_SENSOR)
    objective = _Objective(78.0, AT_TIP, ROD_RADIUS_MM, np.zeros((1, 1)), np.ones(1), 1,
                           fresh=[True])
    theta_own = np.array([math.log(own.rot_compliance), math.log(own.trans_compliance), 0.0])
    theta_own[2] = math.log((own.stub_mm / 15.6) / (1.0 - own.stub_mm / 15.6))
    other = theta_own + np.array([math.log(1.3), 0.0, 0.0])
    objective.solve(other)
    _, poses, in_contact = objective.solve(theta_own)
    cold = rod_equilibria(own, AT_TIP, ROD_RADIUS_MM)[0]
    assert in_contact.all()
    np.testing.assert_allclose(poses[0], pose_of(cold), atol=1e-9)


@pytest.mark.slow
def test_the_sweep_pins_down_a_build_its_grid_does_not():
    sensor = next(s for s in FAMILY if s.sensor_id == "long-110x0.20")
    grid, sweep = simulate_fields(sensor, 0), simulate_sweep(sensor, 0)
    centers = np.vstack([grid.rod_center_mm, sweep.rod_center_mm])
    z = np.concatenate([grid.fields_uT[:, 0], sweep.fields_uT[:, 0]])
    mask = np.arange(len(z)) >= len(grid.rod_center_mm)
    model = calibrate_mechanics(centers, z, ROD_RADIUS_MM, sensor.whisker.reach_mm, 1.0,
                                sweep=mask)
    z_true, tips_true = truth_tip_curve(sensor)
    inside = (z_true >= model.lookup.z_min_uT) & (z_true <= model.lookup.z_max_uT)
    error = tip_error_mm(model.lookup(z_true[inside]), tips_true[inside])
    assert within(error["rmse_mm"], TIP_CURVE_RMSE_MM) and within(error["max_mm"], TIP_CURVE_MAX_MM)
    assert model.sweep_points == mask.sum() >= 10
    assert math.isfinite(model.estimated_tip_error_mm)


def test_the_pose_map_grows_in_degree_first_then_in_the_shifts_order():
    problem = _Problem(AT_TIP, np.zeros(1), ROD_RADIUS_MM, 78.0, 1.0, (-1.0, 0.0))
    ladder = []
    while problem is not None:
        ladder.append((problem.degree, problem.shift_order, problem.terms()))
        problem = problem.richer()
    assert ladder == [(3, 2, 15), (4, 2, 21), (4, 3, 29), (4, 4, 34)]


@pytest.mark.slow
def test_a_root_that_shifts_across_most_of_the_gap_is_fitted_and_ships_with_the_sweep():
    # the stiff 60 mm wire: its root shifts by most of the magnet's gap, where a pose map
    # quadratic in the shift leaves many times the noise and the level set would ship instead
    sensor = next(s for s in sensor_family.FAMILY if s.sensor_id == "stiff-wire-60x0.40")
    row = sensor_family.measure(sensor, tip_sweep=True)
    assert row["tip_model"] == "mechanics" and not row["warned"]
    assert within(row["tip_curve"]["rmse_mm"], TIP_CURVE_RMSE_MM)
    assert within(row["tip_curve"]["max_mm"], TIP_CURVE_MAX_MM)
    assert row["tip_curve"]["coverage"] == 1.0
    assert within(row["estimated_tip_error_mm"], TIP_CURVE_RMSE_MM)
