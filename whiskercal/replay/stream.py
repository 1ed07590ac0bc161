"""The stream a replay reads: any recording :mod:`whiskercal.recording` reads (a ROS bag, an echo
log, a text table, a whiskercal HDF5 file), with the table options as replay's command line
names them."""

from __future__ import annotations

from pathlib import Path

from whiskercal.recording import Recording, RecordingOptions, TableOptions, read_recording
from whiskercal.recording import table as _table

Stream = Recording
"""A replay's stream is a :class:`whiskercal.recording.Recording`."""
TIME_COLUMNS, FIELD_COLUMNS = _table.TIME_COLUMNS, _table.FIELD_COLUMNS
TIME_UNITS, DELIMITERS = _table.TIME_UNITS, _table.DELIMITERS


def read_stream(path: str | Path, time_column: str | None = None, field_column: str | None = None,
                delimiter: str | None = None, time_unit: str = "s",
                options: RecordingOptions | None = None) -> Recording:
    """Read any recording (told apart by its first bytes and name); the column options apply
    to tables, ``options`` (when given) replaces them all."""
    if options is None:
        options = RecordingOptions(TableOptions(time_column, field_column, delimiter=delimiter,
                                                time_unit=time_unit))
    return read_recording(path, options)


def read_table(path: str | Path, time_column: str | None = None, field_column: str | None = None,
               delimiter: str | None = None, time_unit: str = "s") -> Recording:
    """A text table's time (s) and field (µT) columns
    (:func:`whiskercal.recording.table.read_table`)."""
    return _table.read_table(path, TableOptions(time_column, field_column, delimiter=delimiter,
                                                time_unit=time_unit))
