"""The raw calibration dataset (schema ``whiskercal.raw_grid``): written point by point, read whole.

``whiskercal collect`` appends one grid point at a time through :class:`RawGridWriter` and
flushes after each, so a stopped run leaves a valid file with every point taken so far;
``whiskercal fit`` reads it with :func:`read_raw_grid`, and a resumed run reads it back the same
way (``stream=True``) when its journal is gone. docs/formats.md describes the layout. The
crash-proof copy of the same records is the collection run's side journal
(``whiskercal/collect/checkpoint.py``).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping

import h5py
import numpy as np

from whiskercal.artifacts.h5io import (check_schema, malformed_is_an_error, open_h5, read_array,
                                       read_json_attr, sha256_file, write_array,
                                       write_provenance)
from whiskercal.errors import ArtifactError

SCHEMA = "whiskercal.raw_grid"
# 1.1.0: config.plan.tip_sweep (where the tip sweep's points begin); 1.0.0 files have none
SCHEMA_VERSION = "1.1.0"
SUPPORTED_MAJOR = 1

# name: (trailing shape, dtype, units); N rows grow along the first axis.
POINT_FIELDS: dict[str, tuple[tuple[int, ...], Any, str]] = {
    "plan_index": ((), np.int32, "1"),
    "commanded_mm": ((2,), np.float64, "mm"),
    "encoder_mm": ((2,), np.float64, "mm"),
    "rod_center_mm": ((2,), np.float64, "mm"),
    "field_mean_uT": ((3,), np.float64, "µT"),
    "field_std_uT": ((3,), np.float64, "µT"),
    "n_samples": ((), np.int32, "1"),
    "t_start_s": ((), np.float64, "s"),
    "t_end_s": ((), np.float64, "s"),
    "dropped": ((), np.int32, "1"),
    "corrupt": ((), np.int32, "1"),
}
STREAM_FIELDS: dict[str, tuple[tuple[int, ...], Any, str]] = {
    "seq": ((), np.int32, "1"),
    "t_s": ((), np.float64, "s"),
    "counts": ((3,), np.int16, "1"),
    "status": ((), np.uint8, "1"),
    "point": ((), np.int32, "1"),
}
# The twin's ground truth per point, kept apart under /truth.
TRUTH_FIELDS: dict[str, tuple[tuple[int, ...], Any, str]] = {
    "stage_mm": ((2,), np.float64, "mm"),
    "rod_center_mm": ((2,), np.float64, "mm"),
    "contact_mm": ((2,), np.float64, "mm"),
    "contact_arc_mm": ((), np.float64, "mm"),
    "tip_mm": ((2,), np.float64, "mm"),
    "kind": ((), h5py.string_dtype(), "1"),
    "root_rotation_rad": ((), np.float64, "rad"),
    "z_uT": ((), np.float64, "µT"),
}


@dataclass
class RawHeader:
    """What a raw dataset knows before its first point: the plan and the run's settings.

    ``config`` is the whole configuration (plan summary, rig geometry, rod radius, sensor
    settings, device identities) as JSON-able values.
    """

    plan_stage_mm: np.ndarray
    plan_rod_center_mm: np.ndarray
    config: dict[str, Any]
    sensor_id: str
    rod_radius_mm: float
    inputs: dict[str, str] = field(default_factory=dict)

    @property
    def fingerprint(self) -> str:
        """SHA-256 of the plan and the settings that shape the data: resume needs it equal."""
        return plan_fingerprint(self.plan_stage_mm, self.config)


# settings that only decide what a run reports: changing them still resumes a run
_NOT_SHAPING = ("max_frame_loss", "on_overload")


def plan_fingerprint(plan_stage_mm: np.ndarray, config: Mapping[str, Any]) -> str:
    """SHA-256 over the planned positions and the configuration (device identities excluded)."""
    shaping = {key: value for key, value in config.items() if key != "devices"}
    if isinstance(shaping.get("safety"), Mapping):  # a warning threshold shapes no data
        shaping["safety"] = {k: v for k, v in shaping["safety"].items() if k not in _NOT_SHAPING}
    digest = hashlib.sha256(json.dumps(shaping, sort_keys=True, default=str).encode())
    digest.update(np.ascontiguousarray(plan_stage_mm, dtype=np.float64).tobytes())
    return digest.hexdigest()


@dataclass
class PointRecord:
    """One grid point as measured: positions in mm, field in µT, device times in s."""

    plan_index: int
    commanded_mm: np.ndarray
    encoder_mm: np.ndarray
    rod_center_mm: np.ndarray
    field_mean_uT: np.ndarray
    field_std_uT: np.ndarray
    n_samples: int
    t_start_s: float
    t_end_s: float
    dropped: int = 0
    corrupt: int = 0


@dataclass
class StreamChunk:
    """Raw samples as received: sequence numbers, device time s, counts, status, plan index."""

    seq: np.ndarray
    t_s: np.ndarray
    counts: np.ndarray
    status: np.ndarray
    point: np.ndarray

    def __len__(self) -> int:
        return len(self.seq)


@dataclass
class Baseline:
    """A static (no contact) reading: mean and standard deviation in µT, device time in s."""

    field_uT: np.ndarray
    std_uT: np.ndarray
    t_s: float


def _create_growing(group: h5py.Group, name: str, spec: tuple, compress: bool = False) -> None:
    shape, dtype, units = spec
    # the raw stream is most of a file: compressed (lossless) it takes about a third the space
    packing = {"compression": "gzip", "compression_opts": 4, "shuffle": True} if compress else {}
    dataset = group.create_dataset(name, shape=(0, *shape), maxshape=(None, *shape),
                                   dtype=dtype, chunks=(1024 if compress else 64, *shape), **packing)
    dataset.attrs["units"] = units


def _append_rows(dataset: h5py.Dataset, rows: Any) -> None:
    if len(rows) == 0:
        return
    rows = np.asarray(rows)
    start = dataset.shape[0]
    dataset.resize(start + len(rows), axis=0)
    dataset[start:] = rows


def _truth_fill(name: str) -> Any:
    shape, dtype, _ = TRUTH_FIELDS[name]
    return "" if dtype is TRUTH_FIELDS["kind"][1] else np.full(shape, np.nan)


class RawGridWriter:
    """Append-only writer of a raw dataset; every append is flushed to the file.

    Create a new file with :meth:`create`, or continue one with :meth:`open_append`.
    """

    def __init__(self, handle: h5py.File) -> None:
        self._file = handle

    @classmethod
    def create(cls, path: str | Path, header: RawHeader) -> "RawGridWriter":
        """Write a new file (replacing any) with the header and empty point tables."""
        handle = open_h5(path, "w")
        write_provenance(handle, schema=SCHEMA, schema_version=SCHEMA_VERSION,
                         sensor_id=header.sensor_id, inputs=header.inputs, config=header.config)
        handle.attrs["rod_radius_mm"] = float(header.rod_radius_mm)
        handle.attrs["complete"] = False
        handle.attrs["plan_fingerprint"] = header.fingerprint
        plan = handle.create_group("plan")
        write_array(plan, "stage_mm", np.asarray(header.plan_stage_mm, float), "mm")
        write_array(plan, "rod_center_mm", np.asarray(header.plan_rod_center_mm, float), "mm")
        for group_name, fields in (("points", POINT_FIELDS), ("stream", STREAM_FIELDS)):
            group = handle.create_group(group_name)
            for name, spec in fields.items():
                _create_growing(group, name, spec, compress=group_name == "stream")
        handle.create_group("baseline")
        handle.flush()
        return cls(handle)

    @classmethod
    def open_append(cls, path: str | Path) -> "RawGridWriter":
        """Open an existing raw dataset to append more points."""
        handle = open_h5(path, "a")
        check_schema(handle, SCHEMA, SUPPORTED_MAJOR, path)
        return cls(handle)

    @property
    def n_points(self) -> int:
        """Points written so far."""
        return int(self._file["points/plan_index"].shape[0])

    def append_point(self, point: PointRecord, stream: StreamChunk | None = None,
                     truth: Mapping[str, Any] | None = None) -> None:
        """Append one point (its stream samples and twin truth too) and flush."""
        points = self._file["points"]
        for name in POINT_FIELDS:
            _append_rows(points[name], [getattr(point, name)])
        if truth is not None or "truth" in self._file:
            self._append_truth(truth or {})
        if stream is not None and len(stream):
            self._append_stream(stream)
        self._file.flush()

    def append_stream(self, stream: StreamChunk) -> None:
        """Append samples taken between points (``point`` = -1) and flush."""
        if len(stream):
            self._append_stream(stream)
            self._file.flush()

    def _append_stream(self, stream: StreamChunk) -> None:
        group = self._file["stream"]
        for name in STREAM_FIELDS:
            _append_rows(group[name], getattr(stream, name))

    def _append_truth(self, truth: Mapping[str, Any]) -> None:
        """One truth row per point: fields missing from a row are NaN (or "" for text)."""
        unknown = set(truth) - set(TRUTH_FIELDS)
        if unknown:
            raise ValueError(f"unknown truth fields {sorted(unknown)}")
        group = self._file.require_group("truth")
        n_before = self.n_points - 1
        for name in truth:
            if name not in group:
                _create_growing(group, name, TRUTH_FIELDS[name])
                _append_rows(group[name], [_truth_fill(name)] * n_before)
        for name in group:
            _append_rows(group[name], [truth.get(name, _truth_fill(name))])

    def set_baseline(self, which: str, baseline: Baseline) -> None:
        """Store the ``before`` or ``after`` static reading and flush."""
        if which not in ("before", "after"):
            raise ValueError(f"baseline must be 'before' or 'after', not {which!r}")
        group = self._file["baseline"]
        write_array(group, f"{which}_field_uT", np.asarray(baseline.field_uT, float), "µT")
        write_array(group, f"{which}_std_uT", np.asarray(baseline.std_uT, float), "µT")
        write_array(group, f"t_{which}_s", float(baseline.t_s), "s")
        self._file.flush()

    def mark_complete(self) -> None:
        """Record that every planned point and the after-baseline are in the file."""
        self._file.attrs["complete"] = True
        self._file.flush()

    def close(self) -> None:
        """Flush and close the file."""
        if self._file.id.valid:
            self._file.flush()
            self._file.close()


@dataclass(frozen=True)
class FrameQuality:
    """Sensor frames of a run: samples received, frames dropped (sequence gaps) and corrupt."""

    received: int
    dropped: int
    corrupt: int

    @property
    def loss_fraction(self) -> float:
        """Frames lost (dropped or corrupt) per frame sent."""
        sent = self.received + self.dropped + self.corrupt
        return (self.dropped + self.corrupt) / sent if sent else 0.0

    def warning(self, limit: float) -> str | None:
        """One line when more than ``limit`` (a fraction) of the frames were lost, else None."""
        if self.loss_fraction <= limit:
            return None
        return (f"{100 * self.loss_fraction:.1f} % of the sensor's frames were lost "
                f"({self.dropped} dropped, {self.corrupt} corrupt, {self.received} received; "
                f"limit {100 * limit:g} %): check the cable, the USB hub and the host's load")

    def to_dict(self) -> dict:
        """Plain values for JSON."""
        return {"received": self.received, "dropped": self.dropped, "corrupt": self.corrupt,
                "loss_fraction": self.loss_fraction}


@dataclass
class RawGrid:
    """A raw calibration dataset as numpy arrays (mm, µT, s).

    ``z_uT`` is the field's Y mean minus the static baseline, which is interpolated linearly in
    device time between the before and after readings when both exist (drift), else the before
    reading. ``truth`` holds the twin's ground truth per point (None for a real rig). Every
    column of /points is here under its own name (``POINT_FIELDS``); ``stream`` only when the
    reader was asked for it (the raw samples are most of a file and the fit does not need them).
    """

    rod_center_mm: np.ndarray
    z_uT: np.ndarray
    z_std_uT: np.ndarray
    n_samples: np.ndarray
    rod_radius_mm: float
    sensor_id: str
    config: dict[str, Any]
    sha256: str
    complete: bool
    truth: dict[str, np.ndarray] | None
    plan_index: np.ndarray
    field_mean_uT: np.ndarray
    field_std_uT: np.ndarray
    commanded_mm: np.ndarray
    encoder_mm: np.ndarray
    t_start_s: np.ndarray
    t_end_s: np.ndarray
    t_mid_s: np.ndarray
    dropped: np.ndarray
    corrupt: np.ndarray
    plan_stage_mm: np.ndarray
    plan_rod_center_mm: np.ndarray
    baseline_before: Baseline
    baseline_after: Baseline | None
    plan_fingerprint: str = ""
    stream: StreamChunk | None = None
    path: str = ""

    def __len__(self) -> int:
        return len(self.z_uT)

    @property
    def sweep(self) -> np.ndarray:
        """Mask (n,) of the tip sweep's points (``collect.sweep``): plan indices from the
        recorded ``config.plan.tip_sweep.first_index`` on; none in a file without a sweep."""
        first = tip_sweep_first_index(self.config)
        if first is None:
            return np.zeros(len(self.plan_index), bool)
        return self.plan_index >= first

    def without_sweep(self) -> "RawGrid":
        """The grid's own points (the level set's input): the tip sweep's left out."""
        keep = ~self.sweep
        if keep.all():
            return self
        per_point = {name: getattr(self, name)[keep] for name in POINT_FIELDS}
        truth = None if self.truth is None else {k: v[keep] for k, v in self.truth.items()}
        return replace(self, z_uT=self.z_uT[keep], z_std_uT=self.z_std_uT[keep],
                       t_mid_s=self.t_mid_s[keep], truth=truth, **per_point)

    @property
    def encoders(self) -> str:
        """How the stage positions were known: measured by encoders, or "none" (open loop);
        "unknown" for files written before it was recorded."""
        devices = self.config.get("devices", {})
        if "encoders" in devices:
            return str(devices["encoders"])
        has = devices.get("stage", {}).get("has_encoder")
        return "unknown" if has is None else ("measured" if has else "none")

    @property
    def z_sem_uT(self) -> np.ndarray:
        """Standard error (n,) µT of each grid point's mean z."""
        return self.z_std_uT / np.sqrt(np.maximum(self.n_samples, 1))

    @property
    def frames(self) -> "FrameQuality":
        """Samples kept in the stream and frames lost on the line (read with ``stream=True``)."""
        if self.stream is None:
            raise ValueError("frame counts need the stream: read_raw_grid(path, stream=True)")
        return FrameQuality(len(self.stream), int(np.sum(self.dropped)), int(np.sum(self.corrupt)))

    @property
    def baseline_before_uT(self) -> np.ndarray:
        """The static reading before the grid, X Y Z µT."""
        return self.baseline_before.field_uT

    @property
    def baseline_after_uT(self) -> np.ndarray | None:
        """The static reading after the grid, X Y Z µT (None until the run completes)."""
        return None if self.baseline_after is None else self.baseline_after.field_uT


