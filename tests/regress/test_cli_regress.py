"""`whiskercal regress`: passes on the recorded data, names what moved, rewrites on purpose."""

import json
import shutil
from pathlib import Path

import h5py
import pytest
from click.testing import CliRunner

from whiskercal.cli import cli

DATA = Path(__file__).resolve().parents[2] / "data"
SHORT = "twin-short-60mm"


def _regress(*args):
    return CliRunner().invoke(cli, ["regress", *map(str, args)], catch_exceptions=False)


@pytest.fixture
def short_copy(tmp_path):
    """A temporary copy of the smaller recorded dataset (the repository's copy stays untouched),
    its golden file without the default fit's check: these tests are about naming and
    rewriting, which the level set's pipeline shows alone (tests/regress/test_default_fit.py
    has the default fit's)."""
    shutil.copytree(DATA / SHORT, tmp_path / SHORT)
    golden_path = tmp_path / SHORT / "golden.json"
    document = json.loads(golden_path.read_text(encoding="utf-8"))
    document["pipeline"].pop("default_fit_args", None)
    document["quantities"] = {name: entry for name, entry in document["quantities"].items()
                              if not name.startswith("default.")}
    golden_path.write_text(json.dumps(document), encoding="utf-8")
    return tmp_path


@pytest.mark.slow
def test_regress_passes_on_the_recorded_data():
    # What CI runs: every stage recomputed on data/, the default fit of each dataset included.
    result = _regress(DATA, "--json")
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["ok"] is True
    assert [d["dataset"] for d in report["datasets"]] == ["twin-long-110mm", "twin-paper-75mm", SHORT]
    assert all(d["changes"] == [] and d["quantities"] > 100 for d in report["datasets"])


@pytest.mark.slow
def test_an_edited_golden_value_is_named_with_how_far_it_moved(short_copy):
    golden_path = short_copy / SHORT / "golden.json"
    document = json.loads(golden_path.read_text(encoding="utf-8"))
    entry = document["quantities"]["study.trial[20mm].filtered_mean_mm"]
    entry["value"] += 0.01
    golden_path.write_text(json.dumps(document), encoding="utf-8")
    result = _regress(short_copy)
    assert result.exit_code == 1
    assert "1 moved" in result.output
    assert "study.trial[20mm].filtered_mean_mm:" in result.output
    assert "moved -0.01 (allowed 1e-06" in result.output
    assert "1 quantity moved beyond tolerance: twin-short-60mm:study.trial[20mm].filtered_mean_mm" \
        in result.stderr


@pytest.mark.slow  # the update adds the default fit's check, and the last run recomputes it
def test_perturbed_recordings_fail_naming_fit_and_study_quantities_then_update_round_trips(short_copy):
    with h5py.File(short_copy / SHORT / "raw_grid.h5", "r+") as raw:
        field = raw["points/field_mean_uT"]
        values = field[()]
        # ten grid points read 5 µT more deflection (Y axis): enough to move every fit quantity,
        # little enough that the default fit still identifies the suspension (a 30 µT push
        # leaves it 8x the noise unexplained, and the default fit refuses the grid, as it should)
        values[40:50, 1] += 5.0
        field[...] = values
    with h5py.File(short_copy / SHORT / "plane_study.h5", "r+") as study:
        trial = study["trials/depth_20.00mm/stream/field_uT"]
        values = trial[()]
        values[:, 1] -= 40.0  # the whole 20 mm trial reads 40 µT more deflection
        trial[...] = values
    result = _regress(short_copy, "--json")
    assert result.exit_code == 1
    changes = {c["name"]: c for c in json.loads(result.stdout)["datasets"][0]["changes"]}
    assert "fit.rmse_uT" in changes and changes["fit.rmse_uT"]["difference"] != 0
    assert changes["study.trial[20mm].median_z_uT"]["difference"] == pytest.approx(-40.0, abs=1.0)
    assert json.loads(result.stdout)["datasets"][0]["inputs_changed"] == ["plane_study.h5",
                                                                          "raw_grid.h5"]
    updated = _regress(short_copy, "--update")
    assert updated.exit_code == 0
    assert "golden.json rewritten" in updated.output and "fit.rmse_uT" in updated.output
    again = _regress(short_copy)
    assert again.exit_code == 0 and "all within tolerance" in again.output


def test_a_missing_dataset_file_ends_with_one_clear_line(short_copy):
    (short_copy / SHORT / "plane_study.h5").unlink()
    result = _regress(short_copy)
    assert result.exit_code == 4
    assert result.stderr.strip() == (f"error: {SHORT}: missing plane_study.h5 in "
                                     f"{short_copy / SHORT}")


def test_a_missing_data_directory_is_a_usage_error(tmp_path):
    result = _regress(tmp_path / "nowhere")
    assert result.exit_code == 2
    assert "no such directory" in result.stderr


@pytest.mark.parametrize("fit_args, message", [
    (["--samples", "1"], "whiskercal fit --samples 1:"),
    (["--degree", "9"], "whiskercal fit failed:"),
])
def test_a_stage_that_fails_on_a_dataset_is_named(short_copy, fit_args, message):
    golden_path = short_copy / SHORT / "golden.json"
    document = json.loads(golden_path.read_text(encoding="utf-8"))
    document["pipeline"]["fit_args"] = fit_args
    golden_path.write_text(json.dumps(document), encoding="utf-8")
    result = _regress(short_copy)
    assert result.exit_code == 1
    assert result.stderr.startswith(f"error: {SHORT}: {message}")
    assert len(result.stderr.strip().splitlines()) == 1
