"""The branch follower: a contact's readings followed from rest tell apart loads that one
reading cannot (loads fanning out from rest that wrap round past a full turn)."""

import math

import numpy as np
import pytest

from whiskercal.model.load_branches import FITS_SIGMAS, LoadBranches

DIRECTIONS = np.round(np.arange(0.0, 1.0001, 0.05), 3)
SIZES = np.arange(0.0, 30.001, 0.25)


def _fan() -> LoadBranches:
    """Loads (direction a, size m) at radius m(2 - a), angle a(π/2 + m/5) (µT, unit noise), the
    tip at (50 + a·m, m) mm: one-to-one near rest, but past size 24 the last directions wrap round
    onto the first ones' smaller loads (no fold: the map's Jacobian never vanishes)."""
    a, m = np.meshgrid(DIRECTIONS, SIZES, indexing="ij")
    return LoadBranches(_reading(a, m), _tip(a, m), (1.0, 1.0), (-100.0, 100.0))


def _tip(a, m):
    a, m = np.broadcast_arrays(np.asarray(a, float), np.asarray(m, float))
    return np.stack([50.0 + a * m, m], axis=-1)  # at rest every direction's tip is the same


def _reading(a, m):
    radius, angle = m * (2.0 - a), a * (math.pi / 2 + m / 5.0)
    return np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=-1)


def _press(branches: LoadBranches, row: int, to_size: float, seed: int = 0) -> np.ndarray:
    """The follower's tip after pressing along ``row`` from rest to ``to_size``, readings with
    0.3 µT of seeded noise."""
    rng = np.random.default_rng(seed)
    follower = branches.follower()
    tip = None
    for m in np.arange(0.1, to_size + 1e-9, 0.1):
        y, z = _reading(DIRECTIONS[row], m) + rng.normal(0, 0.3, 2)
        tip = follower.tip_scalar(float(y), float(z))
    return np.array(tip)


def test_a_wrapped_load_reads_like_a_smaller_one():
    branches = _fan()
    far = _reading(1.0, 25.0)
    distance = np.linalg.norm(branches.fields_uT - far, axis=-1)
    distance[-1] = np.inf  # not the load itself
    row, size = np.unravel_index(np.nanargmin(distance), distance.shape)
    assert distance[row, size] < FITS_SIGMAS and row <= 2 and SIZES[size] < 15.0


def test_each_press_is_followed_to_its_own_load():
    branches = _fan()
    assert np.linalg.norm(_press(branches, len(DIRECTIONS) - 1, 25.0) - _tip(1.0, 25.0)) < 0.5
    assert np.linalg.norm(_press(branches, 1, 13.0) - _tip(DIRECTIONS[1], 13.0)) < 0.5


def test_one_reading_alone_cannot_tell_them_apart():
    y, z = _reading(1.0, 25.0)
    fresh = np.array(_fan().follower().tip_scalar(float(y), float(z)))
    # a contact that starts here takes the smallest load that explains it, another direction's
    assert np.linalg.norm(fresh - _tip(1.0, 25.0)) > 5.0


def test_no_tip_outside_the_range_or_beyond_every_load():
    branches = _fan()
    follower = branches.follower()
    assert math.isnan(follower.tip_scalar(150.0, 0.0)[0])   # Y outside the range
    assert math.isnan(follower.tip_scalar(99.0, -99.0)[0])  # no load within reach
    assert math.isnan(follower.tip_scalar(1.0, math.nan)[0])
    assert follower.held is None


def test_reset_starts_a_new_contact():
    branches = _fan()
    follower = branches.follower()
    follower.tip_scalar(5.0, 0.5)
    assert follower.held is not None
    follower.reset()
    assert follower.held is None


@pytest.mark.parametrize("row", [0, 10, 20])
def test_presses_are_followed_in_every_direction(row):
    tip = _press(_fan(), row, 25.0, seed=row)
    assert np.linalg.norm(tip - _tip(DIRECTIONS[row], 25.0)) < 0.5
