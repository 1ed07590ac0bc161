"""The mechanics-informed tip model against the twin's truth (seeded grids, tolerances from goals).

The accuracy goals are issue 13's: on the frictionless tip curve over the grid's z range,
0.15 mm RMS on the default sensor and 0.25 mm RMS / 0.5 mm max on any build of the family.
Measured with seed 0 (docs/calibration.md): 0.010 / 0.041 mm on the default sensor,
0.053 / 0.081 mm on the default build with a root 4x stiffer.
"""

import math
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from whiskercal.artifacts.raw_grid import read_raw_grid
from whiskercal.bench.tip_accuracy import FAMILY
from whiskercal.testing.fields import (NOISE_UT, ROD_RADIUS_MM, pose_fields_of_poses,
                                       simulate_fields, true_suspension, truth_tip_curve)
from whiskercal.testing.twin_grid import tip_error_mm
from whiskercal.errors import UsageError
from whiskercal.mechfit.fieldmap import exponents, fit_pose_map
from whiskercal.mechfit.fit import fit_mechanics
from whiskercal.mechfit.forward import Suspension, pose_of, rod_equilibria
from whiskercal.mechfit import tables
from whiskercal.mechfit.tables import FieldTipTable, monotone_z_range, z_lookup
from whiskercal.mechfit.tipcurve import tip_family
from whiskercal.model.calibrate import contact_mask
from whiskercal.twin import truth
from whiskercal.twin.params import DEFAULT_SENSOR
from whiskercal.twin.physics.whisker import WhiskerParams
from goals import DEFAULT_SENSOR_RMSE_MM, TIP_CURVE_MAX_MM, TIP_CURVE_RMSE_MM, within


DATA = Path(__file__).resolve().parents[2] / "data"


def test_the_forward_tip_family_reproduces_the_twins_tip_curve():
    family = tip_family(true_suspension(DEFAULT_SENSOR))
    sweep = truth.tip_contact_sweep(DEFAULT_SENSOR.whisker, 161)
    slopes = sweep.tip_slope_rad[:150]
    tips = np.column_stack([np.interp(-slopes, -family.tip_slope_rad, family.tip_mm[:, k])
                            for k in range(2)])
    # linear interpolation between 0.0125 rad samples accounts for the ~1e-3 mm left
    assert np.abs(tips - sweep.tip_mm[:150]).max() < 5e-3


def test_the_pose_map_recovers_a_polynomial_in_its_span():
    rng = np.random.default_rng(0)
    poses = rng.uniform(-1, 1, (60, 3)) * [0.2, 0.1, 0.1]
    exps = exponents()
    truth_coefficients = rng.normal(0, 100, len(exps))
    fields = np.prod((poses / np.abs(poses).max(0))[:, None, :] ** exps, axis=-1) @ truth_coefficients
    pose_map, residual = fit_pose_map(poses, fields)
    assert np.abs(residual).max() < 1e-8
    assert pose_map(np.zeros(3)) == pytest.approx(0.0)


def test_the_pose_maps_misfit_does_not_move_with_the_poses_last_digits():
    # a grid's poses lie on a two-parameter surface, where some monomial combinations nearly
    # vanish; the misfit must not hang on them (docs/calibration.md, one minimum on every machine)
    raw = read_raw_grid(DATA / "twin-short-60mm" / "raw_grid.h5")
    used = contact_mask(raw.z_uT, raw.z_sem_uT)
    suspension = Suspension(63.0, 3.0, 1 / 25.0, 5e-4)
    poses = np.array([pose_of(e) for e in rod_equilibria(suspension, raw.rod_center_mm[used],
                                                          raw.rod_radius_mm)])
    _, residual = fit_pose_map(poses, raw.z_uT[used])
    chi2 = np.sum(residual ** 2)
    rng = np.random.default_rng(0)
    for _ in range(5):
        nudged = poses * (1.0 + 1e-12 * rng.standard_normal(poses.shape))
        _, moved = fit_pose_map(nudged, raw.z_uT[used])
        # a plain least squares moves it by 1e-6 to 5e-6 here; the ridge by under 2e-8
        assert abs(np.sum(moved ** 2) / chi2 - 1.0) < 1e-7


def test_the_field_table_is_exact_on_a_bilinear_function_and_nan_outside():
    y, z = np.linspace(-100, 0, 11), np.linspace(-50, 50, 21)
    yy, zz = np.meshgrid(y, z, indexing="ij")
    table = FieldTipTable(y, z, np.stack([yy + 2 * zz, yy * zz], axis=-1))
    assert table.tip_scalar(-33.0, 7.5) == pytest.approx((-33.0 + 15.0, -33.0 * 7.5))
    assert all(math.isnan(v) for v in table.tip_scalar(10.0, 0.0))


def test_a_suspension_refuses_non_physical_values():
    with pytest.raises(UsageError):
        Suspension(78.0, 3.0, -0.1, 1e-3)
    with pytest.raises(UsageError):
        Suspension(78.0, 50.0, 0.1, 1e-3)


