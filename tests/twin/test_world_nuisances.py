"""The stage rig's nuisances (``sim://``): the reading's drift and the suspension's creep act on
the field the board reads; off, nothing changes bit for bit; the contact's and the robot's
nuisances, which a stage rig does not have, are refused in one line."""

import itertools

import numpy as np
import pytest
import serial
from test_world_standin import FIELD_PER_RAD_UT, STATIC_FIELD_UT, RigidWhiskerPhysics

import whiskercal.rig  # noqa: F401  (registers sim://)
from whiskercal.errors import UsageError
from whiskercal.rig.sensor import SensorClient
from whiskercal.rig.stage import StageClient
from whiskercal.twin.nuisances import (REALISTIC, DriftTable, Nuisances, ViscoelasticTable, only,
                                       stage_rig_part)
from whiskercal.twin.world import create_world

_names = itertools.count()


def _pressed_and_held(nuisances, hold_samples=900):
    """A homed stand-in rig, the rod pressing the wire at x = 60 mm, then held still for
    ``hold_samples`` samples (3 s at 300 Hz): the world and the truth of the held samples."""
    world = create_world(f"nuisance-test-{next(_names)}", physics=RigidWhiskerPhysics(),
                         nuisances=nuisances, seed=5)
    stage, sensor = StageClient(f"sim://{world.name}/stage"), SensorClient(f"sim://{world.name}/sensor")
    stage.home()
    sensor.start()
    for point in ([-30.0, 60.0], [60.0, 5.0], [60.0, -10.0]):
        stage.move_to(*world.stage_target_for(point), 3000)
        stage.wait_idle(60, on_poll=lambda status: sensor.read_available())
    sensor.read(hold_samples, timeout_s=10)
    truth = world.truth.arrays()
    held = np.flatnonzero(np.all(np.isclose(truth["tool_mm"], truth["tool_mm"][-1], atol=1e-9), axis=1))
    return world, {key: value[held] for key, value in truth.items()}


def _quasi_static_uT(truth) -> np.ndarray:
    """The stand-in's ideal Y field at the truth's (elastic) root rotation, µT."""
    return STATIC_FIELD_UT[1] + FIELD_PER_RAD_UT * truth["root_rotation_rad"]


def test_no_nuisances_leave_the_stage_rig_as_it_was_bit_for_bit():
    fields = [_pressed_and_held(level, 30)[1]["field_true_uT"] for level in (None, Nuisances())]
    np.testing.assert_array_equal(*fields)


def test_a_session_offset_moves_every_reading_by_its_size_with_a_seeded_sign():
    offset = (500.0, 300.0, 100.0)  # µT
    world, truth = _pressed_and_held(Nuisances(drift=DriftTable(session_offset_uT=offset)), 30)
    moved = truth["field_true_uT"][:, 1] - _quasi_static_uT(truth)
    np.testing.assert_allclose(np.abs(moved), offset[1], atol=1e-9)


def test_a_held_push_creeps_toward_its_share_with_the_time_constant():
    share, tau_s = 0.05, 1.0
    world, truth = _pressed_and_held(Nuisances(viscoelastic=ViscoelasticTable(creep_share=share, tau_s=tau_s)))
    crept = (truth["field_true_uT"][:, 1] - _quasi_static_uT(truth)) / FIELD_PER_RAD_UT  # rad
    elastic = truth["root_rotation_rad"][-1]
    t = truth["t_s"] - truth["t_s"][0]
    # the standard linear solid held still: the creep closes on share·rotation as e^{-t/tau}
    remaining = share * elastic - crept
    assert abs(crept[-1]) > 0.9 * share * abs(elastic)  # 3 time constants held
    late = t > 0.5
    np.testing.assert_allclose(remaining[late], remaining[late][0] * np.exp(-(t[late] - t[late][0]) / tau_s),
                               atol=1e-3 * share * abs(elastic))


def test_the_stage_rig_refuses_the_contact_and_robot_nuisances_in_one_line():
    for name in ("contact", "robot"):
        with pytest.raises(UsageError, match=r"stage rig .*drift.*viscoelastic"):
            create_world(f"nuisance-refused-{next(_names)}", nuisances=only(name))
        with pytest.raises(UsageError, match=f"nuisances=realistic:{name}"):
            serial.serial_for_url(f"sim://nuisance-url-{next(_names)}/stage?nuisances=realistic:{name}")


def test_realistic_in_a_sim_url_is_the_drift_and_creep_at_their_realistic_levels(tmp_path):
    port = serial.serial_for_url(f"sim://nuisance-url-{next(_names)}/stage?nuisances=realistic")
    assert port.world.config.nuisances == stage_rig_part(REALISTIC)
    assert port.world.config.nuisances.drift == REALISTIC.drift
    assert port.world.config.nuisances.robot == Nuisances().robot
    path = tmp_path / "drifting.toml"
    path.write_text('sensor_id = "drifting"\n\n[nuisances.drift]\nsession_offset_uT = [0, 700, 0]\n'
                    '\n[nuisances.robot]\nlatency_s = 0.03\n')
    port = serial.serial_for_url(f"sim://nuisance-url-{next(_names)}/stage?sensor={path}")
    # a sensor file's robot table is contour run's: the stage rig takes its drift and creep
    assert port.world.config.nuisances.drift.session_offset_uT == (0.0, 700.0, 0.0)
    assert port.world.config.nuisances.robot == Nuisances().robot
