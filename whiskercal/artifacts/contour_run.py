"""A contour-following run (schema ``whiskercal.contour_run``): writer and reader.

One HDF5 file: root attributes (provenance; the shape, its outline core and corner radius, the
target, the seed, whether the run went its full duration) and a ``samples`` group with one dataset
per column (time, z, the chip's Z axis (from 1.1), the estimated contact, the twin's true tip and contact, the robot's pose, the
controller's phase, the contact kind, slips, the controller's time per sample, the twin's true
slip events (from 1.2)), and a ``transitions`` group (from 1.3): one row per change of the
controller's phase (the sample's index, its time, the phase left, the phase entered, the rule
that moved it). A run is written
once, atomically: a run stopped by Ctrl-C is written with what it has and ``complete`` false.
docs/formats.md lists the layout; docs/contour.md the run.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from whiskercal.artifacts import h5io

SCHEMA = "whiskercal.contour_run"
SCHEMA_VERSION = "1.3.0"  # 1.1: axial_uT; 1.2: twin_slips; 1.3: transitions; optional on reading
SUPPORTED_MAJOR = 1

UNITS = {"t_s": "s", "z_uT": "µT", "axial_uT": "µT", "estimate_mm": "mm", "true_tip_mm": "mm",
         "true_contact_mm": "mm", "pose": "mm, mm, rad", "slip": "1", "phase": "1", "kind": "1",
         "control_s": "s", "twin_slips": "1"}
OPTIONAL = ("axial_uT", "twin_slips")  # absent from runs written before 1.1, 1.2
TRANSITION_UNITS = {"sample": "1", "t_s": "s", "source": "1", "target": "1", "rule": "1"}


@dataclass
class ContourRunFile:
    """What a contour-run file holds (world frame, mm)."""

    shape: str
    core_mm: np.ndarray
    radius_mm: float
    target_z_uT: float
    seed: int
    complete: bool
    wall_s: float
    sensor_id: str
    columns: dict[str, np.ndarray]
    config: dict
    path: str = ""
    transitions: dict[str, np.ndarray] = field(default_factory=dict)  # (none before 1.3)


def write_contour_run(path: str | Path, run: ContourRunFile) -> Path:
    """Write ``run`` to ``path`` atomically (replaced whole)."""
    def write(handle: h5py.File) -> None:
        h5io.write_provenance(handle, schema=SCHEMA, schema_version=SCHEMA_VERSION,
                              sensor_id=run.sensor_id, config=run.config)
        for key in ("shape", "radius_mm", "target_z_uT", "seed", "complete", "wall_s"):
            handle.attrs[key] = getattr(run, key)
        h5io.write_array(handle, "outline_core_mm", np.asarray(run.core_mm, float), "mm")
        _write_columns(handle.create_group("samples"), run.columns, UNITS)
        if run.transitions:
            _write_columns(handle.create_group("transitions"), run.transitions, TRANSITION_UNITS)

    return h5io.write_whole(path, write)


def _write_columns(group, columns: dict, units: dict) -> None:
    for name, values in columns.items():
        values = np.asarray(values)
        if values.dtype.kind == "U":
            values = values.astype("S") if values.size else np.zeros(0, "S1")
        h5io.write_array(group, name, values, units.get(name, "1"))


def _read_columns(group, units: dict, path, optional=()) -> dict[str, np.ndarray]:
    columns = {}
    for name in units:
        if name in optional and name not in group:
            continue
        values = h5io.read_array(group, name, path)
        columns[name] = values.astype(str) if values.dtype.kind == "S" else values
    return columns


def read_contour_run(path: str | Path) -> ContourRunFile:
    """Read a contour-run file; ArtifactError names the file and what is wrong with it."""
    with h5io.open_h5(path) as handle, h5io.malformed_is_an_error(path, "contour run"):
        h5io.check_schema(handle, SCHEMA, SUPPORTED_MAJOR, path)
        columns = _read_columns(handle["samples"], UNITS, path, OPTIONAL)
        transitions = (_read_columns(handle["transitions"], TRANSITION_UNITS, path)
                       if "transitions" in handle else {})
        attrs = handle.attrs
        return ContourRunFile(
            shape=h5io.as_text(attrs["shape"]), core_mm=h5io.read_array(handle, "outline_core_mm", path),
            radius_mm=float(attrs["radius_mm"]), target_z_uT=float(attrs["target_z_uT"]),
            seed=int(attrs["seed"]), complete=bool(attrs["complete"]), wall_s=float(attrs["wall_s"]),
            sensor_id=h5io.as_text(attrs["sensor_id"]), columns=columns,
            config=h5io.read_json_attr(handle, "config", {}), path=str(path),
            transitions=transitions)
