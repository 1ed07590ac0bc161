"""The whisker's bending modes on top of its statics: frequencies against beam theory, the exact
ring-down and ramp lag of the modal response, the stage twin's field after a move, and the
``[dynamics]`` table (off by default: nothing changes)."""

import itertools
import math

import numpy as np
import pytest
from test_world_standin import FIELD_PER_RAD_UT, STATIC_FIELD_UT, RigidWhiskerPhysics

import whiskercal.rig  # noqa: F401  (registers sim://)
from whiskercal.errors import UsageError
from whiskercal.rig.sensor import SensorClient
from whiskercal.rig.stage import StageClient
from whiskercal.twin.nuisances import DynamicsTable, load_dynamics
from whiskercal.twin.physics.dynamics import Mode, RingingRoot, clamped_free_hz, modes
from whiskercal.twin.physics.whisker import WhiskerParams
from whiskercal.twin.sensor_file import load_sensor
from whiskercal.twin.world import create_world

_names = itertools.count()


def test_a_rigid_root_gives_the_clamped_free_beams_frequencies():
    rigid = WhiskerParams(root_rotational_stiffness_n_mm_per_rad=1e7,
                          root_translational_stiffness_n_per_mm=1e7)
    first, second = modes(rigid, 2)
    assert first.frequency_hz == pytest.approx(clamped_free_hz(rigid, 1), rel=1e-4)
    assert second.frequency_hz == pytest.approx(clamped_free_hz(rigid, 2), rel=1e-4)


def test_a_compliant_root_lowers_the_first_mode_toward_the_rigid_wire_on_its_spring():
    whisker = WhiskerParams()
    (first,) = modes(whisker, 1)
    assert first.frequency_hz < clamped_free_hz(whisker, 1)
    # a wire 10⁴ times stiffer turns as a rigid rod on k_θ (the shift held): √(k_θ/I), from
    # below (its own bending lowers it by about 1.6e-4, ten times inside the bound). Not 10⁶:
    # there the stiffness matrix's conditioning, not the physics, moves the eigenvalue by 1e-3
    # with the BLAS
    rod = WhiskerParams(youngs_modulus_n_per_mm2=7.5e8, root_translational_stiffness_n_per_mm=1e5)
    mu = 6450e-12 * math.pi * rod.diameter_mm ** 2 / 4
    a, length = rod.root_offset_mm, rod.length_mm
    inertia = mu * ((a + length) ** 3 - a ** 3) / 3
    expected = math.sqrt(rod.root_rotational_stiffness_n_mm_per_rad / inertia) / (2 * math.pi)
    assert expected * (1 - 1e-3) < modes(rod, 1)[0].frequency_hz < expected


def _one_mode(share=0.8, zeta=0.05, hz=20.0):
    return (Mode(frequency_hz=hz, damping_ratio=zeta, rotation_share=share, shift_share=share),)


def test_a_step_rings_down_as_the_damped_oscillator_exactly():
    mode, = found = _one_mode()
    ringing = RingingRoot(found, rotation_rad=-0.1, shift_mm=(0.0, 0.2))
    ringing.at(0.0, -0.1, (0.0, 0.2))
    step_s = 1e-4  # the input jumps to rest within a tenth of a millisecond
    times = step_s + np.arange(1, 200) / 300.0
    ringing.at(step_s, 0.0, (0.0, 0.0))
    rotations = np.array([ringing.at(t, 0.0, (0.0, 0.0))[0] for t in times])
    omega, zeta = mode.omega_rad_s, mode.damping_ratio
    damped = omega * math.sqrt(1 - zeta ** 2)
    t = times - step_s / 2  # a step smeared over step_s acts at its middle
    expected = -0.1 * 0.8 * np.exp(-zeta * omega * t) * (
        np.cos(damped * t) + zeta / math.sqrt(1 - zeta ** 2) * np.sin(damped * t))
    np.testing.assert_allclose(rotations, expected, atol=2e-3 * 0.08 * step_s * omega)


