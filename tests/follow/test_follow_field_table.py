"""The follower feeds the chip's Z axis to its tracker: a calibration with a (Y, Z) table places
the contact from both axes, an older one from z alone; the moving-base twin streams Z and the
run records it."""

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from whiskercal import runtime
from whiskercal.artifacts.calibration import read_calibration, write_calibration
from whiskercal.artifacts.contour_run import ContourRunFile, read_contour_run, write_contour_run
from whiskercal.follow import FollowConfig, Follower
from whiskercal.twin.mobile import MobileSensor
from whiskercal.twin.outlines import Outline
from whiskercal.twin.params import DEFAULT_SENSOR

FIXTURE = Path(__file__).parents[1] / "fixtures" / "calibration-1.0.0.h5"
POSE = np.array([10.0, 5.0, 0.3])  # mm, mm, rad


class StillRobot:
    """A robot that stays at POSE (the commands are not what these tests look at)."""

    def pose(self) -> np.ndarray:
        return POSE.copy()

    def command(self, velocity_mm_s, turn_rad_s: float) -> None:
        pass


def _table(data):
    """A table whose tip depends on Z (mm per µT) so that reading it is visible."""
    y = np.linspace(data.lookup_z_uT[0], data.lookup_z_uT[-1], 11)
    z = np.linspace(-200.0, 200.0, 9)
    yy, zz = np.meshgrid(y, z, indexing="ij")
    return {"y_uT": y, "axial_uT": z, "tip_mm": np.stack([78.0 + 0.001 * yy, 0.002 * yy + 0.01 * zz], axis=-1)}


@pytest.fixture(scope="module")
def with_table(tmp_path_factory):
    data = read_calibration(FIXTURE)
    path = tmp_path_factory.mktemp("follow-ft") / "cal-table.h5"
    write_calibration(path, replace(data, field_table=_table(data)))
    return path


def _world(tip_mm) -> np.ndarray:
    c, s = math.cos(POSE[2]), math.sin(POSE[2])
    return np.array([[c, -s], [s, c]]) @ np.asarray(tip_mm) + POSE[:2]


def _first_contact(artifact, axial_uT):
    calibration = runtime.load(artifact)
    z = float(np.mean(calibration.z_range_uT))
    follower = Follower(calibration.tracker(out_of_range="clip"), z, FollowConfig())
    return calibration, z, follower.update(z, StillRobot(), axial_uT)


def test_with_a_table_the_contact_comes_from_both_axes(with_table):
    calibration, z, step = _first_contact(with_table, -60.0)
    table_tip = [78.0 + 0.001 * z, 0.002 * z - 0.6]  # the table's tip at (z, -60 µT)
    np.testing.assert_allclose(step.contact_mm, _world(table_tip), atol=1e-9)
    assert np.linalg.norm(step.contact_mm - _world(calibration.tip(z))) > 0.1  # not the z lookup's


def test_without_the_z_axis_or_without_a_table_the_contact_comes_from_z(with_table):
    calibration, z, step = _first_contact(with_table, None)
    np.testing.assert_allclose(step.contact_mm, _world(calibration.tip(z)), atol=1e-9)
    calibration, z, step = _first_contact(FIXTURE, -60.0)  # an artifact without a table
    np.testing.assert_allclose(step.contact_mm, _world(calibration.tip(z)), atol=1e-9)


def test_the_mobile_twin_streams_the_z_axis_from_rest_with_its_noise():
    far = Outline("far", np.array([[500.0, 500.0]]), 10.0)  # never reached: the whisker is free
    robot = MobileSensor(DEFAULT_SENSOR, far, [0.0, 0.0, 0.0], seed=4)
    axial = np.array([robot.step(0.01).axial_uT for _ in range(300)])
    noise = DEFAULT_SENSOR.magnetometer.noise_uT_rms[2]
    assert abs(axial.mean()) < 4 * noise / math.sqrt(axial.size)  # µT: from the reading at rest
    assert 0.8 * noise < axial.std() < 1.2 * noise


def test_pressing_a_wall_moves_the_z_axis():
    wall = Outline("wall", np.array([[0.0, 0.0], [800.0, 0.0], [800.0, 800.0], [0.0, 800.0]]) - 400.0,
                   0.001)  # its bottom face is a straight wall at y = -400 mm
    heading = math.pi / 2 - math.radians(20.0)
    tip = np.array([-200.0, -400.0]) + 4.0 * np.array([math.cos(heading), math.sin(heading)])
    base = tip - DEFAULT_SENSOR.whisker.reach_mm * np.array([math.cos(heading), math.sin(heading)])
    sample = MobileSensor(DEFAULT_SENSOR, wall, [*base, heading], seed=4).step(0.0)
    assert sample.kind != "free"
    noise = DEFAULT_SENSOR.magnetometer.noise_uT_rms[2]
    assert abs(sample.axial_uT) > 10 * noise  # a deflection the Z axis sees far above its noise


def test_a_run_file_records_the_z_axis_and_an_older_one_still_reads(tmp_path):
    columns = {"t_s": np.arange(3.0), "z_uT": np.full(3, -5000.0), "axial_uT": np.array([1.0, 2.0, 3.0]),
               "estimate_mm": np.zeros((3, 2)), "true_tip_mm": np.zeros((3, 2)),
               "true_contact_mm": np.zeros((3, 2)), "pose": np.zeros((3, 3)), "slip": np.zeros(3, bool),
               "phase": np.array(["follow"] * 3), "kind": np.array(["tip"] * 3), "control_s": np.zeros(3)}
    run = ContourRunFile("cylinder", np.zeros((1, 2)), 80.0, -5000.0, 1, True, 1.0, "s", columns, {})
    write_contour_run(tmp_path / "new.h5", run)
    np.testing.assert_array_equal(read_contour_run(tmp_path / "new.h5").columns["axial_uT"], [1.0, 2.0, 3.0])
    del columns["axial_uT"]
    write_contour_run(tmp_path / "old.h5", run)
    assert "axial_uT" not in read_contour_run(tmp_path / "old.h5").columns
