"""A sensor build described in a TOML file (or a JSON-able dict), and back.

The file has a top-level ``sensor_id`` and the tables ``[whisker]``, ``[magnet]`` (with an
optional ``[magnet.grid]``) and ``[magnetometer]``, whose keys are the fields of
`WhiskerParams`, `MagnetParams` (`FieldGrid`) and `MagnetometerParams`. A key left out takes the
value of `DEFAULT_SENSOR`. An optional ``[nuisances]`` table (``twin.nuisances``: drift, creep,
roughness, the robot's pose) is checked with the rest and read by
``twin.nuisances.load_nuisances``, and a ``[dynamics]`` table (the wire's bending modes, off
unless given) by ``twin.nuisances.load_dynamics``. Every table is a typed model (`SensorFile`), so that a typo, a wrong type
or a non-physical number ends in one line naming the file and the key rather than a traceback
or a silently different sensor. docs/twin.md ("Describe your sensor in a file") has an example;
sensors/ at the repository root holds the shipped sensors and a few other builds as files.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

from pydantic import ValidationInfo, field_validator

from whiskercal.errors import UsageError
from whiskercal.tomlconfig import read_toml
from whiskercal.typedconfig import Table, Text, integer, number, numbers, says_of, shown, validate
from whiskercal.twin.nuisances import DynamicsTable, Nuisances
from whiskercal.twin.params import DEFAULT_SENSOR, SENSORS, SensorParams

__all__ = ["RULES", "SensorFile", "load_sensor", "resolve_sensor", "sensor_from_dict", "sensor_to_dict",
           "sensor_to_toml"]

SECTIONS = ("whisker", "magnet", "magnetometer")


_WHISKER, _MAGNET, _METER = DEFAULT_SENSOR.whisker, DEFAULT_SENSOR.magnet, DEFAULT_SENSOR.magnetometer
_GRID = _MAGNET.grid
MM, POSITIVE_MM = number(says="a number of mm"), number(gt=0, says="a positive number of mm")

# What each key must be, and its value when a file leaves it out (`DEFAULT_SENSOR`'s). Every
# field of the parameter classes has a key (tests check it); the limits are what a physical
# build can have, not what is typical.


class WhiskerTable(Table):
    """``[whisker]``: the fields of `WhiskerParams`."""

    length_mm: POSITIVE_MM = _WHISKER.length_mm
    diameter_mm: POSITIVE_MM = _WHISKER.diameter_mm
    youngs_modulus_n_per_mm2: number(gt=0, says="a positive number of N/mm²") = \
        _WHISKER.youngs_modulus_n_per_mm2
    root_offset_mm: number(ge=0, says="a number of mm >= 0") = _WHISKER.root_offset_mm
    root_rotational_stiffness_n_mm_per_rad: number(gt=0, says="a positive number of N·mm/rad") = \
        _WHISKER.root_rotational_stiffness_n_mm_per_rad
    root_translational_stiffness_n_per_mm: number(gt=0, says="a positive number of N/mm") = \
        _WHISKER.root_translational_stiffness_n_per_mm


class GridTable(Table):
    """``[magnet.grid]``: the fields of `FieldGrid`."""

    rotation_rad: numbers(2, says="an increasing pair of numbers of rad") = _GRID.rotation_rad
    shift_mm: numbers(2, says="an increasing pair of numbers of mm") = _GRID.shift_mm
    rotation_step_rad: number(gt=0, says="a positive number of rad") = _GRID.rotation_step_rad
    shift_step_mm: POSITIVE_MM = _GRID.shift_step_mm
    pad_cells: integer(ge=2, le=64) = _GRID.pad_cells

    @field_validator("rotation_rad", "shift_mm")
    @classmethod
    def _increasing(cls, pair: tuple[float, ...], info: ValidationInfo) -> tuple[float, ...]:
        if not pair[0] < pair[1]:
            unit = "rad" if info.field_name == "rotation_rad" else "mm"
            raise ValueError(f"must be an increasing pair of numbers of {unit}, not {shown(pair)}")
        return pair


class MagnetTable(Table):
    """``[magnet]``: the fields of `MagnetParams`, with ``[magnet.grid]``."""

    diameter_mm: POSITIVE_MM = _MAGNET.diameter_mm
    height_mm: POSITIVE_MM = _MAGNET.height_mm
    # No permanent magnet reaches 2 T (NdFeB: about 1.0-1.5 T); zero would make no field.
    polarization_T: number(ge=-2.0, le=2.0, says="a non-zero number of T within ±2") = \
        _MAGNET.polarization_T
    magnet_center_mm: MM = _MAGNET.magnet_center_mm
    gap_mm: POSITIVE_MM = _MAGNET.gap_mm
    sensor_offset_mm: numbers(3, says="a list of 3 numbers of mm (x, y, w)") = _MAGNET.sensor_offset_mm
    sensor_tilt_rad: number(gt=-math.pi / 2, lt=math.pi / 2, says="a number of rad within ±π/2") = \
        _MAGNET.sensor_tilt_rad
    grid: GridTable = GridTable()

    @field_validator("polarization_T")
    @classmethod
    def _some_field(cls, value: float) -> float:
        if value == 0:
            raise ValueError("must be a non-zero number of T within ±2, not 0")
        return value


class MagnetometerTable(Table):
    """``[magnetometer]``: the fields of `MagnetometerParams`."""

    gain: integer(ge=0, le=7) = _METER.gain
    res: integer(ge=0, le=3) = _METER.res
    osr: integer(ge=0, le=3) = _METER.osr
    filt: integer(ge=0, le=7) = _METER.filt
    rate_hz: number(gt=0, says="a positive number of Hz") = _METER.rate_hz
    noise_uT_rms: numbers(3, ge=0, says="a list of 3 numbers of µT >= 0 (X, Y, Z)") = _METER.noise_uT_rms
    offset_uT: numbers(3, says="a list of 3 numbers of µT (X, Y, Z)") = _METER.offset_uT


class SensorFile(Table):
    """A sensor description: ``sensor_id`` and the three tables (a key left out: the default's)."""

    sensor_id: Text
    whisker: WhiskerTable = WhiskerTable()
    magnet: MagnetTable = MagnetTable()
    magnetometer: MagnetometerTable = MagnetometerTable()
    # what a real rig adds (twin.nuisances): checked here, read by load_nuisances, and no part
    # of the build (SensorParams), so datasets and goldens do not change with it
    nuisances: Nuisances = Nuisances()
    # the whisker's bending modes (twin.physics.dynamics), read by load_dynamics; off by default
    # and likewise no part of the build
    dynamics: DynamicsTable = DynamicsTable()

    @field_validator("sensor_id")
    @classmethod
    def _named(cls, sensor_id: str) -> str:
        if not (sensor_id.strip() and sensor_id == sensor_id.strip()):
            raise ValueError(f"must be a non-empty string without surrounding spaces, not {shown(sensor_id)}")
        return sensor_id


def _rules(table: type[Table]) -> dict[str, Any]:
    return {name: _rules(field.annotation) if isinstance(field.annotation, type)
            and issubclass(field.annotation, Table) else says_of(field)
            for name, field in table.model_fields.items()}


RULES: dict[str, dict[str, Any]] = {name: _rules(SensorFile.model_fields[name].annotation)
                                    for name in SECTIONS}
"""What each key of each table must be ("must be ..."), the nested grid as its own dict."""


def _part(default: Any, table: Table, label: str, where: str) -> Any:
    """``default`` (a parameter class) with every value of ``table``."""
    values = {name: _part(getattr(default, name), value, f"{label}.{name}", where)
              if isinstance(value, Table) else value for name, value in table}
    try:
        return dataclasses.replace(default, **values)
    except UsageError as error:  # a check of the parameter class itself
        raise UsageError(f"{where} [{label}] {error}") from None


def _sensor_id_given(data: dict, where: str) -> None:
    if "sensor_id" not in data:
        raise UsageError(f"{where}: sensor_id is missing; name the build (it is written into every "
                         'dataset), e.g. sensor_id = "lab-110mm"')


def _first_difference(sensor: SensorParams, other: SensorParams) -> str:
    """'[section] key (here vs there)' for the first key where two sensors differ."""
    ours, theirs = sensor_to_dict(sensor), sensor_to_dict(other)
    for section in SECTIONS:
        for key, value in ours[section].items():
            if value != theirs[section][key]:
                return f"[{section}] {key} ({shown(value)} here, {shown(theirs[section][key])} there)"
    return "nothing"


def _check_build(sensor: SensorParams, where: str) -> None:
    """Checks across keys: the sample rate, and a shipped id used for another build."""
    meter = sensor.magnetometer
    if not meter.fits_rate():
        raise UsageError(f"{where} [magnetometer] osr {meter.osr} with filt {meter.filt} takes "
                         f"{meter.sample_time_ms():.2f} ms a sample, longer than the "
                         f"{meter.sample_period_ms():.2f} ms period at rate_hz {meter.rate_hz:g}")
    shipped = SENSORS.get(sensor.sensor_id)
    if shipped is not None and sensor != shipped:
        # Datasets name their sensor by id; the same id for another build would compare
        # calibrations against the wrong truth.
        raise UsageError(f"{where}: sensor_id {sensor.sensor_id!r} names a shipped sensor, but "
                         f"{_first_difference(sensor, shipped)} differs; give this build its own sensor_id")


def sensor_from_dict(data: Any, where: str = "sensor") -> SensorParams:
    """A sensor from a nested dict as `sensor_to_dict` makes it (or a TOML file holds it).

    Parameters
    ----------
    data : dict
        ``sensor_id`` and any of the tables ``whisker``, ``magnet``, ``magnetometer``; a key left
        out takes `DEFAULT_SENSOR`'s value.
    where : str
        Names the source in error messages (the file's path).

    Raises
    ------
    UsageError
        One line naming `where` and the key: unknown keys, wrong types, non-finite or
        non-physical values, a conversion too slow for the sample rate, a shipped sensor's id
        on another build.
    """
    if not isinstance(data, dict):
        raise UsageError(f"{where}: a sensor description must be a table of keys")
    _sensor_id_given(data, where)
    given = validate(SensorFile, data, where)
    parts = {name: _part(getattr(DEFAULT_SENSOR, name), getattr(given, name), name, where)
             for name in SECTIONS}
    sensor = SensorParams(sensor_id=given.sensor_id, **parts)
    _check_build(sensor, where)
    return sensor


def _plain(value: Any) -> Any:
    """Tuples as lists and nested parameter classes as dicts: JSON and TOML friendly."""
    if dataclasses.is_dataclass(value):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, (tuple, list)):
        return [_plain(item) for item in value]
    return value