def test_a_steady_ramp_lags_by_two_zeta_v_over_omega_and_a_constant_input_not_at_all():
    mode, = found = _one_mode()
    ringing = RingingRoot(found)
    slope = 0.2  # rad/s
    for t in np.arange(1, 3001) / 300.0:
        rotation, shift = ringing.at(t, slope * t, (0.5, 0.0))
    lag = 0.8 * 2 * mode.damping_ratio * slope / mode.omega_rad_s
    assert slope * t - rotation == pytest.approx(lag, rel=1e-6)
    assert shift[0] == 0.5  # the axial shift stays quasi-static
    still = RingingRoot(found, rotation_rad=0.3)
    assert [still.at(t, 0.3, (0.0, 0.0))[0] for t in (0.1, 0.2, 5.0)] == [0.3, 0.3, 0.3]


def _rig(dynamics, physics="stand-in"):
    """A homed rig, the rod pressing the wire at x = 60 mm; ``physics=None``: the twin's own."""
    physics = RigidWhiskerPhysics() if physics == "stand-in" else physics
    world = create_world(f"dynamics-test-{next(_names)}", physics=physics, dynamics=dynamics)
    stage = StageClient(f"sim://{world.name}/stage")
    sensor = SensorClient(f"sim://{world.name}/sensor")
    stage.home()
    for point, feed in (([-30.0, 60.0], 3000), ([60.0, 5.0], 3000), ([60.0, -10.0], 3000)):
        stage.move_to(*world.stage_target_for(point), feed)
        stage.wait_idle(60, on_poll=lambda status: sensor.read_available())
    return world, stage, sensor


def _push_and_settle(dynamics):
    """The rod pushed 5 mm further at 50 mm/s, stopping at once (the stage's own acceleration
    stops it too gently to ring the wire past the noise), then 0.5 s at rest: the truth of
    the samples after the stage stopped (the quasi-static field from the truth's rotation, the
    dynamic one)."""
    world, stage, sensor = _rig(dynamics)
    world.stage.settings[120] = world.stage.settings[121] = 1e6  # mm/s²
    sensor.start()
    sensor.read(30, timeout_s=1)
    stage.move_to(*world.stage_target_for([60.0, -15.0]), 3000)
    stage.wait_idle(60, on_poll=lambda status: sensor.read_available())
    sensor.read(150, timeout_s=2)
    truth = world.truth.arrays()
    still = np.flatnonzero(np.all(np.isclose(truth["tool_mm"], truth["tool_mm"][-1], atol=1e-9), axis=1))
    after = slice(still[0], None)
    quasi = STATIC_FIELD_UT[1] + FIELD_PER_RAD_UT * truth["root_rotation_rad"][after]
    return world, truth["t_s"][after], quasi, truth["field_true_uT"][after, 1]


def test_the_stage_twin_rings_down_after_a_move_at_the_first_modes_rate():
    dynamics = DynamicsTable(modes=1, damping_ratio=0.05)
    world, t, quasi, field = _push_and_settle(dynamics)
    mode, = dynamics.modes_of(world.sensor.whisker)
    deviation = field - quasi
    assert abs(deviation[0]) > 20.0  # µT: the first samples at rest differ by several noise σ
    # at rest the deviation is the free damped oscillation: e^{-ζωt}(A cos ω_d t + B sin ω_d t)
    omega, zeta = mode.omega_rad_s, mode.damping_ratio
    damped, s = omega * math.sqrt(1 - zeta ** 2), t - t[0]
    basis = np.exp(-zeta * omega * s)[:, None] * np.column_stack([np.cos(damped * s), np.sin(damped * s)])
    coefficients, *_ = np.linalg.lstsq(basis, deviation, rcond=None)
    assert np.max(np.abs(basis @ coefficients - deviation)) < 1e-6 * np.max(np.abs(deviation))


