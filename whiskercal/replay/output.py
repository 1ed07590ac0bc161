"""A replay's files in its output folder: the tip track (CSV, HDF5), a plot and a summary (JSON);
with poses also the world-frame plot and a ROS 2 bag (MCAP) of the stream, poses and contacts.

Every file is written to a temporary name in the same folder, flushed to disk and renamed over
its final name, so a kill at any moment leaves the old file or the new one, never a partial one.
"""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path
from typing import Callable

import numpy as np

from whiskercal.atomic import atomic_set
from whiskercal.errors import UsageError
from whiskercal.jsontools import jsonable
from whiskercal.paths import ensure_dir
from whiskercal.replay.run import ReplayResult

FILES = {"csv": "track.csv", "h5": "track.h5", "png": "replay.png", "world_png": "world.png",
         "bag": "rosbag", "summary": "summary.json"}
"""Each file of a replay's folder; ``world_png`` and ``bag`` only with poses (the bag is a
rosbag2 folder, ``rosbag/rosbag.mcap``, that Foxglove opens)."""
WITH_POSES_ONLY = ("world_png", "bag")


def columns_of(result: ReplayResult) -> dict[str, np.ndarray]:
    """The track's columns (:data:`whiskercal.artifacts.replay_track.COLUMNS`) as arrays (n,)."""
    n = len(result)
    nan = np.full(n, np.nan)
    world = result.world_mm if result.world_mm is not None else np.full((n, 2), np.nan)
    base = result.base_pose if result.base_pose is not None else np.full((n, 3), np.nan)
    return {"t_s": result.t_s, "z_uT": result.z_uT, "contact": result.contact.astype(np.int8),
            "raw_x_mm": result.raw_tip_mm[:, 0], "raw_y_mm": result.raw_tip_mm[:, 1],
            "filtered_x_mm": result.filtered_tip_mm[:, 0],
            "filtered_y_mm": result.filtered_tip_mm[:, 1],
            "out_of_range": result.out_of_range.astype(np.int8),
            "extrapolated": result.extrapolated.astype(np.int8),
            "axial_uT": result.axial_uT if result.axial_uT is not None else nan,
            "world_x_mm": world[:, 0], "world_y_mm": world[:, 1],
            "base_x_mm": base[:, 0], "base_y_mm": base[:, 1], "base_heading_rad": base[:, 2]}


def atomic_write(path: Path, write: Callable[[Path], None]) -> Path:
    """Call ``write(temporary)`` in ``path``'s folder, fsync, rename onto ``path``."""
    temporary = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    try:
        write(temporary)
        with open(temporary, "rb+") as handle:
            os.fsync(handle.fileno())
        os.replace(temporary, path)
    except OSError as error:
        raise UsageError(f"cannot write {path}: {error.strerror or error}") from None
    finally:
        if temporary.exists():
            temporary.unlink()
    return path


def output_paths(out_dir: str | Path) -> dict[str, Path]:
    """Where each file goes (the folder is not created here)."""
    return {key: Path(out_dir) / name for key, name in FILES.items()}


def refuse_inputs_as_outputs(out_dir: str | Path, inputs: list[str | Path]) -> None:
    """Refuse an output folder in which a replay output would replace one of ``inputs``."""
    for target in output_paths(out_dir).values():
        for source in inputs:
            if target.exists() and Path(source).exists() and os.path.samefile(target, source):
                raise UsageError(f"{target} is an input of this replay; choose another --out")


def write_csv(path: Path, result: ReplayResult) -> Path:
    columns = columns_of(result)
    formats = ["%d" if name in ("contact", "out_of_range", "extrapolated") else
               "%.3f" if name.endswith("_uT") else "%.6f" for name in columns]
    table = np.column_stack(list(columns.values())).astype(float)
    header = ",".join(columns)
    return atomic_write(path, lambda p: np.savetxt(p, table, fmt=formats, delimiter=",",
                                                   header=header, comments=""))


def write_h5(path: Path, result: ReplayResult, summary: dict, sensor_id: str,
             inputs: dict[str, str]) -> Path:
    from whiskercal.artifacts.replay_track import write_track

    config = {"rest_uT": result.rest_uT, "axial_rest_uT": result.axial_rest_uT,
              "policy": result.policy, "world": result.world}
    try:
        return write_track(path, columns_of(result), summary, sensor_id, inputs, config)
    except OSError as error:
        raise UsageError(f"cannot write {path}: {error.strerror or error}") from None


