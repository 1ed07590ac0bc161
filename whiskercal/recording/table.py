"""Text tables: CSV, TSV, ``;``- or space-separated, with a header line or without one.

With a header, columns are found by name (:data:`TIME_COLUMNS`, :data:`FIELD_COLUMNS`, and the
other axes where the header has them) or chosen (``time_column``, ``field_column``,
``axial_column``). Without one (the first line is all numbers), ``columns`` names them by
position: ``"t,y"`` or ``"t,x,y,z"`` (``_`` skips a column); two columns default to ``t,y`` and
four to ``t,x,y,z``. Every cell used must be a finite number and time must not go back.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.recording.types import Recording

TIME_COLUMNS = ("t_s", "time_s", "time", "t", "timestamp")
"""Header names tried, in order, for the time column when none is chosen."""
FIELD_COLUMNS = ("y_uT", "field_y_uT", "magnetic_y", "y", "by")
"""Header names tried, in order (case-insensitive), for the Y-field column when none is chosen."""
AXIAL_COLUMNS = ("z_uT", "field_z_uT", "magnetic_z", "z", "bz")
"""... for the chip's Z axis: found, the table is read as three axes."""
X_COLUMNS = ("x_uT", "field_x_uT", "magnetic_x", "x", "bx")
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
DELIMITERS = {"comma": ",", "tab": "\t", "semicolon": ";", "space": " "}
DEFAULT_LAYOUTS = {2: "t,y", 4: "t,x,y,z"}
"""A headerless table's columns by their count, when ``columns`` is not given."""


@dataclass(frozen=True)
class TableOptions:
    """How to read a table (every field optional; None: detected or the default)."""

    time_column: str | None = None
    field_column: str | None = None
    axial_column: str | None = None
    """A header's Z column; "none" reads Y alone even where the header has a Z column."""
    columns: str | None = None
    delimiter: str | None = None
    time_unit: str = "s"
    field_scale: float = 1.0
    """µT per unit of the field's cells."""


def read_table(path: str | Path, options: TableOptions = TableOptions()) -> Recording:
    """The table's time (s) and field (µT) columns as a :class:`Recording`."""
    path = Path(path)
    if options.time_unit not in TIME_UNITS:
        raise UsageError(f"time unit must be one of {', '.join(TIME_UNITS)}, not "
                         f"{options.time_unit!r}")
    lines = data_lines(path)
    if not lines:
        raise UsageError(f"{path}: no header line (the file is empty or only comments)")
    separator = delimiter_of(lines[0][1], options.delimiter, path)
    first = split_line(lines[0][1], separator)
    if all_numbers(first):
        names, body = _headerless(first, options, path), lines
        picked = picked_by_position(names, options.columns or DEFAULT_LAYOUTS[len(first)], path)[1]
    else:
        names, body = first, lines[1:]
        picked = _by_name(names, options, path)
    values = parse_rows(path, body, separator, names, [index for _, index in picked])
    return _recording(path, values, picked, names, options)


def _headerless(first: list[str], options: TableOptions, path: Path) -> list[str]:
    if options.columns is None and len(first) not in DEFAULT_LAYOUTS:
        raise UsageError(f"{path}: a table without a header has {len(first)} columns; name them "
                         "with --columns (t,y or t,x,y,z; _ skips one)")
    return [f"column {k + 1}" for k in range(len(first))]


def picked_by_position(names: list[str], layout: str, path: Path):
    """(names, [(role, index)]) for a ``columns`` layout such as ``t,x,y,z``."""
    roles = [role.strip().lower() for role in layout.split(",")]
    unknown = [role for role in roles if role not in ("t", "x", "y", "z", "_")]
    doubled = [role for role in ("t", "x", "y", "z") if roles.count(role) > 1]
    if unknown or doubled or "t" not in roles or "y" not in roles:
        raise UsageError(f"--columns {layout!r}: name each column t, x, y, z or _ (skipped), once "
                         "each, with t and y")
    if len(roles) != len(names):
        raise UsageError(f"{path}: --columns {layout!r} names {len(roles)} columns, the table has "
                         f"{len(names)}")
    picked = [(role, roles.index(role)) for role in ("t", "x", "y", "z") if role in roles]
    return names, picked


def _by_name(names: list[str], options: TableOptions, path: Path) -> list[tuple[str, int]]:
    if options.columns is not None:
        return picked_by_position(names, options.columns, path)[1]
    picked = [("t", column_index(names, options.time_column, TIME_COLUMNS, "time", path)),
              ("y", column_index(names, options.field_column, FIELD_COLUMNS, "field", path))]
    if (options.axial_column or "").lower() == "none":
        return picked
    axial = _optional_column(names, options.axial_column, AXIAL_COLUMNS, "axial", path)
    if axial is not None:
        x = _optional_column(names, None, X_COLUMNS, "x", path)
        picked += [("z", axial)] + ([("x", x)] if x is not None else [])
    return picked