def tip_sweep_first_index(config: Mapping[str, Any]) -> int | None:
    """The plan index where a dataset's tip sweep begins, from its recorded config, or None."""
    plan = config.get("plan") if isinstance(config, Mapping) else None
    sweep = plan.get("tip_sweep") if isinstance(plan, Mapping) else None
    first = sweep.get("first_index") if isinstance(sweep, Mapping) else None
    return int(first) if isinstance(first, (int, np.integer)) and not isinstance(first, bool) \
        else None


def baseline_y_at(t_s: np.ndarray, before: tuple[float, float],
                  after: tuple[float, float] | None) -> np.ndarray:
    """Static Y reading (µT) at device times ``t_s``, from (time s, value µT) pairs.

    Linear in time between ``before`` and ``after`` (sensor drift), constant when only the
    before reading exists or both were taken at the same time.
    """
    t_s = np.asarray(t_s, dtype=float)
    t0, y0 = before
    if after is None or after[0] == t0:
        return np.full_like(t_s, y0)
    t1, y1 = after
    return y0 + (y1 - y0) * (t_s - t0) / (t1 - t0)


def _read_truth(handle: h5py.File) -> dict[str, np.ndarray] | None:
    """The /truth group of an open raw dataset as arrays (text as str), or None."""
    if "truth" not in handle:
        return None
    truth = {}
    for name, dataset in handle["truth"].items():
        values = dataset[()]
        if dataset.dtype.kind == "O":
            values = np.array([v.decode() if isinstance(v, bytes) else str(v) for v in values])
        truth[name] = values
    return truth


