"""A replay's files in its output folder: the tip track (CSV, HDF5), a plot and a summary (JSON).

Every file is written to a temporary name in the same folder, flushed to disk and renamed over
its final name, so a kill at any moment leaves the old file or the new one, never a partial one.
"""

from __future__ import annotations

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

TRACK_SCHEMA = "whiskercal.replay_track"
TRACK_SCHEMA_VERSION = "1.0.0"
FILES = {"csv": "track.csv", "h5": "track.h5", "png": "replay.png", "summary": "summary.json"}
# column: (units, description); the CSV's header and the HDF5 datasets share these names
COLUMNS = {
    "t_s": ("s", "device time of the sample"),
    "z_uT": ("µT", "deflection: sign x (reading - rest)"),
    "contact": ("1", "1 while the collision detector reports contact"),
    "raw_x_mm": ("mm", "tip from the lookup, whisker base frame (NaN without contact)"),
    "raw_y_mm": ("mm", "tip from the lookup, whisker base frame (NaN without contact)"),
    "filtered_x_mm": ("mm", "tip after the constant-state Kalman filter (NaN before its first tip)"),
    "filtered_y_mm": ("mm", "tip after the constant-state Kalman filter (NaN before its first tip)"),
    "out_of_range": ("1", "-1 below, +1 above the calibrated z range (in contact), else 0"),
    "extrapolated": ("1", "1 when the tip came from a range marked as extrapolated"),
}


def columns_of(result: ReplayResult) -> dict[str, np.ndarray]:
    """The track's columns (:data:`COLUMNS`) as arrays (n,)."""
    return {"t_s": result.t_s, "z_uT": result.z_uT, "contact": result.contact.astype(np.int8),
            "raw_x_mm": result.raw_tip_mm[:, 0], "raw_y_mm": result.raw_tip_mm[:, 1],
            "filtered_x_mm": result.filtered_tip_mm[:, 0],
            "filtered_y_mm": result.filtered_tip_mm[:, 1],
            "out_of_range": result.out_of_range.astype(np.int8),
            "extrapolated": result.extrapolated.astype(np.int8)}


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
    formats = ["%.6f", "%.3f", "%d", "%.6f", "%.6f", "%.6f", "%.6f", "%d", "%d"]
    table = np.column_stack(list(columns.values())).astype(float)
    header = ",".join(columns)
    return atomic_write(path, lambda p: np.savetxt(p, table, fmt=formats, delimiter=",",
                                                   header=header, comments=""))


def write_h5(path: Path, result: ReplayResult, summary: dict, sensor_id: str,
             inputs: dict[str, str]) -> Path:
    from whiskercal.artifacts.h5io import open_h5, write_array, write_provenance

    def write(temporary: Path) -> None:
        with open_h5(temporary, "w") as handle:
            write_provenance(handle, schema=TRACK_SCHEMA, schema_version=TRACK_SCHEMA_VERSION,
                             sensor_id=sensor_id, inputs=inputs,
                             config={"rest_uT": result.rest_uT, "policy": result.policy})
            handle.attrs["summary"] = json.dumps(summary, default=jsonable, sort_keys=True)
            group = handle.create_group("track")
            for name, values in columns_of(result).items():
                write_array(group, name, values, COLUMNS[name][0], description=COLUMNS[name][1])

    return atomic_write(path, write)


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
              inputs: dict[str, str] | None = None) -> dict[str, Path]:
    """Write every file of :data:`FILES` into ``out_dir`` (created); return their paths. They are
    renamed into place together once all are written, so a failure leaves the old set whole."""
    ensure_dir(out_dir)
    paths = output_paths(out_dir)
    with atomic_set(paths) as scratch:
        write_csv(scratch["csv"], result)
        write_h5(scratch["h5"], result, summary, sensor_id, inputs or {})
        write_plot(scratch["png"], result, title=result.source)
        write_summary(scratch["summary"],
                      {**summary, "files": {k: p.name for k, p in paths.items()}})
    return paths