def write_world_plot(path: Path, result: ReplayResult, title: str = "") -> Path:
    """The contacts in the world frame (filtered, dots) and the sensor base's path."""
    from whiskercal.plotting import pyplot, save_png

    plt = pyplot()
    fig, axes = plt.subplots(figsize=(7, 7))
    axes.plot(result.base_pose[:, 0], result.base_pose[:, 1], lw=0.6, color="tab:gray",
              label="sensor base")
    axes.plot(result.world_mm[:, 0], result.world_mm[:, 1], ".", ms=1.5, color="tab:red",
              label="contact (filtered)")
    axes.set_aspect("equal", adjustable="datalim")
    axes.set_xlabel("world x (mm)")
    axes.set_ylabel("world y (mm)")
    axes.legend(loc="best", fontsize=8)
    if title:
        axes.set_title(title, fontsize=9)
    return atomic_write(path, lambda p: save_png(fig, p))


def track_bag_series(result: ReplayResult, field_uT: np.ndarray) -> list:
    """The field stream, the sensor base's poses and the world-frame contacts as a bag's series."""
    from whiskercal.recording.bagwrite import (CONTACT_TOPIC, FIELD_TOPIC, POSE_TOPIC,
                                               SENSOR_FRAME, Series)

    field = np.asarray(field_uT, float)
    if field.ndim == 1:  # Y alone: X and Z unknown, NaN would drop the message
        field = np.column_stack([np.zeros(len(field)), field, np.zeros(len(field))])
    field = np.where(np.isfinite(field), field, 0.0)
    return [Series(FIELD_TOPIC, "field", result.t_s, field, SENSOR_FRAME),
            Series(POSE_TOPIC, "pose", result.t_s, result.base_pose),
            Series(CONTACT_TOPIC, "point", result.t_s, result.world_mm)]


def write_summary(path: Path, summary: dict) -> Path:
    text = json.dumps(summary, default=jsonable, indent=2) + "\n"
    return atomic_write(path, lambda p: p.write_text(text, encoding="utf-8"))


def write_plot(path: Path, result: ReplayResult, title: str = "") -> Path:
    """z over time with the calibrated range, and the tip's x and y (raw and filtered)."""
    from whiskercal.plotting import pyplot, save_png

    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    low, high = result.z_range_uT
    top.axhspan(low, high, color="tab:green", alpha=0.12, label="calibrated range")
    top.plot(result.t_s, result.z_uT, lw=0.6, color="tab:blue", label="z")
    flagged = result.out_of_range != 0
    top.plot(result.t_s[flagged], result.z_uT[flagged], ".", ms=2, color="tab:red",
             label=f"out of range ({result.policy})")
    top.set_ylabel("z (µT)")
    top.legend(loc="lower left", fontsize=8)
    for k, (axis, colour) in enumerate((("x", "tab:orange"), ("y", "tab:purple"))):
        bottom.plot(result.t_s, result.raw_tip_mm[:, k], ".", ms=1, alpha=0.3, color=colour)
        bottom.plot(result.t_s, result.filtered_tip_mm[:, k], lw=0.8, color=colour,
                    label=f"tip {axis} (filtered; dots raw)")
    bottom.set_xlabel("time (s)")
    bottom.set_ylabel("tip (mm)")
    bottom.legend(loc="lower left", fontsize=8)
    if title:
        top.set_title(title, fontsize=9)
    return atomic_write(path, lambda p: save_png(fig, p))


def write_all(out_dir: str | Path, result: ReplayResult, summary: dict, sensor_id: str = "",
              inputs: dict[str, str] | None = None,
              field_uT: np.ndarray | None = None) -> dict[str, Path]:
    """Write every file of :data:`FILES` into ``out_dir`` (created): the world plot and the bag
    only when the replay had poses (the bag's field stream is ``field_uT``, the readings as
    recorded); return their paths. The files are renamed into place together once all are
    written, so a failure leaves the old set whole; the bag, a folder, is staged beside its place
    and renamed with them."""
    from whiskercal.recording.bagwrite import staged_bag

    ensure_dir(out_dir)
    paths = output_paths(out_dir)
    if result.world_mm is None:
        paths = {k: p for k, p in paths.items() if k not in WITH_POSES_ONLY}
    files = {k: p for k, p in paths.items() if k != "bag"}
    with contextlib.ExitStack() as stack:
        scratch = stack.enter_context(atomic_set(files))
        if "bag" in paths:  # renamed into place with the files, or removed with them
            series = track_bag_series(result, result.z_uT if field_uT is None else field_uT)
            stack.enter_context(staged_bag(paths["bag"], series, replace=True))
        write_csv(scratch["csv"], result)
        write_h5(scratch["h5"], result, summary, sensor_id, inputs or {})
        write_plot(scratch["png"], result, title=result.source)
        if "world_png" in scratch:
            write_world_plot(scratch["world_png"], result, title=result.source)
        write_summary(scratch["summary"],
                      {**summary, "files": {k: p.name for k, p in paths.items()}})
    return paths