def _read_baseline(group: h5py.Group, which: str) -> Baseline:
    return Baseline(group[f"{which}_field_uT"][()], group[f"{which}_std_uT"][()],
                    float(group[f"t_{which}_s"][()]))


def _read_baselines(handle: h5py.File, path: Path) -> tuple[Baseline, Baseline | None]:
    group = handle["baseline"] if "baseline" in handle else None
    if group is None or "before_field_uT" not in group:
        raise ArtifactError(f"{path}: no static baseline recorded (the run stopped before it)")
    after = _read_baseline(group, "after") if "after_field_uT" in group else None
    return _read_baseline(group, "before"), after


def _read_stream(handle: h5py.File, path: Path) -> StreamChunk:
    return StreamChunk(**{name: read_array(handle["stream"], name, path) for name in STREAM_FIELDS})


def read_raw_grid(path: str | Path, *, stream: bool = False) -> RawGrid:
    """Load a raw calibration dataset (complete or partial); its raw samples too when ``stream``.

    Raises
    ------
    ArtifactError
        When the file is missing, not a raw grid, of an unknown major version, or has no
        static baseline.
    """
    path = Path(path)
    try:
        handle = open_h5(path)
    except ArtifactError as error:
        if "truncated" not in str(error):
            raise
        hint = journal_hint(path) or "no collection journal next to it; record it again"
        raise ArtifactError(f"{error}; {hint}") from None
    with handle, malformed_is_an_error(path, "raw grid"):
        check_schema(handle, SCHEMA, SUPPORTED_MAJOR, path)
        grid = _grid_from(handle, path)
        if stream:
            grid.stream = _read_stream(handle, path)
    grid.sha256 = sha256_file(path)
    return grid


