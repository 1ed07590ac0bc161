"""A raw grid simulated through the twin (with /truth) and the calibration ``whiskercal fit``
makes of it, shared by the report tests (built once per session)."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal.artifacts.raw_grid import Baseline, PointRecord, RawGridWriter, RawHeader
from whiskercal.testing.twin_grid import noisy_z, simulate_grid
from whiskercal.cli import cli

STATIC_Y_UT = 1160.0
FIELD_STD_UT = 5.6


def write_twin_raw(path, grid, z_uT) -> None:
    """A complete raw grid file with the twin's truth per point (mm, µT)."""
    header = RawHeader(plan_stage_mm=grid.rod_center_mm + 100.0, plan_rod_center_mm=grid.rod_center_mm,
                       config={"rig": {"rod_radius_mm": grid.rod_radius_mm}},
                       sensor_id=grid.sensor.sensor_id, rod_radius_mm=grid.rod_radius_mm)
    writer = RawGridWriter.create(path, header)
    baseline = Baseline(np.array([0.0, STATIC_Y_UT, 0.0]), np.full(3, FIELD_STD_UT), 0.0)
    writer.set_baseline("before", baseline)
    for k, center in enumerate(grid.rod_center_mm):
        field = np.array([0.0, STATIC_Y_UT + z_uT[k], 0.0])
        point = PointRecord(k, center + 100.0, center + 100.0, center, field,
                            np.full(3, FIELD_STD_UT), 30, 1.0 + k, 1.1 + k)
        truth = {"contact_mm": grid.contact_mm[k], "tip_mm": grid.tip_mm[k],
                 "kind": str(grid.kind[k]), "z_uT": grid.z_true_uT[k]}
        writer.append_point(point, truth=truth)
    writer.set_baseline("after", Baseline(baseline.field_uT, baseline.std_uT, 1.0 + len(z_uT)))
    writer.mark_complete()
    writer.close()


@pytest.fixture(scope="session")
def twin_files(tmp_path_factory):
    """(raw.h5, cal.h5) of the default twin sensor, seeded."""
    folder = tmp_path_factory.mktemp("report")
    grid = simulate_grid()
    raw, cal = folder / "raw.h5", folder / "cal.h5"
    write_twin_raw(raw, grid, noisy_z(grid, seed=3))
    # the report draws the z lookup; the (Y, Z) table would add about a minute to the session
    result = CliRunner().invoke(cli, ["fit", "--no-field-table", str(raw), "--out", str(cal)],
                                catch_exceptions=False)
    assert result.exit_code == 0, result.output
    return raw, cal


@pytest.fixture(scope="session")
def study_file(twin_files, tmp_path_factory):
    """A short flat-plane study (two depths, 10 mm slides) run on the twin through sim://."""
    folder = tmp_path_factory.mktemp("study")
    config, study = folder / "study.toml", folder / "study.h5"
    config.write_text("[trials]\ndepths_mm = [10.0, 30.0]\ntravel_mm = 10.0\n")
    result = CliRunner().invoke(cli, ["optimal-depth", "run", "--stage",
                                      "sim://report-study/stage?scene=plane", "--sensor",
                                      "sim://report-study/sensor", "--out", str(study),
                                      "--config", str(config)], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    return study
