"""Checkpoint and resume of a collection run: the journal first, then the HDF5 file.

Every record (header, baseline, point with its raw samples and twin truth, completion) goes to
the append-only journal (durable) and then to the HDF5 file (flushed). Resuming replays the
journal into a fresh HDF5 file, written beside the old one and renamed over it, so a file that a
kill -9 left half-written is simply rebuilt; no point is lost or taken twice. When the run
completes, the HDF5 file is whole and the journal is removed.
"""

from __future__ import annotations

import os
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from whiskercal.artifacts.h5io import open_h5
from whiskercal.artifacts.raw_grid import (POINT_FIELDS, STREAM_FIELDS, Baseline, PointRecord,
                                           RawGridWriter, RawHeader, StreamChunk,
                                           read_plan_fingerprint, read_raw_grid)
from whiskercal.collect.journal import Journal, decode_line, journal_path, replay
from whiskercal.errors import ArtifactError, UsageError
from whiskercal.paths import not_regular_reason


def _header_record(header: RawHeader) -> dict[str, Any]:
    return {"type": "header", "fingerprint": header.fingerprint, "sensor_id": header.sensor_id,
            "rod_radius_mm": header.rod_radius_mm, "config": header.config,
            "inputs": header.inputs, "plan_stage_mm": np.asarray(header.plan_stage_mm),
            "plan_rod_center_mm": np.asarray(header.plan_rod_center_mm)}


def _header_from_record(record: Mapping[str, Any]) -> RawHeader:
    return RawHeader(plan_stage_mm=np.asarray(record["plan_stage_mm"], float).reshape(-1, 2),
                     plan_rod_center_mm=np.asarray(record["plan_rod_center_mm"], float).reshape(-1, 2),
                     config=record["config"], sensor_id=record["sensor_id"],
                     rod_radius_mm=float(record["rod_radius_mm"]), inputs=record["inputs"])


def _stream_from_record(record: Mapping[str, Any] | None) -> StreamChunk | None:
    if not record:
        return None
    arrays = {name: np.asarray(record[name], dtype=spec[1]).reshape(-1, *spec[0])
              for name, spec in STREAM_FIELDS.items()}
    return StreamChunk(**arrays)


def _point_from_record(record: Mapping[str, Any]) -> PointRecord:
    values = {name: np.asarray(record[name], dtype=float) if shape else record[name]
              for name, (shape, _, _) in POINT_FIELDS.items()}
    return PointRecord(**values)


class Checkpoint:
    """The durable state of one run: a raw dataset file and its journal.

    Open with :meth:`start` (a new run) or :meth:`resume` (continue a partial file).
    """

    def __init__(self, path: Path, writer: RawGridWriter, journal: Journal,
                 header: RawHeader, state: dict[str, Any]) -> None:
        self.path = path
        self.header = header
        self._writer = writer
        self._journal = journal
        self.taken: set[int] = set(state.get("taken", ()))
        self.baselines: dict[str, Baseline] = dict(state.get("baselines", {}))
        self.complete: bool = bool(state.get("complete", False))
        self.last_device_t_s: float | None = state.get("last_t_s")
        self.last_wall_s: float | None = state.get("last_wall_s")

    @classmethod
    def start(cls, path: str | Path, header: RawHeader) -> "Checkpoint":
        """Begin a new run, replacing any file and journal at ``path``.

        The new file is created under a hidden name beside ``path`` and renamed over it once its
        header is on disk (the open handle follows the rename): an old dataset is replaced
        whole, never truncated in place, and a name hard-linked to it keeps the old one.
        """
        path = Path(path)
        journal_file = journal_path(path)
        journal_file.unlink(missing_ok=True)
        journal = Journal(journal_file)
        journal.append(_header_record(header))
        scratch = path.with_name(f".{path.name}.new.partial")
        writer = RawGridWriter.create(scratch, header)  # flushed
        try:
            os.replace(scratch, path)
        except BaseException:
            writer.close()
            scratch.unlink(missing_ok=True)
            journal.close()
            raise
        return cls(path, writer, journal, header, {})

    @classmethod
    def resume(cls, path: str | Path, header: RawHeader) -> "Checkpoint":
        """Continue the run recorded at ``path`` (its journal, else the file itself).

        Raises
        ------
        UsageError
            When there is nothing to resume or the recorded plan and configuration differ.
        """
        path = Path(path)
        journal_file = journal_path(path)
        had_journal = journal_file.exists()
        journal = Journal(journal_file)  # locked before anything is read or rebuilt
        try:
            records = _records_to_resume(path, had_journal)
            recorded = records[0]
            if recorded["fingerprint"] != header.fingerprint:
                raise UsageError(f"{path}: cannot resume: it was recorded with a different plan "
                                 "or configuration (start a new file or use the original config)")
            recorded_header = _header_from_record(recorded)
            state = _rebuild(path, recorded_header, records)
            if not had_journal:
                for record in records:
                    journal.append(record)
            return cls(path, RawGridWriter.open_append(path), journal, recorded_header, state)
        except BaseException:
            journal.close()
            if not had_journal:  # the journal this call made holds nothing yet
                journal_file.unlink(missing_ok=True)
            raise

    def add_point(self, point: PointRecord, stream: StreamChunk | None = None,
                  truth: Mapping[str, Any] | None = None) -> None:
        """Record one point durably (journal, then HDF5)."""
        if point.plan_index in self.taken:
            raise ValueError(f"plan point {point.plan_index} is already recorded")
        record = {"type": "point", **asdict(point), "wall_s": time.time(),
                  "stream": None if stream is None else asdict(stream),
                  "truth": None if truth is None else dict(truth)}
        self._journal.append(record)
        self._writer.append_point(point, stream, truth)
        self.taken.add(int(point.plan_index))
        self.last_device_t_s, self.last_wall_s = float(point.t_end_s), record["wall_s"]

    def add_stream(self, stream: StreamChunk) -> None:
        """Record raw samples taken between points."""
        if len(stream):
            self._journal.append({"type": "stream", **asdict(stream)})
            self._writer.append_stream(stream)

    def set_baseline(self, which: str, baseline: Baseline) -> None:
        """Record the ``before`` or ``after`` static reading."""
        self._journal.append({"type": "baseline", "which": which, **asdict(baseline),
                              "wall_s": time.time()})
        self._writer.set_baseline(which, baseline)
        self.baselines[which] = baseline

    def finish(self) -> None:
        """Mark the file complete, close it, and drop the journal it no longer needs."""
        self._journal.append({"type": "complete"})
        self._writer.mark_complete()
        self.close()
        journal_path(self.path).unlink(missing_ok=True)
        self.complete = True

    def close(self) -> None:
        """Close the file and the journal; everything recorded is already durable."""
        self._writer.close()
        self._journal.close()


