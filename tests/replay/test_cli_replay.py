"""``whiskercal replay``: files written, units, the summary, the rest options and clear errors."""

import json
import re

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from replay_session import REST_UT
from whiskercal.cli import cli

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def log(synthetic, tmp_path_factory):
    path = tmp_path_factory.mktemp("replay-log") / "octagon-like.tsv"
    table = np.column_stack([synthetic["t_s"], synthetic["reading_uT"]])
    np.savetxt(path, table, fmt="%.4f", delimiter="\t", header="time\tmagnetic_y", comments="")
    return path


def _run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.mark.slow
def test_replay_writes_track_plot_and_summary(log, artifact, tmp_path):
    result = _run("replay", log, "--artifact", artifact, "--out", tmp_path / "out", "--json")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary["samples"] == 40_000 and summary["out_of_range_below"] > 1000
    assert summary["rest_source"].startswith("median of the first 100")
    assert abs(summary["rest_uT"] - REST_UT) < 3.0
    out = tmp_path / "out"
    assert json.loads((out / "summary.json").read_text())["samples"] == 40_000
    assert (out / "replay.png").read_bytes().startswith(PNG_SIGNATURE)
    header = (out / "track.csv").read_text().splitlines()[0]
    assert header == ("t_s,z_uT,contact,raw_x_mm,raw_y_mm,filtered_x_mm,filtered_y_mm,"
                      "out_of_range,extrapolated,axial_uT,world_x_mm,world_y_mm,base_x_mm,"
                      "base_y_mm,base_heading_rad")
    with h5py.File(out / "track.h5") as handle:
        track = handle["track"]
        units = {name: track[name].attrs["units"] for name in track}
        assert units["t_s"] == "s" and units["z_uT"] == "µT" and units["raw_x_mm"] == "mm"
        assert units["filtered_y_mm"] == "mm" and units["out_of_range"] == "1"
        assert int(np.count_nonzero(track["out_of_range"][()] < 0)) == \
            summary["out_of_range_below"]
    assert not list(out.glob(".*"))  # no temporary file left behind


def test_text_summary_and_given_rest(log, artifact, tmp_path):
    result = _run("replay", log, "--artifact", artifact, "--out", tmp_path, "--rest-uT", REST_UT)
    assert result.exit_code == 0, result.output
    assert "out of range" in result.output and "µs per sample" in result.output
    assert f"rest {REST_UT:.1f} µT (given)" in result.output


@pytest.mark.parametrize("args, message", [
    (["--rest", "auto", "--rest-uT", "1"], "either --rest or --rest-uT"),
    (["--rest", "recorded"], "records no static reading"),
    (["--out-of-range", "raise"], r"sample \d+ \(t = "),
    (["--field-column", "nope"], "no column 'nope'"),
    (["--rest-samples", "40000", "--rest", "auto"], "does not start at rest"),
])
def test_errors_are_one_line_and_non_zero(log, artifact, tmp_path, args, message):
    result = _run("replay", log, "--artifact", artifact, "--out", tmp_path, *args)
    assert result.exit_code != 0
    assert re.search(message, result.output), result.output
    assert len(result.output.strip().splitlines()) == 1
    assert "Traceback" not in result.output


def test_an_input_in_the_output_folder_is_not_overwritten(artifact, tmp_path):
    log = tmp_path / "track.csv"
    log.write_text("t_s,y_uT\n" + "".join(f"{k / 100},{1160 + (k % 3)}\n" for k in range(300)))
    before = log.read_bytes()
    result = _run("replay", log, "--artifact", artifact, "--out", tmp_path)
    assert result.exit_code != 0 and "is an input of this replay" in result.output
    assert log.read_bytes() == before


def test_a_free_stream_warns_that_nothing_touched(artifact, tmp_path):
    log = tmp_path / "free.csv"
    log.write_text("t_s,y_uT\n" + "".join(f"{k / 100},{1160 + (k % 3)}\n" for k in range(300)))
    result = _run("replay", log, "--artifact", artifact, "--out", tmp_path / "out", "--json")
    assert result.exit_code == 0
    assert any("no sample was in contact" in w for w in
               json.loads((tmp_path / "out" / "summary.json").read_text())["warnings"])
