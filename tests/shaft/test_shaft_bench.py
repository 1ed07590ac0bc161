"""``whiskercal bench --quick --only shaft-localizer``: rows, chart and the default's accuracy."""

import json

import pytest
from click.testing import CliRunner

from whiskercal.cli import cli


@pytest.mark.slow
def test_the_shaft_localizer_comparison(tmp_path):
    result = CliRunner().invoke(cli, ["bench", "--quick", "--only", "shaft-localizer", "--out",
                                      str(tmp_path)], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    measured = json.loads((tmp_path / "shaft-localizer.json").read_text())
    rows = {row["label"]: row for row in measured["rows"]}
    default = rows["batch-gn-96 shaft surface"]
    assert default["default"]
    # against the twin's true contact point: trials at 40 % and 70 % of the trace within the
    # goal's 0.5 mm, the trial at 20 % (outside the grid) within its 1 mm
    assert default["median_error_mm"] < 0.5
    assert len(default["root_error_mm"]) == 1 and default["root_error_mm"][0] < 1.0
    # keeps up with the sensor's 300 Hz stream; the 1 ms goal is the bench's to report, as
    # CPU speed moves it
    assert 0.0 < default["ms_per_sample"] < 1000.0 / 300.0
    assert (tmp_path / "shaft-localizer.png").read_bytes().startswith(b"\x89PNG")
