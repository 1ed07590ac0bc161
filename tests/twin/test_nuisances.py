"""The twin's nuisances (``twin.nuisances``): each one's statistics against its parameter
(seeded), off means off, and the [nuisances] table of a sensor file."""

import math

import numpy as np
import pytest

from whiskercal.errors import UsageError
from whiskercal.twin.nuisances import (REALISTIC, ContactTable, DriftTable, Nuisances, PoseChannel,
                                       RobotTable, SensorNuisances, ViscoelasticTable,
                                       load_nuisances, nuisances_named, only)


def test_the_session_offset_has_its_level_on_every_axis_and_a_seeded_sign():
    drift = Nuisances(drift=DriftTable(session_offset_uT=(100.0, 713.0, 50.0)))
    field = np.array([10.0, -3000.0, 400.0])
    read = SensorNuisances(drift, seed=3).field_uT(field, t_s=0.0, moving=False)
    assert np.allclose(np.abs(read - field), [100.0, 713.0, 50.0])
    again = SensorNuisances(drift, seed=3).field_uT(field, 0.0, False)
    assert np.array_equal(read, again)  # seeded
    signs = {tuple(np.sign(SensorNuisances(drift, seed).session_uT)) for seed in range(20)}
    assert len(signs) > 1  # the sign changes from session to session


def test_the_temperature_ramp_scales_the_whole_field_and_the_motor_step_needs_motion():
    drift = Nuisances(drift=DriftTable(temperature_K_per_min=2.0, field_per_K=-0.0012,
                                       motor_step_uT=(15.0, -20.0, 5.0)))
    state = SensorNuisances(drift, seed=0)
    field = np.array([-9977.0, 5169.0, 16053.0])
    after_a_minute = state.field_uT(field, t_s=60.0, moving=False)
    assert np.allclose(after_a_minute, field * (1 - 0.0024))
    moving = state.field_uT(field, t_s=0.0, moving=True)
    assert np.allclose(moving - field, [15.0, -20.0, 5.0])


def test_the_creep_follows_a_standard_linear_solid_and_loops_under_a_cycle():
    visco = Nuisances(viscoelastic=ViscoelasticTable(creep_share=0.05, tau_s=3.0))
    state, dt = SensorNuisances(visco, seed=0), 1.0 / 300.0
    held = 0.08  # rad, the elastic root rotation held from t = 0
    creep = [state.creep(held, dt) for _ in range(900)]  # 3 s = tau
    assert creep[-1] == pytest.approx(0.05 * held * (1 - math.exp(-1.0)), rel=1e-9)
    for _ in range(900 * 8):
        state.creep(0.0, dt)  # released: it recovers with the same time constant
    assert abs(state.creep_rad) < 0.05 * held * 1e-3
    # a slow load and unload: the crept rotation is larger on the way down (hysteresis)
    state = SensorNuisances(visco, seed=0)
    up = [state.creep(0.1 * k / 600, dt) for k in range(600)]
    down = [state.creep(0.1 * (600 - k) / 600, dt) for k in range(600)]
    assert down[300] > up[300] + 1e-4


def test_the_surface_height_has_its_rms_and_correlation_length():
    contact = Nuisances(contact=ContactTable(roughness_rms_mm=0.12, correlation_mm=0.02))
    state = SensorNuisances(contact, seed=5)
    rng = np.random.default_rng(0)
    points = rng.uniform(-80.0, 80.0, (4000, 2))
    heights = np.array([state.height_mm(p) for p in points])
    assert np.std(heights) == pytest.approx(0.12, rel=0.1)
    step = np.array([0.02, 0.0])  # one correlation length: exp(-1/2) for a Gaussian correlation
    shifted = np.array([state.height_mm(p + step) for p in points])
    assert np.corrcoef(heights, shifted)[0, 1] == pytest.approx(math.exp(-0.5), abs=0.12)
    assert state.height_mm(points[0]) == SensorNuisances(contact, seed=5).height_mm(points[0])