def _recording(path: Path, values: np.ndarray, picked, names, options: TableOptions) -> Recording:
    roles = [role for role, _ in picked]
    t_s = values[:, roles.index("t")] * TIME_UNITS[options.time_unit]
    y = values[:, roles.index("y")] * options.field_scale
    described = ", ".join(f"{role} {names[index]!r}" for role, index in picked)
    source = f"{path} ({described}; time in {options.time_unit})"
    if "z" not in roles:
        return Recording(t_s, y, source)
    x = (values[:, roles.index("x")] * options.field_scale if "x" in roles
         else np.full(len(y), np.nan))
    field = np.column_stack([x, y, values[:, roles.index("z")] * options.field_scale])
    return Recording(t_s, field, source)


def data_lines(path: Path) -> list[tuple[int, str]]:
    """Non-blank, non-comment lines with their 1-based line numbers."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise UsageError(f"{path}: not a text table (not UTF-8) and not an HDF5 file") from None
    except OSError as error:
        raise UsageError(f"{path}: cannot read the stream: {error.strerror or error}") from None
    return [(number, line.rstrip("\r\n")) for number, line in enumerate(text.splitlines(), 1)
            if line.strip() and not line.lstrip().startswith("#")]


def delimiter_of(header: str, chosen: str | None, path: Path) -> str:
    if chosen is not None:
        separator = DELIMITERS.get(chosen, chosen)
        if len(separator) != 1:
            raise UsageError(f"delimiter must be one character or one of "
                             f"{', '.join(DELIMITERS)}, not {chosen!r}")
        return separator
    for separator in ("\t", ",", ";"):
        if separator in header:
            return separator
    if len(header.split()) < 2:
        raise UsageError(f"{path}: line 1 (the header) has a single column; a table needs a time "
                         "and a field column (separated by tab, comma, semicolon or spaces)")
    return " "


def split_line(line: str, separator: str) -> list[str]:
    if separator == " ":
        return line.split()
    return [cell.strip() for cell in next(csv.reader([line], delimiter=separator))]


def all_numbers(cells: list[str]) -> bool:
    try:
        [float(cell) for cell in cells]
    except ValueError:
        return False
    return True


def _optional_column(names: list[str], chosen: str | None, defaults: tuple[str, ...], role: str,
                     path: Path) -> int | None:
    if chosen is None and not any(name.lower() in {n.lower() for n in names} for name in defaults):
        return None
    return column_index(names, chosen, defaults, role, path)


def column_index(names: list[str], chosen: str | None, defaults: tuple[str, ...], role: str,
            path: Path) -> int:
    """The index of the chosen column, or of the first default the header has; a name the
    header holds twice is refused (which of them is the stream is not known)."""
    lowered = [name.lower() for name in names]
    wanted = [chosen] if chosen is not None else list(defaults)
    for name in wanted:
        exact = names.count(name)
        matches = lowered.count(name.lower())
        if matches > 1:
            raise UsageError(f"{path}: the header has {matches} columns named {name!r}; rename "
                             f"them or choose one with --columns")
        if matches:
            return names.index(name) if exact else lowered.index(name.lower())
    what = f"no column {chosen!r}" if chosen is not None else \
        f"no {role} column (looked for {', '.join(defaults)})"
    raise UsageError(f"{path}: {what} in the header (columns: {', '.join(names)}); choose one "
                     f"with --{role}-column")


def parse_rows(path: Path, lines: list[tuple[int, str]], separator: str, names: list[str],
                indices: list[int]) -> np.ndarray:
    """The chosen cells as floats (rows, len(indices)); indices[0] is the time column."""
    if not lines:
        raise UsageError(f"{path}: the table has a header but no samples")
    values = np.empty((len(lines), len(indices)))
    previous_t = -math.inf
    for row, (number, line) in enumerate(lines):
        cells = split_line(line, separator)
        if len(cells) != len(names):
            raise UsageError(f"{path}: line {number} has {len(cells)} fields, the header "
                             f"{len(names)}")
        for k, index in enumerate(indices):
            values[row, k] = _number(cells[index], path, number, names[index])
        if values[row, 0] < previous_t:
            raise UsageError(f"{path}: line {number}, column {names[indices[0]]!r}: time goes "
                             f"back ({values[row, 0]:g} after {previous_t:g})")
        previous_t = values[row, 0]
    return values


def _number(cell: str, path: Path, line: int, column: str) -> float:
    try:
        value = float(cell)
    except ValueError:
        raise UsageError(f"{path}: line {line}, column {column!r}: {cell!r} is not a "
                         "number") from None
    if not math.isfinite(value):
        raise UsageError(f"{path}: line {line}, column {column!r}: {cell!r} is not a finite "
                         "number")
    return value
