"""A reconstruction's points (x, y in mm) from any of the files that hold one.

- a text table (comma, tab, semicolon or spaces between fields; ``#`` lines are comments) with
  or without a header: with a header, the columns ``world_x_mm, world_y_mm`` (a replay's track),
  else ``x, y`` (or ``x_mm, y_mm``), else the table's only two columns; without one, the first
  two columns. Plain tables are in ``units`` (mm or m), columns named ``*_mm`` in mm.
- a replay's track (``whiskercal.replay_track`` HDF5): its ``world_x_mm``, ``world_y_mm``.
- a contour run (``whiskercal.contour_run``): its ``estimate_mm`` while following.

Rows without a finite point (a replay's samples without a contact) are left out and counted.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whiskercal.errors import UsageError

UNITS_MM = {"mm": 1.0, "m": 1000.0}
WORLD_COLUMNS = ("world_x_mm", "world_y_mm")
_XY_COLUMNS = (("x", "y"), ("x_mm", "y_mm"))
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
TRACK_SCHEMA, RUN_SCHEMA = "whiskercal.replay_track", "whiskercal.contour_run"


@dataclass(frozen=True)
class PointSet:
    """Points (n, 2) in mm, where they came from and how many rows had no finite point."""

    xy_mm: np.ndarray
    source: str
    skipped: int


def read_points(path: str | Path, units: str | None = None) -> PointSet:
    """The points of ``path`` (module docstring); ``units`` (mm, m; None: mm) only for a text
    table's unnamed columns. A UsageError or ArtifactError names the file and what is wrong."""
    path = Path(path)
    if units is not None and units not in UNITS_MM:
        raise UsageError(f"--units must be one of {', '.join(UNITS_MM)}, not {units!r}")
    if path.is_dir():
        raise UsageError(f"{path} is a directory, not a table of points")
    try:
        with open(path, "rb") as handle:
            start = handle.read(len(_HDF5_SIGNATURE))
    except OSError as error:
        raise UsageError(f"{path}: cannot read the points ({error.strerror or error})") from None
    if start == _HDF5_SIGNATURE:
        if units not in (None, "mm"):
            raise UsageError(f"{path} records mm: --units applies to text tables only")
        xy, source = _from_h5(path)
    else:
        xy, source = _from_table(path, units)
    return _finite(xy, source, path)


def _finite(xy: np.ndarray, source: str, path: Path) -> PointSet:
    keep = np.all(np.isfinite(xy), axis=1)
    if not keep.any():
        raise UsageError(f"{path}: no finite points ({source})")
    return PointSet(xy[keep], source, int(np.sum(~keep)))


def _from_h5(path: Path) -> tuple[np.ndarray, str]:
    from whiskercal.artifacts import h5io

    with h5io.open_h5(path) as handle:
        schema = h5io.as_text(handle.attrs.get("schema", ""))
        if schema == RUN_SCHEMA:
            return _from_run(path), "the contour run's estimate_mm while following"
        if schema != TRACK_SCHEMA:
            raise UsageError(f"{path}: a {schema or 'schema-less'} file holds no points: give a "
                             "table of x, y, a replay's track or a contour run")
        track = handle["track"] if "track" in handle else {}
        if not all(name in track for name in WORLD_COLUMNS):
            raise UsageError(f"{path}: the track has no {' and '.join(WORLD_COLUMNS)} (a replay "
                             "without poses tracks the tip in the sensor's frame, not the world)")
        xy = np.column_stack([np.asarray(track[name][()], float) for name in WORLD_COLUMNS])
        return xy, f"the track's {', '.join(WORLD_COLUMNS)}"


def _from_run(path: Path) -> np.ndarray:
    from whiskercal.artifacts.contour_run import read_contour_run
    from whiskercal.contour.summary import followed

    run = read_contour_run(path)
    return np.asarray(run.columns["estimate_mm"], float)[followed(run)]


def _from_table(path: Path, units: str | None) -> tuple[np.ndarray, str]:
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise UsageError(f"{path}: not a text table (nor an HDF5 file)") from None
    lines = [(n, line) for n, line in enumerate(text.splitlines(), start=1)
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise UsageError(f"{path}: no points (the file is empty or only comments)")
    separator = _separator(lines[0][1])
    header = _cells(lines[0][1], separator)
    if len(header) < 2:
        raise UsageError(f"{path}: line {lines[0][0]} has a single column; points are x, y per line")
    has_header = not all(_is_number(cell) for cell in header)
    columns, scale, source = _choose(path, header if has_header else None, units)
    rows = lines[1:] if has_header else lines
    if not rows:
        raise UsageError(f"{path}: the table has a header but no points")
    width = len(header)
    table = np.array([_row(path, n, line, separator, width, columns) for n, line in rows], float)
    return table * scale, source


def _separator(line: str) -> str | None:
    """Tab, comma or semicolon when the line has one, else runs of spaces (None)."""
    return next((mark for mark in ("\t", ",", ";") if mark in line), None)


def _cells(line: str, separator: str | None) -> list[str]:
    return [cell.strip() for cell in (line.split(separator) if separator else line.split())]


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _choose(path: Path, header: list[str] | None, units: str | None) -> tuple[tuple[int, int], float, str]:
    """The two columns' indices, the factor to mm, and the words saying which they are."""
    scale = UNITS_MM[units or "mm"]
    if header is None:
        return (0, 1), scale, f"columns 1 and 2 in {units or 'mm'}"
    names = [name.lower() for name in header]
    for pair in (WORLD_COLUMNS,) + _XY_COLUMNS:
        if all(name in names for name in pair):
            in_mm = pair[0].endswith("_mm")
            if in_mm and units not in (None, "mm"):
                raise UsageError(f"{path}: the columns {', '.join(pair)} are in mm; leave out --units")
            return (names.index(pair[0]), names.index(pair[1])), 1.0 if in_mm else scale, \
                f"columns {', '.join(pair)} in {'mm' if in_mm else units or 'mm'}"
    if len(header) == 2:
        return (0, 1), scale, f"columns {header[0]}, {header[1]} in {units or 'mm'}"
    raise UsageError(f"{path}: which columns are x and y? the header has {', '.join(header)}; "
                     f"name them {', '.join(WORLD_COLUMNS)} or x, y")


def _row(path: Path, number_: int, line: str, separator: str | None, width: int,
         columns: tuple[int, int]) -> tuple[float, float]:
    cells = _cells(line, separator)
    if len(cells) != width:
        raise UsageError(f"{path}: line {number_} has {len(cells)} fields, the first line {width}")
    try:
        return float(cells[columns[0]]), float(cells[columns[1]])
    except ValueError:
        raise UsageError(f"{path}: line {number_}: {line.strip()[:60]!r} is not numbers") from None

