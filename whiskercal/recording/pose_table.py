"""Poses as a text table: ``t_s, x_mm, y_mm, heading_rad`` (a header with those names, in any
order, or no header and the columns in that order); the delimiter as for a field table."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.recording import table
from whiskercal.recording.types import Poses, check_times

POSE_COLUMNS = ("t_s", "x_mm", "y_mm", "heading_rad")


def read_pose_table(path: str | Path) -> Poses:
    """The poses of a table (mm, rad; the heading unwrapped)."""
    path = Path(path)
    lines = table.data_lines(path)
    if not lines:
        raise UsageError(f"{path}: the pose table is empty")
    separator = table.delimiter_of(lines[0][1], None, path)
    first = table.split_line(lines[0][1], separator)
    if table.all_numbers(first):
        names, body, indices = [f"column {k + 1}" for k in range(len(first))], lines, [0, 1, 2, 3]
        if len(first) != 4:
            raise UsageError(f"{path}: a pose table without a header has the columns "
                             f"{', '.join(POSE_COLUMNS)}; this one has {len(first)}")
    else:
        names, body = first, lines[1:]
        missing = [name for name in POSE_COLUMNS if name not in {n.lower() for n in names}]
        if missing:
            raise UsageError(f"{path}: a pose table has the columns {', '.join(POSE_COLUMNS)}; "
                             f"this one lacks {', '.join(missing)} (columns: {', '.join(names)})")
        indices = [table.column_index(names, name, (name,), "pose", path) for name in POSE_COLUMNS]
    values = table.parse_rows(path, body, separator, names, indices)
    check_times(values[:, 0], str(path))
    return Poses(values[:, 0].copy(), np.column_stack([values[:, 1:3], np.unwrap(values[:, 3])]),
                 f"{path} (pose table, mm and rad)")