def test_the_reported_pose_is_the_true_one_a_latency_earlier_with_its_noise():
    channel = PoseChannel(RobotTable(latency_s=0.05), seed=0)
    for t in np.arange(0, 451) / 300:  # up to 1.5 s: the robot reports its latest pose
        channel.record(t, np.array([8.0 * t, -2.0 * t, 0.1 * t]))
    assert np.allclose(channel.reported(1.5), [8.0 * 1.45, -2.0 * 1.45, 0.1 * 1.45])
    noisy = PoseChannel(RobotTable(pose_noise_mm=0.03, heading_noise_rad=0.0005), seed=1)
    noisy.record(0.0, np.zeros(3))
    draws = np.array([noisy.reported(0.0) for _ in range(4000)])
    assert np.std(draws, axis=0) == pytest.approx([0.03, 0.03, 0.0005], rel=0.1)


def test_each_period_lasts_its_nominal_length_plus_the_jitter():
    channel = PoseChannel(RobotTable(jitter_s=0.003), seed=2)
    periods = np.array([channel.period_s(1 / 30) for _ in range(4000)])
    assert np.mean(periods) == pytest.approx(1 / 30, abs=3e-4)
    assert np.std(periods) == pytest.approx(0.003, rel=0.1)
    assert PoseChannel(RobotTable(), seed=2).period_s(1 / 30) == 1 / 30


def test_nuisances_all_at_zero_leave_the_moving_twin_unchanged_bit_for_bit():
    from whiskercal.twin.mobile import MobileSensor
    from whiskercal.twin.outlines import outline
    from whiskercal.twin.params import DEFAULT_SENSOR

    shape = outline("cylinder")
    pose = np.array([0.0, -150.0, math.pi / 2])  # below the cylinder, pointing at it
    runs = []
    for nuisances in (None, Nuisances()):
        robot = MobileSensor(DEFAULT_SENSOR, shape, pose, seed=4, nuisances=nuisances)
        robot.command(np.array([0.0, 5.0]), 0.0)
        runs.append([(robot.step(1 / 300).z_uT, *robot.pose()) for _ in range(50)])
    assert runs[0] == runs[1]
    assert Nuisances().off and not REALISTIC.off


def test_one_nuisance_alone_and_the_named_levels():
    assert only("drift").drift == REALISTIC.drift and only("drift").robot == RobotTable()
    assert nuisances_named("off").off and nuisances_named(None).off
    assert nuisances_named("realistic") == REALISTIC
    assert nuisances_named("realistic:robot").robot == REALISTIC.robot
    with pytest.raises(UsageError, match="unknown nuisance"):
        only("gremlins")
    with pytest.raises(UsageError, match="unknown nuisances"):
        nuisances_named("lots")


def test_a_sensor_file_carries_a_checked_nuisances_table(tmp_path):
    from whiskercal.twin.sensor_file import load_sensor

    path = tmp_path / "rig.toml"
    path.write_text('sensor_id = "my-rig"\n[nuisances.drift]\nsession_offset_uT = [0, 713, 0]\n'
                    "[nuisances.robot]\nlatency_s = 0.033\n")
    assert load_sensor(path).sensor_id == "my-rig"  # the build is unchanged by the table
    read = load_nuisances(path)
    assert read.drift.session_offset_uT == (0.0, 713.0, 0.0) and read.robot.latency_s == 0.033
    path.write_text('sensor_id = "my-rig"\n[nuisances.robot]\nlatency_ms = 33\n')
    with pytest.raises(UsageError, match=r"\[nuisances.robot\] latency_ms: unknown key"):
        load_sensor(path)
    path.write_text('sensor_id = "my-rig"\n[nuisances.contact]\nmu_static = 0.1\nmu_kinetic = 0.2\n')
    with pytest.raises(UsageError, match="mu_static must be at least mu_kinetic"):
        load_nuisances(path)