def test_a_tip_loads_slope_is_its_end_states_and_its_parameters_are_its_own():
    from whiskercal.mechfit.forward import tip_load, tip_load_and_angle
    from whiskercal.twin.physics import elastica as el

    suspension = Suspension(78.0, 3.0, 0.1, 1e-3)
    force = np.array([-0.4, -1.2])  # EI/L²
    pose, tip, moment, angle = tip_load_and_angle(suspension, force, 0.0)
    p = suspension.params()
    p[el.P_FX], p[el.P_FY] = force
    assert angle == el.end_state(el.CANTILEVER, np.array([moment]), p, el.DEFAULT_STEPS)[2]
    assert all(np.array_equal(a, b) for a, b in zip(tip_load(suspension, force, 0.0),
                                                   (pose, tip, moment)))
    # the vector handed out is a copy: a caller setting its force leaves the next one clean
    assert suspension.params()[el.P_FX] == 0.0


def test_monotone_range_stops_where_z_turns_back():
    assert monotone_z_range(np.array([0.0, -1.0, -3.0, -2.0, -5.0])) == (-3.0, 0.0)


def _tip_curve_error(sensor):
    grid = simulate_fields(sensor, seed=0)
    fit = fit_mechanics(grid.rod_center_mm, grid.fields_uT[:, 0], ROD_RADIUS_MM,
                        sensor.whisker.reach_mm, NOISE_UT[0])
    z_range = (grid.fields_uT[:, 0].min(), grid.fields_uT[:, 0].max())
    lookup = z_lookup(fit, z_range)
    z, tips = truth_tip_curve(sensor)
    inside = (z >= lookup.z_min_uT) & (z <= lookup.z_max_uT)
    covered = ((z >= z_range[0]) & (z <= z_range[1])).sum()
    return tip_error_mm(lookup(z[inside]), tips[inside]), inside.sum() / covered, fit


@pytest.mark.slow
def test_the_default_sensor_meets_its_tip_goal():
    error, coverage, fit = _tip_curve_error(DEFAULT_SENSOR)
    assert coverage == 1.0
    assert within(error["rmse_mm"], DEFAULT_SENSOR_RMSE_MM) and within(error["max_mm"], TIP_CURVE_MAX_MM)
    # the residual sits at the reading noise (1 µT), so nothing is left unexplained
    assert fit.rms_uT[0] < 1.1 * NOISE_UT[0]


@pytest.mark.slow
def test_a_build_with_a_four_times_stiffer_root_meets_the_family_goal():
    stiff = next(s for s in FAMILY if s.sensor_id == "default-stiff-root")
    error, coverage, _ = _tip_curve_error(stiff)
    assert coverage == 1.0
    assert within(error["rmse_mm"], TIP_CURVE_RMSE_MM) and within(error["max_mm"], TIP_CURVE_MAX_MM)


@pytest.mark.parametrize("theta", [(-3.0, -8.0, -1000.0), (-3.0, -8.0, 1000.0),
                                   (900.0, -900.0, 0.0)])
def test_any_trial_parameters_give_a_representable_suspension(theta):
    # a profile's least squares may try a stub's logit or a compliance's log far out: no overflow
    from whiskercal.mechfit.fit import MAX_STUB_FRACTION, _Objective

    objective = _Objective(78.0, np.zeros((1, 2)), 0.5, np.zeros((1, 1)), np.ones(1), 3)
    suspension = objective.suspension(np.array(theta))
    assert 0.0 <= suspension.stub_mm <= 78.0 * MAX_STUB_FRACTION
    assert np.isfinite([suspension.rot_compliance, suspension.trans_compliance]).all()


def _soft_root_build():
    # a 100 mm x 0.30 mm wire on a root half the default's stiffness against turning: its
    # frictionless tip curve folds back at about -14.3 mT, inside the range a grid reaches
    return replace(DEFAULT_SENSOR, sensor_id="soft-root-100x0.30",
                   whisker=WhiskerParams(length_mm=100.0, diameter_mm=0.30,
                                         root_rotational_stiffness_n_mm_per_rad=1.5))


def _exact_model(sensor):
    """A stand-in fit with the twin's own suspension and field: only the lookup is tested."""
    return SimpleNamespace(suspension=true_suspension(sensor),
                           pose_map=lambda poses: pose_fields_of_poses(sensor, poses))


@pytest.mark.parametrize("follow", [True, False])
def test_the_z_lookup_ends_short_of_a_fold_its_knots_cannot_follow(follow, monkeypatch):
    if not follow:  # the check off: the knots cut across the fold's bend
        monkeypatch.setattr(tables, "FOLLOW_TOLERANCE_MM", math.inf)
    sensor = _soft_root_build()
    z, tips = truth_tip_curve(sensor)
    lookup = z_lookup(_exact_model(sensor), (-15000.0, -500.0))
    inside = (z >= lookup.z_min_uT) & (z <= lookup.z_max_uT)
    error = tip_error_mm(lookup(z[inside]), tips[inside])
    if follow:
        # the fold is at the curve's lowest z; the lookup keeps most of the range before it
        assert z.min() < lookup.z_min_uT < 0.8 * z.min()
        # + the forward tip family's own 5e-3 mm from the twin's curve (the first test)
        assert error["max_mm"] <= tables.FOLLOW_TOLERANCE_MM + 0.01
    else:
        assert error["max_mm"] > 0.5
