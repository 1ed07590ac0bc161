"""Recordings in: the look-alikes of the seed authors' logs, tables with and without a header,
echo logs of both ROS versions, the time and unit checks, and what is not a regular file."""

import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from whiskercal.errors import UsageError
from whiskercal.recording import (RecordingOptions, TableOptions, check_rate, read_poses,
                                  read_recording)

FIXTURES = Path(__file__).parents[1] / "fixtures" / "recordings"


def test_the_authors_style_echo_log_reads_as_three_axes_in_uT():
    recording = read_recording(FIXTURES / "echo-three-axis.yaml")
    assert recording.axes == 3 and len(recording) == 360
    # the fixture's invented rest (X, Y, Z) = (-9000, 5100, 16000) µT, noise 4 µT
    np.testing.assert_allclose(np.median(recording.field_uT[:100], axis=0),
                               [-9000.0, 5100.0, 16000.0], atol=5.0)
    assert recording.t_s[0] == pytest.approx(1_700_000_000.25, abs=1e-6)
    assert check_rate(recording.t_s, 300.0, "log") == pytest.approx(166.7, rel=1e-3)


def test_the_authors_style_headerless_log_takes_no_sample_as_a_header():
    recording = read_recording(FIXTURES / "headerless-y.txt")
    assert recording.axes == 1 and len(recording) == 360  # every line is a sample
    assert abs(np.median(recording.y_uT[:100]) - 1150.0) < 5.0
    assert "column 1" in recording.source


