"""A replay's tip track (schema ``whiskercal.replay_track``): writer and reader.

One HDF5 file: root attributes (provenance; the replay's summary as JSON text) and a ``track``
group with one dataset (n,) per column of :data:`COLUMNS`, each with its ``units`` and a
``description``. Written once, atomically. The world-frame columns, the Z axis and the sensor
base's pose (from 1.1) are NaN where the replay had no poses (or no Z axis); a 1.0 file lacks
them and reads with them NaN. docs/formats.md lists the layout; docs/recordings.md the replay.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from whiskercal.artifacts import h5io
from whiskercal.atomic import atomic_path
from whiskercal.jsontools import jsonable

SCHEMA = "whiskercal.replay_track"
SCHEMA_VERSION = "1.1.0"  # 1.1: the Z axis, the world frame and the base pose (ADDED_IN_1_1)
SUPPORTED_MAJOR = 1

# column: (units, description); the CSV's header shares these names
COLUMNS = {
    "t_s": ("s", "time of the sample, the recording's clock"),
    "z_uT": ("µT", "deflection: sign x (Y reading - rest)"),
    "contact": ("1", "1 while the collision detector reports contact"),
    "raw_x_mm": ("mm", "tip from the lookup, whisker base frame (NaN without contact)"),
    "raw_y_mm": ("mm", "tip from the lookup, whisker base frame (NaN without contact)"),
    "filtered_x_mm": ("mm", "tip after the constant-state Kalman filter (NaN without one)"),
    "filtered_y_mm": ("mm", "tip after the constant-state Kalman filter (NaN without one)"),
    "out_of_range": ("1", "-1 below, +1 above the calibrated range (in contact), else 0"),
    "extrapolated": ("1", "1 when the tip came from a range marked as extrapolated"),
    "axial_uT": ("µT", "the chip's Z axis: axial sign x (Z reading - rest) (NaN: Y alone)"),
    "world_x_mm": ("mm", "the filtered contact in the world frame (NaN without a pose or tip)"),
    "world_y_mm": ("mm", "the filtered contact in the world frame (NaN without a pose or tip)"),
    "base_x_mm": ("mm", "the sensor base frame's origin in the world (NaN without a pose)"),
    "base_y_mm": ("mm", "the sensor base frame's origin in the world (NaN without a pose)"),
    "base_heading_rad": ("rad", "the sensor base frame's heading in the world (NaN: no pose)"),
}
ADDED_IN_1_1 = ("axial_uT", "world_x_mm", "world_y_mm", "base_x_mm", "base_y_mm",
                "base_heading_rad")


@dataclass
class ReplayTrack:
    """What a track file holds: the columns (each (n,)), the summary, the sensor, the config."""

    columns: dict[str, np.ndarray]
    summary: dict
    sensor_id: str
    config: dict
    schema_version: str
    path: str = ""


def write_track(path: str | Path, columns: dict[str, np.ndarray], summary: dict, sensor_id: str,
                inputs: dict[str, str], config: dict) -> Path:
    """Write a track (every column of :data:`COLUMNS`, equal lengths) to ``path`` atomically."""
    missing = [name for name in COLUMNS if name not in columns]
    lengths = {len(columns[name]) for name in COLUMNS if name in columns}
    if missing or len(lengths) > 1:
        raise ValueError(f"a track needs every column, of one length (missing {missing})")
    path = Path(path)
    with atomic_path(path) as scratch, h5py.File(scratch, "w") as handle:
        h5io.write_provenance(handle, schema=SCHEMA, schema_version=SCHEMA_VERSION,
                              sensor_id=sensor_id, inputs=inputs, config=config)
        handle.attrs["summary"] = json.dumps(summary, default=jsonable, sort_keys=True)
        group = handle.create_group("track")
        for name, (units, description) in COLUMNS.items():
            h5io.write_array(group, name, np.asarray(columns[name]), units, description=description)
    return path


def read_track(path: str | Path) -> ReplayTrack:
    """Read a track file; ArtifactError names the file and what is wrong with it."""
    with h5io.open_h5(path) as handle:
        version = h5io.check_schema(handle, SCHEMA, SUPPORTED_MAJOR, path)
        if not isinstance(handle.get("track", getlink=True), h5py.HardLink):
            raise h5io.ArtifactError(f"{path}: no track group")
        group = handle["track"]
        columns = {}
        for name in COLUMNS:
            if name in ADDED_IN_1_1 and name not in group:
                continue
            columns[name] = np.asarray(h5io.read_array(group, name, path))
        lengths = {len(values) for values in columns.values()}
        if len(lengths) > 1:
            raise h5io.ArtifactError(f"{path}: the track's columns differ in length")
        n = lengths.pop() if lengths else 0
        for name in ADDED_IN_1_1:
            columns.setdefault(name, np.full(n, np.nan))
        summary = h5io.read_json_attr(handle, "summary", {})
        return ReplayTrack(columns, summary, h5io.as_text(handle.attrs.get("sensor_id", "")),
                           h5io.read_json_attr(handle, "config", {}), version, str(path))
