"""The (Y, Z) joint fit's own z lookup against the twin's truth: on the thin 120 mm wire with
the tip sweep (seed 1) the Y fit's lookup misses the true tips by millimetres; the joint fit's
answers most of the curve several times closer, with an estimate made of its parts."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from whiskercal.bench.tip_accuracy import FAMILY
from whiskercal.testing.fields import (NOISE_UT, ROD_RADIUS_MM, lookup_errors, simulate_fields,
                                       simulate_sweep, truth_tip_curve)
from whiskercal.mechfit.identify import calibrate_mechanics
from whiskercal.mechfit.joint_lookup import joint_z_lookup
from whiskercal.mechfit.magnetfit import fit_mechanics_magnet
from whiskercal.mechfit.tables import interpolation_error_mm
from goals import TIP_CURVE_MAX_MM, TIP_CURVE_RMSE_MM, within


@pytest.mark.slow
def test_the_thin_wires_joint_lookup_answers_the_curve_far_closer_than_y_alone():
    sensor = next(b for b in FAMILY if b.sensor_id == "thin-120x0.15")
    grid, sweep = simulate_fields(sensor, 1), simulate_sweep(sensor, 1)
    centers = np.vstack([grid.rod_center_mm, sweep.rod_center_mm])
    fields = np.vstack([grid.fields_uT, sweep.fields_uT])
    swept = np.arange(len(centers)) >= len(grid.rod_center_mm)
    length = sensor.whisker.reach_mm
    fit = fit_mechanics_magnet(centers, fields, ROD_RADIUS_MM, length, NOISE_UT, sweep=swept)
    y_range = (float(grid.fields_uT[:, 0].min()), float(grid.fields_uT[:, 0].max()))
    joint = joint_z_lookup(fit, centers, fields, NOISE_UT, ROD_RADIUS_MM, length, y_range,
                           swept)
    truth = lookup_errors(joint.lookup, *truth_tip_curve(sensor), y_range)
    y_alone = calibrate_mechanics(centers, fields[:, 0], ROD_RADIUS_MM, length, NOISE_UT[0],
                                  sweep=swept)
    y_truth = lookup_errors(y_alone.lookup, *truth_tip_curve(sensor), y_range)
    # What the method guarantees on this build: most of the curve answered, five times closer
    # than Y alone. Not that its estimate bounds the truth: this grid admits two suspensions
    # about equally well (k_theta*L/EI near the twin's and near twice it, their minima within
    # a few of chi2 and their tip curves half a millimetre apart), the fit lands in either as
    # the arithmetic's last digits fall, and an estimate made around one minimum cannot see
    # the other (docs/research/2026-12-07-two-minima.md). Estimate against truth is the
    # sensor-family bench's to measure.
    assert truth["coverage"] >= 0.75
    assert truth["rmse_mm"] < y_truth["rmse_mm"] / 5
    assert joint.estimated_tip_error_mm < math.inf
    assert joint.estimated_tip_error_mm == pytest.approx(math.hypot(
        max(joint.local_mm, joint.profile_mm), interpolation_error_mm(fit, joint.lookup)))


class _FixedResidual:
    """A stand-in joint objective leaving ``residual`` anywhere, without a stage offset."""

    offset_axes = ()

    def __init__(self, residual):
        self.residual = residual

    def __call__(self, params):
        return self.residual


def test_a_fit_that_leaves_more_than_the_noise_or_leans_on_the_stage_gets_no_estimate(
        monkeypatch):
    # the thin wire's seed 2, fitted at chi2/dof 1.18 (k_theta*L/EI 172 against 77), erred
    # 1.56 mm under a 0.13 mm estimate; its seed 1 under one BLAS kernel stopped with the stage
    # offset at its bound, 1.4 mm off under a 0.10 mm estimate: neither gets an estimate, and
    # the lookup cannot be adopted
    from whiskercal.mechfit import joint_lookup

    monkeypatch.setattr(joint_lookup, "_lookup", lambda *args: "lookup")
    monkeypatch.setattr(joint_lookup, "with_interpolation_error", lambda estimate, *a: estimate)
    n = 400  # readings: 200 contacts, Y and Z
    cases = {"explained": (1.05, 0.0), "misfit": (1.18, 0.0), "at the bound": (1.05, -0.1)}
    results = {}
    for name, (level, offset_x_mm) in cases.items():
        residual = np.full(n, np.sqrt(level * (n - 14) / n))
        monkeypatch.setattr(joint_lookup, "joint_objective",
                            lambda *a, r=residual: _FixedResidual(r))
        monkeypatch.setattr(joint_lookup, "linearized_tip_change_mm", lambda *a: 0.01)
        fit = SimpleNamespace(pose_map=SimpleNamespace(orders=(1, 2, 3, 4)),
                              starts=[{"params": np.zeros(10),
                                       "stage_offset_mm": [offset_x_mm, 0.0]}])
        results[name] = joint_lookup.joint_z_lookup(fit, np.zeros((n // 2, 2)),
                                                    np.zeros((n // 2, 2)), (1.0, 1.6), 0.6,
                                                    78.0, (-100.0, -1.0))
    assert results["explained"].estimated_tip_error_mm == 0.01
    for refused in ("misfit", "at the bound"):
        assert math.isinf(results[refused].estimated_tip_error_mm)
        assert all(math.isnan(v) for v in results[refused].metrics().values())
