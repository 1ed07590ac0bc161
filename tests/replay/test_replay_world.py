"""Replay with the robot's poses and the sensor's mount: world-frame contacts, pose gaps counted,
the world plot and the ROS 2 bag; three axes through a (Y, Z) table with rest and sign per axis;
time columns and inputs that lie are refused in one line."""

import json
import math
import os
import re
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from whiskercal import runtime
from whiskercal.artifacts.calibration import read_calibration, write_calibration
from whiskercal.artifacts.replay_track import read_track
from whiskercal.cli import cli
from whiskercal.mount import Mount, write_mount
from whiskercal.recording import Recording, read_recording
from whiskercal.replay import ReplayOptions, replay

FIXTURES = Path(__file__).parents[1] / "fixtures"
ARTIFACT = FIXTURES / "calibration-1.3.0-target.h5"
REST_UT = 1160.5
RATE_HZ = 300.0
MOUNT = Mount(x_mm=12.0, y_mm=-3.5, yaw_deg=90.0)
GAP_S = (2.0, 2.6)  # no pose in between


def _stream(n: int = 1500, seed: int = 5):
    """Rest, then a press to the middle of the calibrated range and back, with noise."""
    calibration = runtime.load(ARTIFACT)
    low, high = calibration.z_range_uT
    z = np.zeros(n)
    press = slice(n // 5, n - n // 6)
    z[press] = 0.5 * (low + high) * np.sin(np.linspace(0.0, np.pi, len(z[press])))
    reading = REST_UT + z + np.random.default_rng(seed).normal(0.0, 5.0, n)
    return np.arange(n) / RATE_HZ, reading


def _effector(t_s):
    """The end effector moving along x at 10 mm/s while turning at 0.3 rad/s."""
    return np.column_stack([100.0 + 10.0 * t_s, 50.0 + 0.0 * t_s, 0.3 * t_s])


def _run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def world_replay(tmp_path_factory):
    folder = tmp_path_factory.mktemp("replay-world")
    t, reading = _stream()
    np.savetxt(folder / "log.csv", np.column_stack([t, reading]), fmt="%.9f", delimiter=",",
               header="t_s,y_uT", comments="")
    pose_t = np.arange(0.0, t[-1] + 0.02, 0.02)
    pose_t = pose_t[(pose_t < GAP_S[0]) | (pose_t > GAP_S[1])]
    np.savetxt(folder / "poses.csv", np.column_stack([pose_t, _effector(pose_t)]), fmt="%.9f",
               delimiter=",", header="t_s,x_mm,y_mm,heading_rad", comments="")
    write_mount(folder / "mount.toml", MOUNT)
    result = _run("replay", folder / "log.csv", "--artifact", ARTIFACT, "--out", folder / "out",
                  "--rest-uT", REST_UT, "--poses", folder / "poses.csv", "--mount",
                  folder / "mount.toml", "--max-pose-gap-ms", 30, "--json")
    assert result.exit_code == 0, result.output
    track = np.genfromtxt(folder / "out" / "track.csv", delimiter=",", names=True)
    return folder, json.loads(result.output), track, t


def test_world_points_are_the_filtered_tip_through_pose_and_mount(world_replay):
    _, summary, track, t = world_replay
    posed = (t < GAP_S[0] - 0.03) | (t > GAP_S[1] + 0.03)
    tip = np.column_stack([track["filtered_x_mm"], track["filtered_y_mm"]])
    expected = MOUNT.to_world(_effector(t), tip)  # the motion is linear: interpolation is exact
    has_tip = np.isfinite(tip[:, 0])
    assert np.count_nonzero(has_tip & posed) > 500
    world = np.column_stack([track["world_x_mm"], track["world_y_mm"]])
    np.testing.assert_allclose(world[has_tip & posed], expected[has_tip & posed], atol=1e-6)
    assert np.all(np.isnan(world[~has_tip]))
    in_gap = (t > GAP_S[0] + 0.03) & (t < GAP_S[1] - 0.03)
    assert np.all(np.isnan(world[in_gap])) and np.count_nonzero(in_gap & has_tip) > 100
    # the base frame's heading is the effector's plus the mount's yaw
    np.testing.assert_allclose(track["base_heading_rad"][posed], 0.3 * t[posed] + math.pi / 2,
                               atol=1e-6)
    counted = summary["world"]["samples_without_pose"]
    assert np.count_nonzero(in_gap) <= counted <= np.count_nonzero(~posed)
    assert summary["world"]["world_points"] == np.count_nonzero(np.isfinite(world[:, 0]))
    assert any("from every pose: no world point" in w for w in summary["warnings"])


def test_the_track_file_the_plot_and_the_bag_hold_the_same(world_replay):
    from rosbags.highlevel import AnyReader

    folder, summary, track, _ = world_replay
    out = folder / "out"
    stored = read_track(out / "track.h5")
    assert stored.schema_version == "1.1.0"
    np.testing.assert_allclose(stored.columns["world_x_mm"], track["world_x_mm"], atol=1e-6)
    assert (out / "world.png").read_bytes().startswith(b"\x89PNG")
    assert sorted(summary["files"]) == ["bag", "csv", "h5", "png", "summary", "world_png"]
    bag = read_recording(out / "rosbag")
    np.testing.assert_allclose(bag.y_uT, np.loadtxt(folder / "log.csv", delimiter=",",
                                                    skiprows=1)[:, 1], atol=1e-6)
    with AnyReader([out / "rosbag"]) as reader:
        points = [c for c in reader.connections if c.msgtype == "geometry_msgs/msg/PointStamped"]
        assert sum(c.msgcount for c in points) == summary["world"]["world_points"]


def _table_artifact(tmp_path) -> Path:
    """The 1.0.0 fixture with a (Y, Z) table whose tip moves 0.01 mm per µT of Z."""
    data = read_calibration(FIXTURES / "calibration-1.0.0.h5")
    y = np.linspace(data.lookup_z_uT[0], data.lookup_z_uT[-1], 11)
    z = np.linspace(-200.0, 200.0, 9)
    yy, zz = np.meshgrid(y, z, indexing="ij")
    table = {"y_uT": y, "axial_uT": z,
             "tip_mm": np.stack([78.0 + 0.001 * yy, 0.002 * yy + 0.01 * zz], axis=-1)}
    path = tmp_path / "cal-table.h5"
    write_calibration(path, replace(data, field_table=table))
    return path


def test_three_axes_read_through_the_table_with_rest_and_sign_per_axis(tmp_path):
    calibration = runtime.load(_table_artifact(tmp_path))
    n = 600
    low, high = calibration.z_range_uT
    z = np.where((np.arange(n) > 200) & (np.arange(n) < 500), 0.5 * (low + high), 0.0)
    axial = np.where(z != 0.0, -60.0, 0.0)
    rest = np.array([-9000.0, 1160.5, 16000.0])
    field = np.column_stack([np.full(n, rest[0]), rest[1] + z, rest[2] - axial])  # Z mounted flipped
    recording = Recording(np.arange(n) / RATE_HZ, field, "three axes")
    result = replay(recording, calibration, ReplayOptions(rest="auto", axial_sign=-1))
    assert result.axial_rest_uT == rest[2] and result.rest_uT == rest[1]
    pressed = result.contact
    assert np.count_nonzero(pressed) > 250
    np.testing.assert_allclose(result.axial_uT[pressed], -60.0)
    table_tip = np.column_stack([78.0 + 0.001 * z, 0.002 * z + 0.01 * axial])[pressed]
    np.testing.assert_allclose(result.raw_tip_mm[pressed], table_tip, atol=1e-9)
    y_only = replay(Recording(recording.t_s, field[:, 1], "Y"), calibration, ReplayOptions(rest="auto"))
    assert np.max(np.abs(y_only.raw_tip_mm[pressed] - table_tip)) > 0.5  # the z lookup's tip


def test_lying_time_columns_and_non_files_are_refused_in_one_line(tmp_path):
    t, reading = _stream(600)
    ms = tmp_path / "ms.csv"
    np.savetxt(ms, np.column_stack([t * 1000.0, reading]), fmt="%.6f", delimiter=",",
               header="t_s,y_uT", comments="")
    good = tmp_path / "good.csv"
    np.savetxt(good, np.column_stack([t, reading]), fmt="%.6f", delimiter=",",
               header="t_s,y_uT", comments="")
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    for args, message in [((ms,), r"600 samples over 1996.67 s is 0.3 Hz.*another unit \(a table's --time-unit\)"),
                          ((fifo,), "must be a regular file, not a FIFO"),
                          ((good, "--poses", tmp_path / "none.csv"), "no such file"),
                          ((good, "--mount", tmp_path / "m.toml"), "--mount needs --poses"),
                          ((good, "--poses", fifo), "must be a regular file, not a FIFO")]:
        result = _run("replay", *args, "--artifact", ARTIFACT, "--out", tmp_path / "out")
        assert result.exit_code == 2 and re.search(message, result.output), result.output
        assert len(result.output.strip().splitlines()) == 1
    result = _run("replay", good, "--artifact", fifo, "--out", tmp_path / "out")
    assert result.exit_code == 2 and "artifact must be a regular file" in result.output
    assert not (tmp_path / "out").exists()


def _robot_bag(path, t, reading, pose_t):
    """A robot's recorder: the field (tesla) and a transform tree with world -> ee."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types

    def header(seconds, frame):
        ns = int(round((1_700_000_000.0 + seconds) * 1e9))
        return types["std_msgs/msg/Header"](types["builtin_interfaces/msg/Time"](
            ns // 10**9, ns % 10**9), frame)

    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        mag = writer.add_connection("/mag", "sensor_msgs/msg/MagneticField", typestore=store)
        tf = writer.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=store)
        for seconds, y in zip(t, reading):
            message = types["sensor_msgs/msg/MagneticField"](header(seconds, "mag"), types[
                "geometry_msgs/msg/Vector3"](-9e-3, y * 1e-6, 1.6e-2), np.zeros(9))
            writer.write(mag, int(seconds * 1e9), store.serialize_cdr(
                message, "sensor_msgs/msg/MagneticField"))
        for seconds, (x, y, heading) in zip(pose_t, _effector(pose_t)):
            transform = types["geometry_msgs/msg/TransformStamped"](header(seconds, "world"), "ee", types[
                "geometry_msgs/msg/Transform"](types["geometry_msgs/msg/Vector3"](x / 1e3, y / 1e3, 0.0),
                                               types["geometry_msgs/msg/Quaternion"](
                                                   0.0, 0.0, math.sin(heading / 2), math.cos(heading / 2))))
            writer.write(tf, int(seconds * 1e9), store.serialize_cdr(
                types["tf2_msgs/msg/TFMessage"]([transform]), "tf2_msgs/msg/TFMessage"))
    return path


def test_a_robots_bag_with_a_transform_tree_and_a_mount(tmp_path):
    t, reading = _stream(900)
    bag = _robot_bag(tmp_path / "robot", t, reading, np.arange(0.0, t[-1] + 0.02, 0.02))
    write_mount(tmp_path / "mount.toml", MOUNT)
    result = _run("replay", bag, "--artifact", ARTIFACT, "--out", tmp_path / "out", "--rest-uT",
                  REST_UT, "--poses", "/tf", "--pose-frames", "world,ee", "--mount",
                  tmp_path / "mount.toml", "--json")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary["axes"] == 3 and summary["world"]["samples_without_pose"] == 0
    track = read_track(tmp_path / "out" / "track.h5").columns
    tip = np.column_stack([track["filtered_x_mm"], track["filtered_y_mm"]])
    has_tip = np.isfinite(tip[:, 0])
    assert np.count_nonzero(has_tip) > 300
    expected = MOUNT.to_world(_effector(track["t_s"] - 1_700_000_000.0), tip)
    world = np.column_stack([track["world_x_mm"], track["world_y_mm"]])
    # epoch stamps resolve 0.24 µs as float64: the pose moves 10 mm/s, so 1e-5 mm is ample
    np.testing.assert_allclose(world[has_tip], expected[has_tip], atol=1e-4)


def _folder_state(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


@pytest.mark.parametrize("failing", ["summary", "bag"])
def test_the_bag_is_replaced_with_the_other_files_or_not_at_all(world_replay, tmp_path,
                                                                 monkeypatch, failing):
    import errno

    from whiskercal.recording import bagwrite
    from whiskercal.replay import output

    folder = world_replay[0]
    out = tmp_path / "out"
    shutil.copytree(folder / "out", out)
    before = _folder_state(out)
    args = ("replay", folder / "log.csv", "--artifact", ARTIFACT, "--out", out, "--rest-uT",
            REST_UT + 1.0, "--poses", folder / "poses.csv", "--mount", folder / "mount.toml",
            "--max-pose-gap-ms", 30, "--force")

    def full_disk(*args, **kwargs):  # the summary, or the bag, does not fit
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with monkeypatch.context() as patch:
        if failing == "summary":
            patch.setattr(output, "write_summary", full_disk)
        else:
            patch.setattr(bagwrite, "_write_rosbag", full_disk)
        failed = _run(*args)
    assert failed.exit_code == 2 and "No space left on device" in failed.stderr
    assert _folder_state(out) == before  # the old bag and files whole, no partial bag beside
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in (folder / "out").iterdir())
    replaced = _run(*args)
    assert replaced.exit_code == 0, replaced.output
    assert read_recording(out / "rosbag").y_uT.size == read_recording(folder / "out" / "rosbag").y_uT.size
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in (folder / "out").iterdir())


def test_the_pose_latency_auto_is_estimated_from_the_data(tmp_path):
    """A tip held on one world point while the base presses in and out and turns: the poses,
    written 40 ms late, are placed by the latency estimated from the replay's own data."""
    calibration = runtime.load(ARTIFACT)
    low, high = calibration.z_range_uT
    rng = np.random.default_rng(7)
    t = np.arange(3000) / RATE_HZ
    press = (t > 1.0) & (t < 9.0)
    wobble = np.convolve(rng.normal(0, 1, t.size), np.ones(30) / 30, mode="same")
    z = np.where(press, 0.5 * (low + high) * (1 + 0.6 * wobble), 0.0)
    reading = REST_UT + z + rng.normal(0.0, 5.0, t.size)
    tip = calibration.tip(np.where(press, z, 0.5 * (low + high)), out_of_range="clip")
    heading = 0.4 + 0.1 * np.sin(t)
    c, s = np.cos(heading), np.sin(heading)
    base = np.array([150.0, 40.0]) - np.column_stack([c * tip[:, 0] - s * tip[:, 1],
                                                      s * tip[:, 0] + c * tip[:, 1]])
    late = 0.04  # s: the pose stamped t is the robot at t - 40 ms
    pose = np.column_stack([np.interp(t - late, t, base[:, k]) for k in range(2)]
                           + [np.interp(t - late, t, heading)])
    np.savetxt(tmp_path / "log.csv", np.column_stack([t, reading]), fmt="%.9f", delimiter=",",
               header="t_s,y_uT", comments="")
    np.savetxt(tmp_path / "poses.csv", np.column_stack([t, pose]), fmt="%.9f", delimiter=",",
               header="t_s,x_mm,y_mm,heading_rad", comments="")
    result = _run("replay", tmp_path / "log.csv", "--artifact", ARTIFACT, "--out",
                  tmp_path / "out", "--rest-uT", REST_UT, "--poses", tmp_path / "poses.csv",
                  "--pose-latency-ms", "auto", "--json")
    assert result.exit_code == 0, result.output
    world = json.loads(result.output)["world"]
    assert world["pose_latency_estimated"] is True
    assert world["pose_latency_ms"] == pytest.approx(40.0, abs=1e3 / RATE_HZ)
    refused = _run("replay", tmp_path / "log.csv", "--artifact", ARTIFACT, "--out",
                   tmp_path / "out2", "--rest-uT", REST_UT, "--poses", tmp_path / "poses.csv",
                   "--pose-latency-ms", "soon")
    assert refused.exit_code != 0 and "must be a number of ms or auto" in refused.output
