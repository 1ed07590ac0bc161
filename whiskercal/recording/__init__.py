"""Recordings in: a robot's or a rig's logs as field samples (and poses), one reader per format.

>>> from whiskercal.recording import RecordingOptions, read_poses, read_recording
>>> recording = read_recording("run/", RecordingOptions())               # doctest: +SKIP
>>> poses = read_poses("/robot/pose", "run/")                            # doctest: +SKIP

Formats (told apart by their first bytes and names, :func:`files.kind_of`):

- a ROS bag (``bag``): a rosbag2 folder (MCAP or sqlite3 storage), an MCAP file alone, or a
  ROS 1 ``.bag`` file;
- a ``rostopic echo`` / ``ros2 topic echo`` log (``echo``): YAML documents separated by ``---``;
- a text table (``table``): CSV, TSV, ``;``- or space-separated, with a header or without;
- a whiskercal HDF5 file (``hdf5``): a raw grid's or a plane study's stream.

Every reader returns a :class:`Recording` (time s, field µT: Y alone or three axes), checked
here the same way: times finite and in order, a field magnitude a magnetometer can read.
Poses come from a topic of the same bag or from a second file (a bag, an echo log of poses, or
a table ``t_s, x_mm, y_mm, heading_rad``). docs/recordings.md describes each format.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from whiskercal.errors import UsageError
from whiskercal.recording.files import kind_of, regular_file
from whiskercal.recording.frames import poses_at
from whiskercal.recording.table import TableOptions
from whiskercal.recording.types import (FIELD_UNITS, Poses, Recording, check_plausible_field,
                                        check_rate, check_times, field_scale)

__all__ = ["FIELD_UNITS", "Poses", "Recording", "RecordingOptions", "TableOptions", "check_rate",
           "kind_of", "poses_at", "read_poses", "read_recording", "regular_file"]


@dataclass(frozen=True)
class RecordingOptions:
    """How to read a recording: a table's columns, a bag's field topic, the field's unit (None:
    the format's own: tesla in a MagneticField message, µT elsewhere)."""

    table: TableOptions = TableOptions()
    field_topic: str | None = None
    field_unit: str | None = None


def read_recording(path: str | Path, options: RecordingOptions = RecordingOptions()) -> Recording:
    """The field samples of the recording at ``path``, whatever its format."""
    if options.field_unit is not None:
        field_scale(options.field_unit)
    kind = kind_of(path)
    if options.field_topic is not None and kind not in ("bag1", "bag2", "mcap"):
        raise UsageError(f"{path}: --field-topic applies to a bag; this is a {kind} file")
    recording = _read(path, kind, options)
    check_times(recording.t_s, recording.source)
    hint = (f"read as {options.field_unit}" if options.field_unit else
            "in the format's own unit")
    check_plausible_field(recording, hint)
    return recording


def _read(path, kind: str, options: RecordingOptions) -> Recording:
    if kind in ("bag1", "bag2", "mcap"):
        from whiskercal.recording.bag import read_bag

        return read_bag(path, options.field_topic, options.field_unit)
    if kind == "echo":
        from whiskercal.recording.echo import read_echo

        return read_echo(path, options.field_unit)
    if kind == "hdf5":
        from whiskercal.recording.hdf5 import read_hdf5_stream

        return read_hdf5_stream(path)
    from dataclasses import replace

    from whiskercal.recording.table import read_table

    scale = field_scale(options.field_unit or "uT")
    return read_table(path, replace(options.table, field_scale=scale))


def read_poses(spec: str, recording_path: str | Path | None = None,
               frames: tuple[str, str] | None = None) -> Poses:
    """Poses from ``spec``: a file (a bag, an echo log of poses, a table), ``auto`` (the
    recording's bag's one pose topic), or a topic of the recording's bag."""
    if Path(spec).exists():
        return _poses_from_file(Path(spec), None, frames)
    bag = recording_path is not None and kind_of(recording_path) in ("bag1", "bag2", "mcap")
    if not bag:
        raise UsageError(f"--poses {spec}: no such file (a topic names poses only in a bag)")
    return _poses_from_file(Path(recording_path), None if spec == "auto" else spec, frames)


def _poses_from_file(path: Path, topic: str | None, frames) -> Poses:
    kind = kind_of(path)
    if kind in ("bag1", "bag2", "mcap"):
        from whiskercal.recording.bag import read_bag_poses

        return read_bag_poses(path, topic, frames)
    if kind == "echo":
        from whiskercal.recording.echo import read_echo_poses

        return read_echo_poses(path)
    if kind == "table":
        from whiskercal.recording.pose_table import read_pose_table

        return read_pose_table(path)
    raise UsageError(f"{path}: a {kind} file holds no poses")