def _write(tmp_path, text, name="log.csv"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_headerless_layouts_by_count_and_by_columns(tmp_path):
    four = read_recording(_write(tmp_path, "0,1,2,3\n0.01,4,5,6\n"))
    np.testing.assert_array_equal(four.field_uT, [[1, 2, 3], [4, 5, 6]])
    chosen = read_recording(_write(tmp_path, "9,0,7,1160\n9,0.5,8,1170\n"),
                            RecordingOptions(TableOptions(columns="_,t,_,y")))
    np.testing.assert_array_equal(chosen.t_s, [0.0, 0.5])
    np.testing.assert_array_equal(chosen.y_uT, [1160.0, 1170.0])
    with pytest.raises(UsageError, match="has 3 columns; name them with --columns"):
        read_recording(_write(tmp_path, "0,1,2\n1,2,3\n"))


def test_a_header_with_a_z_column_reads_three_axes_and_none_reads_y(tmp_path):
    path = _write(tmp_path, "t_s,magnetic_y,magnetic_z\n0,1160,400\n0.01,1170,410\n")
    recording = read_recording(path)
    assert recording.axes == 3 and np.all(np.isnan(recording.field_uT[:, 0]))
    np.testing.assert_array_equal(recording.axial_uT, [400.0, 410.0])
    assert read_recording(path, RecordingOptions(TableOptions(axial_column="none"))).axes == 1


@pytest.mark.parametrize("text, options, message", [
    ("t_s,y_uT,y_uT\n0,1,2\n", {}, "2 columns named 'y_uT'"),
    ("t_s,Y_uT,y_uT\n0,1,2\n", {}, "2 columns named 'y_uT'"),
    ("0,1\n1,2\n", {"columns": "t,q"}, "name each column t, x, y, z or _"),
    ("0,1\n1,2\n", {"columns": "t,y,z"}, "names 3 columns, the table has 2"),
    ("0,1160\n0,1170\n", {}, "every sample has the same time"),
])
def test_tables_that_lie_are_refused_in_one_line(tmp_path, text, options, message):
    with pytest.raises(UsageError, match=message) as raised:
        read_recording(_write(tmp_path, text), RecordingOptions(TableOptions(**options)))
    assert "\n" not in str(raised.value)


def test_the_implied_rate_is_checked_against_the_sensors():
    t_ms_read_as_s = np.arange(1200) * (1000.0 / 300.0)  # ms stamps taken for seconds
    with pytest.raises(UsageError, match=r"1200 samples over 3996.67 s is 0.3 Hz.*300 Hz"):
        check_rate(t_ms_read_as_s, 300.0, "log")
    with pytest.raises(UsageError, match="share their time stamp"):
        check_rate(np.repeat(np.arange(100) / 300.0, 3), 300.0, "log")
    assert check_rate(np.arange(100) / 167.0, 300.0, "log") == pytest.approx(167.0)


def test_ros2_echo_of_magnetic_field_is_tesla_and_wrong_units_are_refused(tmp_path):
    message = ("header:\n  stamp:\n    sec: 5\n    nanosec: {ns}\n  frame_id: mag\n"
               "magnetic_field:\n  x: {x}\n  y: {y}\n  z: {z}\nmagnetic_field_covariance:\n"
               "- 0.0\n- 0.0\n---\n")
    text = "".join(message.format(ns=k * 3_333_333, x=-9e-3, y=5.1e-3 + k * 1e-6, z=1.6e-2)
                   for k in range(5))
    recording = read_recording(_write(tmp_path, text, "mag.yaml"))
    np.testing.assert_allclose(recording.field_uT[0], [-9000.0, 5100.0, 16000.0])
    np.testing.assert_allclose(recording.t_s[1] - recording.t_s[0], 0.003333333)
    with pytest.raises(UsageError, match="implausibly small.*tesla"):
        read_recording(_write(tmp_path, text, "mag.yaml"), RecordingOptions(field_unit="uT"))
    microtesla_as_tesla = "".join(message.format(ns=k * 3_333_333, x=-9000.0, y=5100.0,
                                                 z=16000.0) for k in range(5))
    with pytest.raises(UsageError, match="implausibly large"):
        read_recording(_write(tmp_path, microtesla_as_tesla, "bad.yaml"))


def test_echo_poses_and_pose_tables(tmp_path):
    pose = ("header:\n  stamp:\n    secs: 1\n    nsecs: {ns}\n  frame_id: world\npose:\n"
            "  position:\n    x: {x}\n    y: 0.5\n    z: 0.0\n  orientation:\n    x: 0.0\n"
            "    y: 0.0\n    z: {qz}\n    w: {qw}\n---\n")
    headings = [3.0, 3.1, -3.1]  # across ±π: unwrapped
    text = "".join(pose.format(ns=k * 10_000_000, x=0.1 * k, qz=np.sin(h / 2), qw=np.cos(h / 2))
                   for k, h in enumerate(headings))
    poses = read_poses(str(_write(tmp_path, text, "poses.yaml")))
    np.testing.assert_allclose(poses.pose[:, 0], [0.0, 100.0, 200.0])  # m -> mm
    np.testing.assert_allclose(poses.pose[:, 2], [3.0, 3.1, 2 * np.pi - 3.1], atol=1e-12)
    table = read_poses(str(_write(tmp_path, "heading_rad,t_s,x_mm,y_mm\n0.5,0,1,2\n0.6,1,3,4\n")))
    np.testing.assert_array_equal(table.pose, [[1, 2, 0.5], [3, 4, 0.6]])
    with pytest.raises(UsageError, match="lacks heading_rad"):
        read_poses(str(_write(tmp_path, "t_s,x_mm,y_mm\n0,1,2\n", "p2.csv")))


def test_what_is_not_a_regular_file_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "log.fifo"
    os.mkfifo(fifo)
    with pytest.raises(UsageError, match="must be a regular file, not a FIFO"):
        read_recording(fifo)
    with pytest.raises(UsageError, match="must be a regular file, not a FIFO"):
        read_poses(str(fifo))
    with pytest.raises(UsageError, match="without metadata.yaml is not a rosbag2 bag"):
        read_recording(tmp_path)
    bare = _write(tmp_path, "", "run.mcap")
    bare.write_bytes(b"\x89MCAP0\r\n" + bytes(64))
    with pytest.raises(UsageError, match="run.mcap: not a readable bag"):
        read_recording(bare)
    bare.write_bytes(b"SQLite format 3\x00" + bytes(64))
    with pytest.raises(UsageError, match="sqlite3 file without its bag's metadata.yaml"):
        read_recording(bare)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.lists(st.tuples(st.floats(-1e5, 1e5), st.floats(-1e5, 1e5), st.floats(-1e5, 1e5)),
                min_size=2, max_size=30),
       st.sampled_from([",", "\t", ";", " "]), st.booleans())
def test_any_table_of_numbers_round_trips_with_or_without_a_header(rows, separator, header):
    """Written with a delimiter, with a header or none (then --columns names them), every cell
    reads back as written."""
    import tempfile

    t = np.arange(len(rows)) / 300.0
    lines = (["t_s" + separator + separator.join(["x_uT", "y_uT", "z_uT"])] if header else [])
    lines += [separator.join(repr(float(v)) for v in (t[k], *row)) for k, row in enumerate(rows)]
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "log.txt"
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        recording = read_recording(path, RecordingOptions(TableOptions(
            columns=None if header else "t,x,y,z"))) if _plausible(rows) else None
    if recording is not None:
        np.testing.assert_array_equal(recording.t_s, t)
        np.testing.assert_array_equal(recording.field_uT, np.asarray(rows, float))


def _plausible(rows) -> bool:
    """The reader refuses a field whose median magnitude no magnetometer reads."""
    magnitude = np.median(np.linalg.norm(np.asarray(rows, float), axis=1))
    return 0.1 <= magnitude <= 1e5
