"""Fixtures shared across the test directories."""

import os

import pytest


@pytest.fixture(scope="session")
def default_sensor_joint_fit():
    """The default twin sensor's grid simulated with seed 0 and the (Y, Z) joint fit to it, once
    per test process: the magnet-map, table-trust and study tests read the same fit (half a
    minute each)."""
    from whiskercal.mechfit.magnetfit import fit_mechanics_magnet
    from whiskercal.testing.fields import NOISE_UT, ROD_RADIUS_MM, simulate_fields
    from whiskercal.twin.params import DEFAULT_SENSOR

    grid = simulate_fields(DEFAULT_SENSOR, seed=0)
    fit = fit_mechanics_magnet(grid.rod_center_mm, grid.fields_uT, ROD_RADIUS_MM,
                               DEFAULT_SENSOR.whisker.reach_mm, NOISE_UT)
    return grid, fit


@pytest.fixture(scope="session", autouse=True)
def _files_shared_by_the_run(tmp_path_factory):
    """The folder of tests/run_shared.py: under pytest-xdist the base temporary folder's parent,
    which every worker of the run shares; this process's own otherwise."""
    from run_shared import share_in

    base = tmp_path_factory.getbasetemp()
    share_in((base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / "shared")