def recorded_fingerprint(path: str | Path) -> str:
    """The plan fingerprint a partial run was started with (journal header, else the file).

    Raises
    ------
    UsageError
        When there is no run at ``path`` to resume.
    """
    path = Path(path)
    journal_file = journal_path(path)
    for name in (journal_file, path):
        reason = not_regular_reason(name)
        if reason is not None:
            raise UsageError(f"{name}: {reason}: nothing to resume")
    if journal_file.exists():
        with open(journal_file, "rb") as handle:
            header = decode_line(handle.readline())
        if header is not None and header.get("type") == "header":
            return str(header["fingerprint"])
    fingerprint = read_plan_fingerprint(path) if path.exists() else None
    if fingerprint is not None:
        return fingerprint
    if path.exists():
        try:
            open_h5(path).close()
        except ArtifactError as error:
            raise UsageError(f"{error}; its journal {journal_file.name} is gone: nothing to "
                             "resume, start a new --out") from None
    raise UsageError(f"{path}: nothing to resume (no readable file or journal)")


def _records_to_resume(path: Path, had_journal: bool) -> list[dict[str, Any]]:
    if had_journal:
        return replay(journal_path(path))
    if path.exists():
        return _records_from_h5(path)
    raise UsageError(f"{path}: nothing to resume (no such file or journal)")


def _records_from_h5(path: Path) -> list[dict[str, Any]]:
    """Records equivalent to a valid raw dataset, for resuming a file whose journal is gone."""
    try:
        grid = read_raw_grid(path, stream=True)
    except ArtifactError as error:
        raise UsageError(f"cannot resume: {error}") from None
    if grid.complete:
        raise UsageError(f"{path}: the run is already complete; nothing to resume")
    header = RawHeader(grid.plan_stage_mm, grid.plan_rod_center_mm, grid.config, grid.sensor_id,
                       grid.rod_radius_mm)
    records = [{**_header_record(header), "fingerprint": grid.plan_fingerprint},
               {"type": "baseline", "which": "before", **asdict(grid.baseline_before)},
               {"type": "stream", **asdict(grid.stream)}]
    points = {name: getattr(grid, name) for name in POINT_FIELDS}
    for row in range(len(grid)):
        record = {"type": "point", **{name: values[row] for name, values in points.items()},
                  "stream": None,
                  "truth": None if grid.truth is None else {k: v[row] for k, v in grid.truth.items()}}
        records.append(record)
    return records


def _rebuild(path: Path, header: RawHeader, records: list[dict[str, Any]]) -> dict[str, Any]:
    """Write the records into a fresh HDF5 file and rename it over ``path``; return the state."""
    staging = path.with_name(path.name + ".rebuild")
    writer = RawGridWriter.create(staging, header)
    state: dict[str, Any] = {"taken": [], "baselines": {}}
    try:
        try:
            for record in records[1:]:
                _apply(writer, record, state)
        finally:
            writer.close()
        os.replace(staging, path)
    except BaseException:
        staging.unlink(missing_ok=True)
        raise
    return state


def _apply(writer: RawGridWriter, record: Mapping[str, Any], state: dict[str, Any]) -> None:
    kind = record["type"]
    if kind == "point":
        point = _point_from_record(record)
        if point.plan_index in state["taken"]:
            return  # a record can only repeat if a journal was replayed twice: keep the first
        writer.append_point(point, _stream_from_record(record.get("stream")), record.get("truth"))
        state["taken"].append(int(point.plan_index))
        state["last_t_s"], state["last_wall_s"] = float(point.t_end_s), record.get("wall_s")
    elif kind == "stream":
        writer.append_stream(_stream_from_record(record))
    elif kind == "baseline":
        baseline = Baseline(np.asarray(record["field_uT"], float),
                            np.asarray(record["std_uT"], float), float(record["t_s"]))
        writer.set_baseline(record["which"], baseline)
        state["baselines"][record["which"]] = baseline
    elif kind == "complete":
        writer.mark_complete()
        state["complete"] = True
