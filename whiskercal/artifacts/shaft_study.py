"""The shaft study dataset (schema ``whiskercal.shaft_study``): writer, checkpoint and reader.

One HDF5 file holds the run's configuration, the static baseline and one group per finished
trial (a rod pressed onto the shaft at one radial distance, then slid along a known direction).
A trial is added whole, on a copy renamed over the original (``h5io.update_copy``), so a crash leaves
the old file or the new one; ``--resume`` runs only the trials that are missing. docs/formats.md
lists the layout; docs/shaft.md the study.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from whiskercal.artifacts import h5io
from whiskercal.artifacts.plane_study import _comparable
from whiskercal.errors import ArtifactError, UsageError
from whiskercal.paths import ensure_dir

SCHEMA = "whiskercal.shaft_study"
SCHEMA_VERSION = "1.0.0"
SUPPORTED_MAJOR = 1

_UNITS = {"t_s": "s", "z_uT": "µT", "field_uT": "µT", "phase": "1", "position_mm": "mm",
          "contact_mm": "mm", "rod_center_mm": "mm", "kind": "1", "z_true_uT": "µT"}


@dataclass
class ShaftTrial:
    """One trial: per-sample stream (K), the object's position per sample, the twin's truth."""

    name: str
    radial_mm: float
    stream: dict[str, np.ndarray]
    """t_s (K,) board s, field_uT (K,3), z_uT (K,) Y minus static, phase (K,) 0 push 1 slide 2 out,
    position_mm (K,2) the rod's centre in the whisker frame from the stage's reports."""
    attrs: dict[str, Any] = field(default_factory=dict)
    truth: dict[str, np.ndarray] | None = None
    """Twin only: contact_mm (K,2), rod_center_mm (K,2), kind (K,), z_true_uT (K,)."""


def _write_group(group: h5py.Group, arrays: dict[str, np.ndarray]) -> None:
    for name, values in arrays.items():
        values = np.asarray(values)
        if values.dtype.kind == "U":
            values = values.astype("S")
        h5io.write_array(group, name, values, _UNITS.get(name, "1"))


def _read_group(group: h5py.Group) -> dict[str, np.ndarray]:
    out = {}
    for name, dataset in group.items():
        values = dataset[()]
        out[name] = values.astype(str) if values.dtype.kind == "S" else values
    return out


class ShaftStudyWriter:
    """Create (or with ``resume`` continue) a shaft study file; add finished trials atomically.
    An existing finished file is replaced only with ``force`` (``h5io.refuse_to_replace_run``)."""

    def __init__(self, path: str | Path, config: dict, sensor_id: str, resume: bool = False,
                 force: bool = False):
        self.path, self.config = Path(path), config
        h5io.refuse_to_replace_run(self.path, resume, force, "shaft study")
        if resume:
            with h5io.open_h5(self.path) as handle:
                h5io.check_schema(handle, SCHEMA, SUPPORTED_MAJOR, self.path)
                stored = h5io.read_json_attr(handle, "config", {})
            if _comparable(stored) != _comparable(config):
                raise UsageError(f"{self.path} was started with another configuration; "
                                 "resume it with the same --config or start a new file")
        else:
            ensure_dir(self.path.parent)
            h5io.create_trials_file(self.path, schema=SCHEMA, schema_version=SCHEMA_VERSION,
                                    sensor_id=sensor_id, config=config)

    def _update(self, write) -> None:
        h5io.update_copy(self.path, write)

    def done(self) -> list[str]:
        """Names of the trials already in the file."""
        with h5io.open_h5(self.path) as handle:
            return sorted(handle["trials"])

    def write_baseline(self, static_field_uT: np.ndarray) -> None:
        """The static reading (µT) the trials' z is relative to."""
        def write(handle: h5py.File) -> None:
            if "static_field_uT" in handle.attrs:
                return
            handle.attrs["static_field_uT"] = np.asarray(static_field_uT, float)
        self._update(write)

    def add_trial(self, trial: ShaftTrial) -> None:
        """Add one finished trial (atomically)."""
        def write(handle: h5py.File) -> None:
            group = handle["trials"].create_group(trial.name)
            group.attrs["radial_mm"] = float(trial.radial_mm)
            for key, value in trial.attrs.items():
                group.attrs[key] = value
            _write_group(group.create_group("stream"), trial.stream)
            if trial.truth is not None:
                _write_group(group.create_group("truth"), trial.truth)
        self._update(write)

    def mark_complete(self) -> None:
        """Set the root attribute ``complete`` once every planned trial is in the file."""
        self._update(lambda handle: handle.attrs.__setitem__("complete", True))


@dataclass
class ShaftStudy:
    """A shaft study file read into memory."""

    path: Path
    config: dict
    sensor_id: str
    complete: bool
    trials: list[ShaftTrial]


def read_shaft_study(path: str | Path) -> ShaftStudy:
    """Read a shaft study file (schema checked; an unknown major version is refused).

    Raises ArtifactError when the file is missing, not HDF5, or not a shaft study it reads.
    """
    path = Path(path)
    with h5io.open_h5(path) as handle, h5io.malformed_is_an_error(path, "shaft study file"):
        h5io.check_schema(handle, SCHEMA, SUPPORTED_MAJOR, path)
        trials = []
        for name, group in sorted(handle["trials"].items()):
            if "stream" not in group:
                raise ArtifactError(f"trial {name} is incomplete in {path}")
            attrs = {key: group.attrs[key] for key in group.attrs if key != "radial_mm"}
            truth = _read_group(group["truth"]) if "truth" in group else None
            trials.append(ShaftTrial(name, float(group.attrs["radial_mm"]),
                                     _read_group(group["stream"]), attrs, truth))
        return ShaftStudy(path, h5io.read_json_attr(handle, "config", {}),
                          h5io.as_text(handle.attrs.get("sensor_id", "")),
                          bool(handle.attrs.get("complete", False)), trials)
