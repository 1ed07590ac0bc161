"""`twin describe`: a build's stiffness ratio, the paper's push, the one-to-one z range, saturation."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.cli import cli
from whiskercal.study.config import load_config as load_study_config
from whiskercal.twin.describe import describe, held_sweep, saturation
from whiskercal.twin.params import DEFAULT_SENSOR
from whiskercal.twin.physics.obstacles import plane_for_depth
from whiskercal.twin.physics.plane import solve_plane
from whiskercal.twin.sensor_file import load_sensor
from whiskercal.twin.truth import static_field_uT, z_of_pose

EXAMPLES = Path(__file__).resolve().parents[2] / "sensors"


@pytest.fixture(scope="module")
def default_description():
    return describe(DEFAULT_SENSOR)


def test_default_ratio_and_ei_are_the_documented_ones(default_description):
    # docs/twin.md: EI = 14.38 N·mm²; k_θ·L/EI = 3 · 75 / 14.38.
    assert default_description.bending_stiffness_n_mm2 == pytest.approx(14.38, abs=0.005)
    assert default_description.root_ratio == pytest.approx(15.6, abs=0.05)


def test_default_push_is_the_studys_40_mm_tip_contact(default_description):
    push = default_description.push
    # docs/twin.md's sweep at 40 mm: tip (53.8, -50.5) mm, |F| 6.0 mN.
    assert push.kind == "tip" and push.depth_mm == 40.0
    np.testing.assert_allclose(push.tip_mm, (53.8, -50.5), atol=0.05)
    assert push.force_n == pytest.approx(0.0060, abs=0.00005)
    # The paper's sensor reads about -8760 µT at this target (its Fig. 5B).
    assert -9500 < push.z_uT < -8000


def test_default_one_to_one_range_holds_every_study_depth(default_description):
    one = default_description.one_to_one
    assert one.ends_at == "sweep_end" and one.z_range_uT[1] == 0.0
    whisker = DEFAULT_SENSOR.whisker
    for depth in load_study_config()["trials"]["depths_mm"]:
        eq = solve_plane(whisker, plane_for_depth(whisker, float(depth)))
        z = float(z_of_pose(DEFAULT_SENSOR, eq.root_rotation_rad, eq.root_shift_mm))
        assert one.z_range_uT[0] < z < 0.0, depth


def test_default_does_not_saturate_at_the_firmwares_settings(default_description):
    sat = default_description.saturation
    assert sat.axis is None and sat.z_uT is None and not sat.at_rest
    assert max(sat.peak_fraction) < 0.75  # as test_params checks over the grid and study


@pytest.mark.slow
def test_a_long_thin_build_bends_more_and_pushes_less():
    description = describe(load_sensor(EXAMPLES / "long-110mm.toml"))
    # EI = 75000 · π · 0.2⁴ / 64; ratio 3 · 110 / EI.
    assert description.bending_stiffness_n_mm2 == pytest.approx(5.890, abs=0.001)
    assert description.root_ratio == pytest.approx(56.0, abs=0.05)
    assert description.push.kind == "tip"
    assert 0 < description.push.force_n < 0.5 * 0.0060
    assert description.one_to_one.z_range_uT[0] < description.push.z_uT < 0


@pytest.mark.slow
def test_a_short_build_on_a_soft_root_folds_and_its_fold_is_real():
    sensor = load_sensor(EXAMPLES / "short-45mm-soft.toml")
    description = describe(sensor)
    assert description.root_ratio == pytest.approx(1.22, abs=0.01)
    one = description.one_to_one
    assert one.ends_at == "fold"
    # Past the fold, z comes back into the range: one z there belongs to two tips.
    sweep = held_sweep(sensor)
    z = z_of_pose(sensor, sweep.root_rotation_rad, sweep.root_shift_mm)
    fold = int(np.flatnonzero(sweep.tip_slope_rad == one.tip_slope_rad)[0])
    assert z[fold] == pytest.approx(one.z_range_uT[0])
    assert np.all(np.diff(z[:fold + 1]) < 0)
    assert z[fold + 1:].max() > one.z_range_uT[0]
    # The paper's 40 mm is most of this wire's length: the shaft lies on the plane.
    assert description.push.kind == "tangential"


def test_saturation_is_found_on_the_axis_that_reaches_its_range_first():
    # A chip offset of -20 mT on Y leaves 12.8 mT of room below the static reading.
    sensor = dataclasses.replace(DEFAULT_SENSOR, sensor_id="offset", magnetometer=dataclasses.replace(
        DEFAULT_SENSOR.magnetometer, offset_uT=(0.0, -20000.0, 0.0)))
    sat = saturation(sensor, held_sweep(sensor))
    # Y reads static + z + offset and rounds to the last count half a count before -32768 µT.
    expected = -32767.5 - static_field_uT(sensor)[1] + 20000.0
    assert sat.axis == "Y" and not sat.at_rest
    assert sat.z_uT == pytest.approx(expected, abs=1e-6)


def test_the_papers_high_resolution_setting_saturates_z_at_rest():
    # GAIN_SEL 7, RES 0 (0.150/0.242 µT/LSB): Z holds ±7.9 mT, the magnet gives -27 mT at rest.
    sensor = dataclasses.replace(DEFAULT_SENSOR, sensor_id="fine", magnetometer=dataclasses.replace(
        DEFAULT_SENSOR.magnetometer, gain=7, res=0))
    sat = saturation(sensor, held_sweep(sensor))
    assert (sat.axis, sat.z_uT, sat.at_rest) == ("Z", 0.0, True)


def test_cli_text_states_units_and_the_deflection_used():
    result = CliRunner().invoke(cli, ["twin", "describe", "twin-paper-75mm"], catch_exceptions=False)
    assert result.exit_code == 0
    out = result.output
    for expected in ("EI                 14.38 N·mm²", "k_θ·L/EI           15.6",
                     "the study's plane (tilted 20°, μ_s 0.30, μ_k 0.22) 40 mm past the undeflected tip",
                     "force              0.006 N", "one-to-one z range   -15274 .. 0 µT",
                     "saturation           none over the tip-contact sweep"):
        assert expected in out, out


@pytest.mark.slow
def test_cli_json_has_stable_keys_for_a_file():
    path = str(EXAMPLES / "stiff-root-75mm.toml")
    result = CliRunner().invoke(cli, ["twin", "describe", path, "--json", "--depth", "30"],
                                catch_exceptions=False)
    assert result.exit_code == 0
    data = json.loads(result.output)
    assert list(data) == ["sensor_id", "reach_mm", "bending_stiffness_n_mm2", "root_ratio_k_theta_l_over_ei",
                          "static_field_uT", "paper_deflection", "one_to_one", "saturation", "sensor"]
    assert data["sensor_id"] == "stiff-root-75mm"
    assert data["root_ratio_k_theta_l_over_ei"] == pytest.approx(62.6, abs=0.05)
    assert set(data["paper_deflection"]) == {"depth_mm", "tilt_deg", "mu_static", "mu_kinetic", "kind",
                                             "tip_mm", "force_n", "z_uT"}
    assert data["paper_deflection"]["depth_mm"] == 30.0
    assert set(data["one_to_one"]) == {"z_range_uT", "ends_at", "tip_slope_rad", "tip_mm", "swept_to_rad"}
    assert set(data["saturation"]) == {"gain", "res", "axis", "z_uT", "at_rest", "full_scale_uT",
                                       "peak_fraction"}
    assert data["sensor"]["whisker"]["root_rotational_stiffness_n_mm_per_rad"] == 12.0


def test_cli_refuses_a_bad_file_in_one_line(tmp_path):
    path = tmp_path / "lab.toml"
    path.write_text('sensor_id = "lab"\n[whisker]\nlength_mm = -3\n')
    result = CliRunner().invoke(cli, ["twin", "describe", str(path)])
    assert result.exit_code == 2
    assert result.output.strip().splitlines()[-1].endswith("[whisker] length_mm: must be a positive number of mm, not -3")
