"""The flat-plane study dataset (schema ``whiskercal.plane_study``): writer, checkpoint and reader.

One HDF5 file holds the study's header (baseline, first contact, the plan) and one group per
finished trial. A trial is written whole when it ends: the file is copied, the trial added to the
copy, and the copy renamed over the original, so a crash or ``kill -9`` at any moment leaves
either the old file or the new one, never a half-written trial. A finished trial is never redone;
``--resume`` continues with the trials that are missing. docs/formats.md describes the layout;
docs/study.md the study (``whiskercal/study/``) that writes and analyses it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from whiskercal.artifacts import h5io
from whiskercal.errors import ArtifactError, UsageError
from whiskercal.paths import ensure_dir

SCHEMA = "whiskercal.plane_study"
SCHEMA_VERSION = "1.0.0"
SUPPORTED_MAJOR = 1

PHASE_APPROACH, PHASE_SLIDE, PHASE_RETRACT = 0, 1, 2
"""Values of /trials/*/stream/phase: moving to depth, sliding at constant velocity, backing off."""


@dataclass
class TrialRecord:
    """Everything recorded during one trial (arrays per sensor sample K or per stage poll M)."""

    depth_mm: float
    stream: dict[str, np.ndarray]
    """seq (K,), t_s (K,) device s, counts (K,3), field_uT (K,3), status (K,), phase (K,)."""
    stage: dict[str, np.ndarray]
    """sample_index (M,): sensor samples received before the poll; mpos_mm (M,2); enc_mm (M,2)."""
    plane: dict[str, np.ndarray]
    """point_mm (K,2), normal (K,2): the plane's line per sample in the whisker frame."""
    attrs: dict[str, Any] = field(default_factory=dict)
    """start/end of the slide in stage coordinates, speed, travel, counters of dropped frames ..."""
    truth: dict[str, np.ndarray] | None = None
    """Twin only: tip_mm (K,2), contact_mm (K,2), kind (K,), z_uT (K,) noise-free."""


_UNITS = {
    "seq": "1", "t_s": "s", "counts": "1", "field_uT": "µT", "status": "1", "phase": "1",
    "sample_index": "1", "mpos_mm": "mm", "enc_mm": "mm", "t_host_s": "s",
    "point_mm": "mm", "normal": "1", "tip_mm": "mm", "contact_mm": "mm", "kind": "1",
    "z_uT": "µT", "stage_mm": "mm",
}


def trial_name(depth_mm: float) -> str:
    """Group name of the trial at a depth, e.g. ``depth_05.00mm``."""
    return f"depth_{depth_mm:05.2f}mm"


def _write_group(group: h5py.Group, arrays: dict[str, np.ndarray]) -> None:
    for name, values in arrays.items():
        values = np.asarray(values)
        if values.dtype.kind == "U":
            values = values.astype("S")
        h5io.write_array(group, name, values, _UNITS.get(name, "1"))


class StudyWriter:
    """Create or resume a study file and add finished trials atomically.

    Parameters
    ----------
    path
        The study file.
    config
        The full study configuration (stored as JSON; resume refuses a different one).
    sensor_id
        Identity of the sensor.
    resume
        Continue an existing file instead of refusing to overwrite it.
    force
        Replace an existing finished study (the new file, written whole, is renamed over it);
        a partial one is continued with ``resume``, never replaced.
    """

    def __init__(self, path: str | Path, config: dict, sensor_id: str, resume: bool = False,
                 force: bool = False):
        self.path = Path(path)
        self.config = config
        h5io.refuse_to_replace_run(self.path, resume, force, "study")
        if resume:
            self._check_resumable()
        else:
            self._create(sensor_id)

    def _create(self, sensor_id: str) -> None:
        ensure_dir(self.path.parent)
        h5io.create_trials_file(self.path, schema=SCHEMA, schema_version=SCHEMA_VERSION,
                                sensor_id=sensor_id, config=self.config)

    def _check_resumable(self) -> None:
        with h5io.open_h5(self.path) as handle:
            h5io.check_schema(handle, SCHEMA, SUPPORTED_MAJOR, self.path)
            stored = h5io.read_json_attr(handle, "config", {})
        if _comparable(stored) != _comparable(self.config):
            raise UsageError(f"{self.path} was started with another configuration; "
                             "resume it with the same --config or start a new file")

    def _update(self, write) -> None:
        """Apply ``write(handle)`` to a copy of the file and rename it over the original."""
        h5io.update_copy(self.path, write)

    def done_depths(self) -> list[float]:
        """Depths (mm) of the trials already in the file."""
        with h5io.open_h5(self.path) as handle:
            return sorted(float(g.attrs["depth_mm"]) for g in handle["trials"].values())

    def header(self) -> dict[str, Any]:
        """What the header holds so far: baseline and first contact (empty dict before them)."""
        with h5io.open_h5(self.path) as handle:
            return _read_header(handle)

    def write_header(self, baseline_field_uT: np.ndarray, baseline_std_uT: np.ndarray,
                     first_contact_stage_mm: np.ndarray, first_contact_z_uT: float) -> None:
        """Store the static baseline and the stage position of first contact (distance 0)."""
        def write(handle: h5py.File) -> None:
            group = handle.require_group("header")
            h5io.write_array(group, "baseline_field_uT", baseline_field_uT, "µT")
            h5io.write_array(group, "baseline_std_uT", baseline_std_uT, "µT")
            h5io.write_array(group, "first_contact_stage_mm", first_contact_stage_mm, "mm")
            h5io.write_array(group, "first_contact_z_uT", float(first_contact_z_uT), "µT")
        self._update(write)

    def add_trial(self, record: TrialRecord) -> None:
        """Add one finished trial (atomically; replaces nothing that is already there)."""
        def write(handle: h5py.File) -> None:
            group = handle["trials"].create_group(trial_name(record.depth_mm))
            group.attrs["depth_mm"] = float(record.depth_mm)
            for key, value in record.attrs.items():
                group.attrs[key] = value
            for part in ("stream", "stage", "plane"):
                _write_group(group.create_group(part), getattr(record, part))
            if record.truth is not None:
                _write_group(handle.require_group("truth").create_group(group.name.split("/")[-1]),
                             record.truth)
        self._update(write)

    def mark_complete(self) -> None:
        """Set the root attribute ``complete`` once every planned trial is in the file."""
        def write(handle: h5py.File) -> None:
            handle.attrs["complete"] = True
        self._update(write)


def _comparable(config: dict) -> str:
    """The configuration as canonical JSON text (lists and tuples compare equal), without the
    settings that only decide what a run reports (a study started before they existed resumes)."""
    plain = json.loads(json.dumps(config, default=_plain))
    if isinstance(plain.get("safety"), dict):
        plain["safety"].pop("max_frame_loss", None)
    return json.dumps(plain, sort_keys=True)


def _plain(value: Any) -> Any:
    if isinstance(value, (np.ndarray, np.generic)):
        return value.tolist()
    return str(value)


def _read_header(handle: h5py.File) -> dict[str, Any]:
    if "header" not in handle:
        return {}
    return {name: handle["header"][name][()] for name in handle["header"]}


def _read_group(group: h5py.Group) -> dict[str, np.ndarray]:
    out = {}
    for name, dataset in group.items():
        values = dataset[()]
        out[name] = values.astype(str) if values.dtype.kind == "S" else values
    return out


@dataclass
class Study:
    """A study file read into memory."""

    path: Path
    config: dict
    sensor_id: str
    sha256: str
    complete: bool
    header: dict[str, Any]
    trials: list[TrialRecord]

    def missing_depths(self) -> list[float]:
        """Planned depths (mm) that have no trial in the file."""
        planned = [float(d) for d in self.config.get("trials", {}).get("depths_mm", [])]
        done = {round(t.depth_mm, 6) for t in self.trials}
        return [d for d in planned if round(d, 6) not in done]


def read_study(path: str | Path) -> Study:
    """Read a study file (schema checked; an unknown major version is refused).

    Raises
    ------
    ArtifactError
        When the file is missing, not HDF5, or not a study of a supported version.
    """
    path = Path(path)
    with h5io.open_h5(path) as handle, h5io.malformed_is_an_error(path, "study file"):
        h5io.check_schema(handle, SCHEMA, SUPPORTED_MAJOR, path)
        trials = [_read_trial(handle, name) for name in sorted(handle.get("trials", {}))]
        study = Study(path=path, config=h5io.read_json_attr(handle, "config", {}),
                      sensor_id=h5io.as_text(handle.attrs.get("sensor_id", "")),
                      sha256=h5io.sha256_file(path), complete=bool(handle.attrs.get("complete", False)),
                      header=_read_header(handle), trials=trials)
    return study


def _read_trial(handle: h5py.File, name: str) -> TrialRecord:
    group = handle["trials"][name]
    try:
        parts = {part: _read_group(group[part]) for part in ("stream", "stage", "plane")}
    except KeyError as error:
        raise ArtifactError(f"trial {name} is incomplete in the study file ({error})") from None
    truth = _read_group(handle["truth"][name]) if "truth" in handle and name in handle["truth"] else None
    attrs = {key: group.attrs[key] for key in group.attrs if key != "depth_mm"}
    return TrialRecord(depth_mm=float(group.attrs["depth_mm"]), attrs=attrs, truth=truth, **parts)