def journal_hint(path: str | Path) -> str | None:
    """What the collection journal next to a torn file holds, and how to go on from it.

    The journal (``RAW.h5.journal``, written by whiskercal.collect.journal) holds one CRC-checked
    JSON line per record, its header first; only the header and the point count are read here.
    None when there is no readable journal.
    """
    path = Path(path)
    journal = path.with_name(path.name + ".journal")
    resume = f"continue with whiskercal collect --resume --out {path} (same --config)"
    try:
        lines = journal.read_bytes().splitlines()
        planned = len(json.loads(lines[0][9:])["plan_stage_mm"])
    except (OSError, IndexError, KeyError, TypeError, ValueError):
        return None
    taken = len({json.loads(line[9:])["plan_index"] for line in lines[1:]
                 if b'"type":"point"' in line and _json_ok(line[9:])})
    return f"its journal holds {taken} of {planned} points: {resume}"


def _json_ok(body: bytes) -> bool:
    try:
        return "plan_index" in json.loads(body)
    except ValueError:
        return False


def read_plan_fingerprint(path: str | Path) -> str | None:
    """The plan fingerprint a raw dataset was started with ("" when it has none), or None when
    the file does not open (a run killed before its first flush leaves such a file)."""
    try:
        with open_h5(path) as handle:
            return str(handle.attrs.get("plan_fingerprint", ""))
    except ArtifactError:
        return None


