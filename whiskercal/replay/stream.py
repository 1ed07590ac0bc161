"""A recorded magnetometer stream for replay: device time (s) and the Y field (µT) per sample.

Two kinds of file are read:

- a text table (CSV, TSV, ``;``- or space-separated) with a header line, a time column and a
  Y-field column (:func:`read_table`); lines starting with ``#`` are skipped;
- the HDF5 files whiskercal records: a raw calibration grid (``whiskercal.raw_grid``: its raw
  sample stream, counts converted with the recorded sensor settings) or a flat-plane study
  (``whiskercal.plane_study``: every trial's stream, in trial order). Both carry the static
  reading taken before the run, which becomes the stream's ``recorded_rest_uT``.

A file that cannot be read gives one :class:`~whiskercal.errors.UsageError` (text) or
:class:`~whiskercal.errors.ArtifactError` (HDF5) naming the file, and for a table the line and
column.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whiskercal.errors import ArtifactError, UsageError

TIME_COLUMNS = ("t_s", "time_s", "time", "t", "timestamp")
"""Header names tried, in order, for the time column when none is chosen."""
FIELD_COLUMNS = ("y_uT", "field_y_uT", "magnetic_y", "y", "by")
"""Header names tried, in order (case-insensitive), for the Y-field column when none is chosen."""
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
DELIMITERS = {"comma": ",", "tab": "\t", "semicolon": ";", "space": " "}
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


@dataclass
class Stream:
    """Samples in time order: ``t_s`` (n,) s and ``field_uT`` (n,) the raw Y reading, µT.

    ``recorded_rest_uT`` is the static Y reading the file itself recorded (None for a table);
    ``source`` says where the samples came from (file and columns or datasets).
    """

    t_s: np.ndarray
    field_uT: np.ndarray
    source: str
    recorded_rest_uT: float | None = None

    def __len__(self) -> int:
        return len(self.t_s)


def read_stream(path: str | Path, time_column: str | None = None, field_column: str | None = None,
                delimiter: str | None = None, time_unit: str = "s") -> Stream:
    """Read a table or a whiskercal HDF5 file (told apart by the file's first bytes).

    The column options apply to tables only; an HDF5 file always gives its Y axis.
    """
    path = Path(path)
    try:
        with path.open("rb") as handle:
            head = handle.read(len(HDF5_SIGNATURE))
    except OSError as error:
        raise UsageError(f"{path}: cannot read the stream: {error.strerror or error}") from None
    if head == HDF5_SIGNATURE:
        return read_hdf5_stream(path)
    return read_table(path, time_column, field_column, delimiter, time_unit)


def read_table(path: str | Path, time_column: str | None = None, field_column: str | None = None,
               delimiter: str | None = None, time_unit: str = "s") -> Stream:
    """A text table's time (converted to s from ``time_unit``) and Y-field (µT) columns.

    ``delimiter``: one of :data:`DELIMITERS` (a name) or the character itself; None detects it
    from the header line (tab, then comma, then semicolon, else runs of spaces). Columns are
    named as in the header (exact, then case-insensitive); None tries :data:`TIME_COLUMNS` and
    :data:`FIELD_COLUMNS`. Every cell used must be a finite number and time must not go back.
    """
    path = Path(path)
    if time_unit not in TIME_UNITS:
        raise UsageError(f"time unit must be one of {', '.join(TIME_UNITS)}, not {time_unit!r}")
    lines = _data_lines(path)
    if not lines:
        raise UsageError(f"{path}: no header line (the file is empty or only comments)")
    header_number, header = lines[0]
    separator = _delimiter(header, delimiter, path)
    names = _split(header, separator)
    t_index = _column(names, time_column, TIME_COLUMNS, "time", path)
    y_index = _column(names, field_column, FIELD_COLUMNS, "field", path)
    t_s, field_uT = _parse_rows(path, lines[1:], separator, names, (t_index, y_index))
    t_s *= TIME_UNITS[time_unit]
    source = f"{path} (time {names[t_index]!r} in {time_unit}, field {names[y_index]!r} in µT)"
    return Stream(t_s, field_uT, source)


def _data_lines(path: Path) -> list[tuple[int, str]]:
    """Non-blank, non-comment lines with their 1-based line numbers."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise UsageError(f"{path}: not a text table (not UTF-8) and not an HDF5 file") from None
    except OSError as error:
        raise UsageError(f"{path}: cannot read the stream: {error.strerror or error}") from None
    return [(number, line.rstrip("\r\n")) for number, line in enumerate(text.splitlines(), 1)
            if line.strip() and not line.lstrip().startswith("#")]


def _delimiter(header: str, chosen: str | None, path: Path) -> str:
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


def _split(line: str, separator: str) -> list[str]:
    if separator == " ":
        return line.split()
    return [cell.strip() for cell in next(csv.reader([line], delimiter=separator))]


def _column(names: list[str], chosen: str | None, defaults: tuple[str, ...], role: str,
            path: Path) -> int:
    """The index of the chosen column, or of the first default the header has."""
    lowered = [name.lower() for name in names]
    wanted = [chosen] if chosen is not None else list(defaults)
    for name in wanted:
        if name in names:
            return names.index(name)
        if name.lower() in lowered:
            return lowered.index(name.lower())
    what = f"no column {chosen!r}" if chosen is not None else \
        f"no {role} column (looked for {', '.join(defaults)})"
    raise UsageError(f"{path}: {what} in the header (columns: {', '.join(names)}); choose one "
                     f"with --{role}-column")


def _parse_rows(path: Path, lines: list[tuple[int, str]], separator: str, names: list[str],
                indices: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    if not lines:
        raise UsageError(f"{path}: the table has a header but no samples")
    values = np.empty((len(lines), 2))
    previous_t = -math.inf
    for row, (number, line) in enumerate(lines):
        cells = _split(line, separator)
        if len(cells) != len(names):
            raise UsageError(f"{path}: line {number} has {len(cells)} fields, the header "
                             f"{len(names)}")
        for k, index in enumerate(indices):
            values[row, k] = _number(cells[index], path, number, names[index])
        if values[row, 0] < previous_t:
            raise UsageError(f"{path}: line {number}, column {names[indices[0]]!r}: time goes "
                             f"back ({values[row, 0]:g} after {previous_t:g})")
        previous_t = values[row, 0]
    return values[:, 0].copy(), values[:, 1].copy()


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


def read_hdf5_stream(path: str | Path) -> Stream:
    """The Y stream of a whiskercal raw grid or plane study, with its recorded static reading."""
    from whiskercal.artifacts import h5io

    path = Path(path)
    with h5io.open_h5(path) as handle:
        schema = h5io.as_text(handle.attrs.get("schema", ""))
    if schema == "whiskercal.raw_grid":
        return _raw_grid_stream(path)
    if schema == "whiskercal.plane_study":
        return _study_stream(path)
    raise ArtifactError(f"{path}: an HDF5 file of schema {schema or 'none'!r} holds no stream to "
                        "replay (whiskercal.raw_grid or whiskercal.plane_study expected)")


def _raw_grid_stream(path: Path) -> Stream:
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.protocol.sensor_config import SensorConfig

    grid = read_raw_grid(path, stream=True)
    settings = grid.config.get("sensor", {})
    try:
        config = SensorConfig(**{k: int(settings[k]) for k in ("gain", "res") if k in settings})
        lsb_y = float(config.lsb_uT[1])
    except (TypeError, ValueError, IndexError, KeyError) as error:
        raise ArtifactError(f"{path}: bad sensor settings in the config ({error})") from None
    stream = grid.stream
    if stream is None or len(stream) == 0:
        raise ArtifactError(f"{path}: the raw grid holds no raw samples")
    return Stream(np.asarray(stream.t_s, float), stream.counts[:, 1].astype(float) * lsb_y,
                  f"{path} (raw grid stream, Y counts x {lsb_y:g} µT)",
                  float(grid.baseline_before_uT[1]))


def _study_stream(path: Path) -> Stream:
    from whiskercal.artifacts.plane_study import read_study

    study = read_study(path)
    trials = [t for t in study.trials if len(t.stream.get("t_s", ())) > 0]
    if not trials:
        raise ArtifactError(f"{path}: the study holds no trial with samples")
    try:
        t_s = np.concatenate([np.asarray(t.stream["t_s"], float) for t in trials])
        field = np.concatenate([np.asarray(t.stream["field_uT"], float)[:, 1] for t in trials])
        rest = float(np.asarray(study.header["baseline_field_uT"], float)[1])
    except (KeyError, IndexError, ValueError) as error:
        raise ArtifactError(f"{path}: a trial's stream or the baseline is malformed "
                            f"({error})") from None
    return Stream(t_s, field, f"{path} (plane study, {len(trials)} trials, field Y)", rest)
