"""mount-cal on the twin, its sensor truly off the nominal mount by a seeded error: the fit
finds the true mount within its own stated uncertainty, and the loop driven through the fitted
mount loses the size error the nominal one gives the reconstruction."""

import json
import tempfile
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from goals import MARGIN

from whiskercal.bench.mount_cal import NOMINAL, drawn_error, size_error_mm
from whiskercal.cli import cli
from whiskercal.contour import contour_record
from whiskercal.mount import Mount, read_mount, write_mount
from whiskercal.mountcal import Routine, mount_cal

pytestmark = [pytest.mark.slow, pytest.mark.timeout(900)]
SEED = 2


@pytest.fixture(scope="module")
def table_artifact():
    """The recorded default grid with its (Y, Z) table and the study's target (a minute)."""
    from whiskercal.bench.contour_target import calibrations_with_target

    return calibrations_with_target(Path(tempfile.mkdtemp(prefix="whiskercal-mountcal-")))["yz-table"]


@pytest.fixture(scope="module")
def calibrated(table_artifact):
    error = drawn_error(SEED)
    url = f"sim://cylinder?mount_error={error[0]},{error[1]},{error[2]}&seed={SEED}"
    return mount_cal(table_artifact, Routine(nominal=NOMINAL), url)


def test_the_fit_finds_the_true_mount_within_its_stated_uncertainty(calibrated):
    summary = calibrated.summary()
    truth, std = summary["truth"], summary["mount"]["std"]
    assert truth["kinds"] == ["tip"]  # every press held the tip on the cylinder
    for key in ("x_mm", "y_mm", "yaw_deg"):
        assert abs(truth["fit_error"][key]) <= MARGIN * std[key], key
    # the uncertainty says something: well inside what the drawing is off by
    assert std["x_mm"] < 1.0 and std["y_mm"] < 0.3 and std["yaw_deg"] < 0.5
    nominal_off = np.hypot(truth["nominal_error"]["x_mm"], truth["nominal_error"]["y_mm"])
    fit_off = np.hypot(truth["fit_error"]["x_mm"], truth["fit_error"]["y_mm"])
    assert fit_off < 0.5 * nominal_off
    assert abs(truth["fit_error"]["yaw_deg"]) < 0.5 * abs(truth["nominal_error"]["yaw_deg"])


def test_the_fitted_mount_removes_the_size_error(calibrated, table_artifact):
    true, fitted = calibrated.true_mount, calibrated.fit.mount
    sizes = {}
    for name, mount in (("nominal", NOMINAL), ("fitted", fitted)):
        offset = (true.x_mm - mount.x_mm, true.y_mm - mount.y_mm, true.yaw_deg - mount.yaw_deg)
        record = contour_record("cylinder", table_artifact, duration_s=25.0, seed=SEED,
                                mount=(mount, offset))
        assert record.config["mount"]["true"] == true.as_dict()  # the twin's truth records it
        sizes[name] = size_error_mm(record)
    assert abs(sizes["nominal"]) > 0.3
    assert abs(sizes["fitted"]) < 0.3 * abs(sizes["nominal"])


def test_the_command_writes_the_mount_file_and_says_how_well_it_is_known(tmp_path, table_artifact):
    nominal = tmp_path / "nominal.toml"
    write_mount(nominal, NOMINAL)
    out = tmp_path / "mount.toml"
    words = ["mount-cal", "--artifact", str(table_artifact), "--mount", str(nominal),
             "--robot", "sim://cylinder?mount_error=1.0,-0.5,1.5&seed=4", "--stations", "3",
             "--out", str(out), "--json"]
    result = CliRunner().invoke(cli, words)
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    fitted = read_mount(out)
    assert fitted == Mount(summary["mount"]["x_mm"], summary["mount"]["y_mm"],
                           summary["mount"]["yaw_deg"])
    assert "one standard deviation" in out.read_text()
    assert abs(summary["truth"]["fit_error"]["yaw_deg"]) < 0.5
    again = CliRunner().invoke(cli, words)
    assert again.exit_code != 0 and "--force" in again.stderr
