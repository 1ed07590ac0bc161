"""rig.machine_space: every layout of grbl 1.1's machine space (gnea/grbl limits_go_home and
system_check_travel_limits) mapped onto whiskercal's stage coordinates."""

import numpy as np
import pytest

from whiskercal.errors import DeviceError
from whiskercal.rig.machine_space import machine_space

SETTINGS = {20: 1, 22: 1, 27: 1.0, 100: 80.0, 101: 80.0, 130: 200.0, 131: 150.0}


def _space(dir_mask: int, homed_mm=None, overrides=None):
    return machine_space({**SETTINGS, 23: dir_mask, **(overrides or {})}, homed_mm)


def test_stock_homing_toward_the_minimum_puts_stage_zero_where_homing_ends():
    space = _space(3, homed_mm=[-199.0, -149.0])
    assert space.layout.startswith("stock")
    np.testing.assert_allclose(space.origin_mm, [-199.0, -149.0])
    np.testing.assert_allclose([space.low_mm, space.high_mm], [[-200.0, -150.0], [0.0, 0.0]])
    assert space.travel_mm == (199.0, 149.0)
    np.testing.assert_allclose(space.to_machine([10.0, 20.0]), [-189.0, -129.0])
    np.testing.assert_allclose(space.to_stage([-189.0, -129.0, 0.0]), [10.0, 20.0])


def test_stock_homing_toward_the_maximum_puts_stage_zero_at_the_far_end_of_the_workspace():
    space = _space(0, homed_mm=[-1.0, -1.0])  # the switches at 0, pulled off by $27
    np.testing.assert_allclose(space.origin_mm, [-200.0, -150.0])
    assert space.travel_mm == (200.0, 150.0)


def test_force_set_origin_builds_are_told_by_the_homed_position():
    toward_min = _space(3, homed_mm=[0.0, 0.0])
    assert toward_min.layout.startswith("HOMING_FORCE_SET_ORIGIN")
    np.testing.assert_allclose(toward_min.origin_mm, [0.0, 0.0])
    np.testing.assert_allclose([toward_min.low_mm, toward_min.high_mm], [[0, 0], [200, 150]])
    mixed = _space(1, homed_mm=[0.0, 0.0])  # X toward its minimum, Y toward its maximum
    np.testing.assert_allclose(mixed.origin_mm, [0.0, -150.0])
    np.testing.assert_allclose([mixed.low_mm, mixed.high_mm], [[0, -150], [200, 0]])


def test_before_homing_the_stock_layout_is_assumed_and_its_travel_is_the_smaller():
    assert _space(3).layout.startswith("stock") and _space(3).travel_mm == (199.0, 149.0)
    here_positive = machine_space({**SETTINGS, 23: 3}, here_mm=[20.0, 0.0])
    assert here_positive.layout.startswith("HOMING_FORCE_SET_ORIGIN")


def test_homing_off_keeps_the_power_up_position_as_the_stage_origin():
    space = _space(3, overrides={22: 0, 20: 0})
    np.testing.assert_allclose(space.origin_mm, [0.0, 0.0])
    assert space.travel_mm == (200.0, 150.0)


def test_a_homed_position_that_fits_no_layout_is_refused():
    with pytest.raises(DeviceError, match=r"fits neither stock grbl 1\.1 .*\[-199\.0, -149\.0\]"):
        _space(3, homed_mm=[-5.0, -149.0])


def test_targets_outside_the_workspace_are_refused_before_they_are_sent():
    space = _space(3, homed_mm=[-199.0, -149.0])
    space.check(space.to_machine([199.0, 149.0]), "here")  # the far corner is inside
    with pytest.raises(DeviceError, match=r"stage target \(199\.500, 10\.000\) mm .* not sent"):
        space.check(space.to_machine([199.5, 10.0]), "here")
    with pytest.raises(DeviceError, match="outside the board's workspace"):
        space.check(space.to_machine([-1.5, 10.0]), "here")  # past the switch
