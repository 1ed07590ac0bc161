"""MLX90393 facts: the datasheet's numbers, and the host and the twin agree on them."""

import numpy as np
import pytest

from whiskercal.protocol import mlx90393 as host
from whiskercal.twin.physics import magnetometer as twin


def test_sensitivity_protocol_defaults():
    # docs/protocol.md: gain 7, res 0 is 0.150 / 0.242 µT/LSB; res 2 is 0.600 on X/Y
    np.testing.assert_allclose(host.lsb_uT(7, 0), [0.150, 0.150, 0.242])
    assert host.lsb_uT(7, 2)[1] == pytest.approx(0.600)


@pytest.mark.parametrize("gain", range(8))
@pytest.mark.parametrize("res", range(4))
def test_host_and_twin_use_the_same_sensitivity(gain, res):
    np.testing.assert_allclose(host.lsb_uT(gain, res), twin.lsb_uT(gain, res))


@pytest.mark.parametrize("filt", range(8))
@pytest.mark.parametrize("osr", range(4))
def test_host_and_twin_use_the_same_conversion_time(osr, filt):
    assert host.conversion_time_ms(osr, filt) == twin.conversion_time_ms(osr, filt)


def test_300_hz_admits_the_documented_settings():
    # reference/README.md: 300 Hz fits DF0/OSR0-1, DF1/OSR0-1, DF2/OSR0, DF3/OSR0
    fits = {(f, o) for f in range(8) for o in range(4) if host.sample_time_ms(o, f) <= 1000 / 300}
    assert fits == {(0, 0), (0, 1), (1, 0), (1, 1), (2, 0), (3, 0)}
