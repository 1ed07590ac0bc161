"""The follower's error estimated on a model's own presses (``followed_tip_error_mm``), on a
synthetic fan of loads whose readings and tips are known exactly (no fitted model)."""

import math

import numpy as np
import pytest

from whiskercal.mechfit import branch_surface
from whiskercal.model.load_branches import LoadBranches

DIRECTIONS = np.linspace(0.0, 1.0, 21)  # one row a degree of the real grid's ALPHAS_DEG
SIZES = np.arange(0.0, 20.001, 0.5)


def _fan(fields=None):
    """Loads (direction a, size m) read 10 m (2 - a) µT at angle a π/2, the tip at (50 + a m, m)
    mm: one-to-one, about 20 µT a millimetre of tip."""
    a, m = np.meshgrid(DIRECTIONS, SIZES, indexing="ij")
    radius, angle = 10.0 * m * (2.0 - a), a * math.pi / 2
    default = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=-1)
    tips = np.stack([50.0 + a * m, m], axis=-1)
    return (fields if fields is not None else default), tips


def _error(noise_uT, fields=None, seed=0):
    fields, tips = _fan(fields)
    branches = LoadBranches(fields, tips, (noise_uT, noise_uT), (-1000.0, 1000.0))
    return branch_surface.followed_tip_error_mm(branches, (noise_uT, noise_uT), seed=seed)


@pytest.fixture(scope="module")
def quiet():
    return _error(1.0)


def test_the_error_grows_with_the_noise_and_holding_averages_it_down(quiet):
    loud = _error(5.0)
    assert quiet["presses"] == loud["presses"] == len(DIRECTIONS[::2])
    assert quiet["lost_directions_deg"] == [] and loud["lost_directions_deg"] == []
    # one reading: the noise over the map's gain (about 0.05 mm a µT), on each axis
    assert 0.02 < quiet["estimate_mm"] < 0.3
    assert 3.0 < loud["estimate_mm"] / quiet["estimate_mm"] < 8.0
    for result in (quiet, loud):  # 30 samples averaged: well under half the one-sample error
        assert result["held_estimate_mm"] < 0.5 * result["estimate_mm"]


def test_a_press_whose_readings_cannot_tell_its_loads_apart_is_named_not_averaged(quiet):
    fields, _ = _fan()
    fields[4, 2:] = fields[4, 1]  # every size along direction 4 reads the same
    result = _error(1.0, fields)
    assert result["lost_directions_deg"] == [branch_surface.ALPHAS_DEG[4]]
    assert result["presses"] == len(DIRECTIONS[::2])
    assert result["estimate_mm"] == pytest.approx(quiet["estimate_mm"], rel=0.2)


def test_a_direction_with_too_few_loads_is_not_pressed():
    fields, _ = _fan()
    fields[3:6, 2:] = np.nan  # directions 3-5 end after their first load
    assert _error(1.0, fields)["presses"] == len(DIRECTIONS[::2]) - 1


def test_no_press_gives_no_estimate():
    fields, _ = _fan()
    fields[:, 2:] = np.nan
    result = _error(1.0, fields)
    assert result["presses"] == 0 and math.isnan(result["estimate_mm"])
    assert math.isnan(result["held_estimate_mm"])