@pytest.mark.slow  # the first use of the real physics builds its field table
def test_a_wire_that_slips_past_the_rod_rings_in_the_stage_twin():
    dynamics = DynamicsTable(modes=2)
    world, stage, sensor = _rig(dynamics, physics=None)
    reach = world.sensor.whisker.reach_mm
    sensor.start()
    for point, feed in (([reach - 1.0, 8.0], 3000), ([reach - 1.0, -20.0], 600)):
        stage.move_to(*world.stage_target_for(point), feed)  # the tip springs past the rod
        stage.wait_idle(60, on_poll=lambda status: sensor.read_available())
    sensor.read(300, timeout_s=2)
    truth = world.truth.arrays()
    released = np.flatnonzero(truth["kind"] == "free")
    released = released[released > np.flatnonzero(truth["kind"] != "free")[-1]]
    z = truth["z_true_uT"][released]  # the quasi-static z of a free wire is 0
    (first, _), period = dynamics.modes_of(world.sensor.whisker), 1.0 / 300
    assert np.max(np.abs(z[:30])) > 100.0  # µT: the release rings far past the noise
    # a second later the first mode's envelope has shrunk it by e^{-ζω·1 s}
    late = np.max(np.abs(z[300:330])) / np.max(np.abs(z[:30]))
    assert late < 2 * math.exp(-first.decay_per_s * 300 * period)
    assert world.solver_failures == 0


def test_no_modes_leave_the_stage_twin_quasi_static_bit_for_bit():
    readings = []
    for dynamics in (None, DynamicsTable()):
        world, t, quasi, field = _push_and_settle(dynamics)
        np.testing.assert_array_equal(field, quasi)
        readings.append(world.truth.arrays()["field_true_uT"])
    np.testing.assert_array_equal(*readings)


def test_a_sensor_file_carries_a_dynamics_table(tmp_path):
    path = tmp_path / "ringing.toml"
    path.write_text('sensor_id = "ringing"\n\n[dynamics]\nmodes = 2\ndamping_ratio = 0.02\n')
    assert load_sensor(path).sensor_id == "ringing"
    table = load_dynamics(path)
    assert table.modes == 2 and table.damping_ratio == 0.02 and not table.off
    assert table.density_kg_m3 == 6450.0
    path.write_text('sensor_id = "ringing"\n\n[dynamics]\nmodes = 3\n')
    with pytest.raises(UsageError, match=r"\[dynamics\] modes"):
        load_dynamics(path)
    (tmp_path / "plain.toml").write_text('sensor_id = "plain"\n')
    assert load_dynamics(tmp_path / "plain.toml").off


def _mobile_run(dynamics, steps=240):
    """The robot drives its whisker into the cylinder at 20 mm/s for 0.3 s, then stands: z."""
    from whiskercal.twin.mobile import MobileSensor
    from whiskercal.twin.outlines import outline
    from whiskercal.twin.params import DEFAULT_SENSOR

    robot = MobileSensor(DEFAULT_SENSOR, outline("cylinder"), np.array([0.0, -150.0, math.pi / 2]),
                         seed=4, dynamics=dynamics)
    robot.command(np.array([0.0, 20.0]), 0.0)
    z = []
    for index in range(steps):
        if index == 90:
            robot.command(np.zeros(2), 0.0)
        z.append(robot.step(1 / 300).z_uT)
    return np.array(z)


def test_the_mobile_twin_rings_while_it_moves_and_settles_at_rest_and_without_modes_is_unchanged():
    plain = _mobile_run(None)
    np.testing.assert_array_equal(plain, _mobile_run(DynamicsTable()))
    ringing = _mobile_run(DynamicsTable(modes=2))
    difference = np.abs(ringing - plain)  # the same seed: the same noise on both
    assert np.any(plain[:90] < -100.0)  # the whisker was pressed while the robot moved
    assert difference[:120].max() > 5.0
    assert difference[-30:].max() < 0.5 * difference[:120].max()


def test_a_sensor_file_in_a_sim_url_brings_its_dynamics(tmp_path):
    import serial

    path = tmp_path / "ringing.toml"
    path.write_text('sensor_id = "ringing"\n\n[dynamics]\nmodes = 1\n')
    port = serial.serial_for_url(f"sim://dynamics-url-{next(_names)}/stage?sensor={path}")
    assert port.world.config.dynamics.modes == 1
    plain = serial.serial_for_url(f"sim://dynamics-url-{next(_names)}/stage")
    assert plain.world.config.dynamics is None
