"""Reading streams: text tables (delimiters, columns, bad cells) and whiskercal's HDF5 files."""

from pathlib import Path

import numpy as np
import pytest

from whiskercal.errors import ArtifactError, UsageError
from whiskercal.replay import read_stream, read_table

DATASET = Path(__file__).parents[2] / "data" / "twin-paper-75mm"


def _write(tmp_path, text, name="log.csv", encoding="utf-8"):
    path = tmp_path / name
    path.write_text(text, encoding=encoding)
    return path


@pytest.mark.parametrize("text", [
    "t_s,y_uT\n0,1160\n0.5,-3000\n",
    "t_s\ty_uT\n0\t1160\n0.5\t-3000\n",
    "t_s;y_uT\n0;1160\n0.5;-3000\n",
    "t_s   y_uT\n0  1160\n  0.5 -3000\n",
    "# a comment\n\nt_s,y_uT\n0,1160\n\n# another\n0.5,-3000\r\n",
    "\ufefft_s,y_uT\n0,1160\n0.5,-3000\n",
    "Time,Magnetic_Y,x\n0,1160,7\n0.5,-3000,8\n",
])
def test_delimiters_comments_and_default_columns(tmp_path, text):
    stream = read_stream(_write(tmp_path, text))
    np.testing.assert_array_equal(stream.t_s, [0.0, 0.5])
    np.testing.assert_array_equal(stream.field_uT, [1160.0, -3000.0])
    assert stream.recorded_rest_uT is None


def test_chosen_columns_quoted_cells_and_time_unit(tmp_path):
    path = _write(tmp_path, 'stamp,"magnetic_x","magnetic_y"\n1000,"5","1160.5"\n2000,"6","-1"\n')
    stream = read_table(path, time_column="stamp", field_column="magnetic_y", time_unit="ms")
    np.testing.assert_array_equal(stream.t_s, [1.0, 2.0])
    np.testing.assert_array_equal(stream.field_uT, [1160.5, -1.0])


@pytest.mark.parametrize("text, options, message", [
    ("", {}, "no header line"),
    ("# only\n\n", {}, "no header line"),
    ("t_s,y_uT\n", {}, "no samples"),
    ("single\n1\n", {}, "single column"),
    ("t_s,b_uT\n0,1\n", {}, r"no field column \(looked for .*\) in the header \(columns: t_s, b_uT\)"),
    ("t_s,y_uT\n0,1\n", {"field_column": "z"}, r"no column 'z'.*--field-column"),
    ("t_s,y_uT\n0,1\n1,2,3\n", {}, "line 3 has 3 fields, the header 2"),
    ("t_s,y_uT\n0,1\n1,abc\n", {}, r"line 3, column 'y_uT': 'abc' is not a number"),
    ("t_s,y_uT\n0,1\n1,\n", {}, r"line 3, column 'y_uT': '' is not a number"),
    ("t_s,y_uT\n0,nan\n", {}, r"line 2, column 'y_uT': 'nan' is not a finite number"),
    ("t_s,y_uT\ninf,1\n", {}, r"line 2, column 't_s': 'inf' is not a finite number"),
    ("t_s,y_uT\n1,1\n0.5,1\n", {}, r"line 3, column 't_s': time goes back"),
    ("t_s,y_uT\n0,1\n", {"delimiter": "::"}, "delimiter must be one character"),
    ("t_s,y_uT\n0,1\n", {"time_unit": "h"}, "time unit must be one of"),
])
def test_bad_tables_give_one_line_naming_file_line_and_column(tmp_path, text, options, message):
    path = _write(tmp_path, text)
    with pytest.raises(UsageError, match=message) as raised:
        read_stream(path, **options)
    assert "\n" not in str(raised.value)


def test_binary_and_missing_files(tmp_path):
    binary = tmp_path / "log.bin"
    binary.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(UsageError, match="not a text table"):
        read_stream(binary)
    with pytest.raises(UsageError, match="cannot read the stream"):
        read_stream(tmp_path / "missing.csv")


def test_hdf5_streams_carry_their_recorded_rest():
    grid = read_stream(DATASET / "raw_grid.h5")
    study = read_stream(DATASET / "plane_study.h5")
    for stream in (grid, study):
        assert len(stream) > 10_000
        assert np.all(np.diff(stream.t_s) >= 0)
        # the twin's static Y reading, as the reference's octagon session (about 1160 µT)
        assert 1000.0 < stream.recorded_rest_uT < 1300.0
        assert abs(np.median(stream.field_uT[:50]) - stream.recorded_rest_uT) < 30.0


def test_hdf5_of_another_schema_is_refused(tmp_path):
    with pytest.raises(ArtifactError, match="holds no stream to replay"):
        read_stream(Path(__file__).parents[1] / "fixtures" / "calibration-1.0.0.h5")