def _grid_from(handle: h5py.File, path: Path) -> RawGrid:
    columns = {name: read_array(handle["points"], name, path) for name in POINT_FIELDS}
    before, after = _read_baselines(handle, path)
    t_mid = 0.5 * (columns["t_start_s"] + columns["t_end_s"])
    static_y = baseline_y_at(t_mid, (before.t_s, before.field_uT[1]),
                             None if after is None else (after.t_s, after.field_uT[1]))
    return RawGrid(
        z_uT=columns["field_mean_uT"][:, 1] - static_y,
        z_std_uT=columns["field_std_uT"][:, 1],
        rod_radius_mm=float(handle.attrs["rod_radius_mm"]),
        sensor_id=str(handle.attrs["sensor_id"]),
        config=read_json_attr(handle, "config", {}),
        sha256="",
        complete=bool(handle.attrs.get("complete", False)),
        truth=_read_truth(handle),
        t_mid_s=t_mid,
        plan_stage_mm=read_array(handle["plan"], "stage_mm", path),
        plan_rod_center_mm=read_array(handle["plan"], "rod_center_mm", path),
        baseline_before=before,
        baseline_after=after,
        plan_fingerprint=str(handle.attrs.get("plan_fingerprint", "")),
        path=str(path),
        **columns,
    )