def sensor_to_dict(sensor: SensorParams) -> dict[str, Any]:
    """Every parameter of a sensor as a JSON-able nested dict; `sensor_from_dict` reads it back."""
    return {"sensor_id": sensor.sensor_id, **{name: _plain(getattr(sensor, name)) for name in SECTIONS}}


def _toml_value(value: Any) -> str:
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a JSON string is a valid TOML basic string
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(item) for item in value) + "]"
    return repr(value)  # int, or a float repr (finite, so valid TOML)


def _toml_table(label: str, table: dict[str, Any]) -> list[str]:
    lines = [f"[{label}]"]
    nested = []
    for key, value in table.items():
        if isinstance(value, dict):
            nested += ["", *_toml_table(f"{label}.{key}", value)]
        else:
            lines.append(f"{key} = {_toml_value(value)}")
    return lines + nested


def sensor_to_toml(sensor: SensorParams) -> str:
    """The sensor as a complete TOML description (every key); `load_sensor` reads it back."""
    data = sensor_to_dict(sensor)
    lines = [f"sensor_id = {_toml_value(data['sensor_id'])}"]
    for name in SECTIONS:
        lines += ["", *_toml_table(name, data[name])]
    return "\n".join(lines) + "\n"


def load_sensor(path: str | Path) -> SensorParams:
    """The sensor described by the TOML file at `path` (see the module's docstring)."""
    if not Path(path).exists():
        raise UsageError(f"{path}: no such sensor file")
    return sensor_from_dict(read_toml(path), str(path))


def resolve_sensor(id_or_path: str | Path) -> SensorParams:
    """A shipped sensor by its id (`twin.params.SENSORS`), or the sensor in a .toml file.

    Raises
    ------
    UsageError
        When the text is neither a shipped id nor a path to a TOML file, or the file is bad.
    """
    text = str(id_or_path)
    if text in SENSORS:
        return SENSORS[text]
    path = Path(text)
    if path.suffix.lower() == ".toml" or path.is_file():
        return load_sensor(path)
    raise UsageError(f"unknown sensor {text!r}: give a shipped sensor id "
                     f"({', '.join(sorted(SENSORS))}) or the path of a .toml sensor file")
