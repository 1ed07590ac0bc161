"""A sensor build described in a TOML file (or a JSON-able dict), and back.

The file has a top-level ``sensor_id`` and the tables ``[whisker]``, ``[magnet]`` (with an
optional ``[magnet.grid]``) and ``[magnetometer]``, whose keys are the fields of
`WhiskerParams`, `MagnetParams` (`FieldGrid`) and `MagnetometerParams`. A key left out takes the
value of `DEFAULT_SENSOR`. Every value is checked here, key by key, so that a typo, a wrong type
or a non-physical number ends in one line naming the file and the key rather than a traceback
or a silently different sensor. docs/twin.md ("Describe your sensor in a file") has an example;
sensors/ at the repository root holds the shipped sensors and a few other builds as files.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from whiskercal.errors import UsageError
from whiskercal.tomlconfig import read_toml
from whiskercal.twin.params import DEFAULT_SENSOR, SENSORS, SensorParams
from whiskercal.twin.physics.magnet import FieldGrid

__all__ = ["RULES", "load_sensor", "resolve_sensor", "sensor_from_dict", "sensor_to_dict",
           "sensor_to_toml"]

SECTIONS = ("whisker", "magnet", "magnetometer")


def _is_number(value: Any) -> bool:
    # TOML booleans are Python ints: refuse them as numbers.
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class Number:
    """A finite number that passes `ok`; `says` completes "must be ..."."""

    says: str
    ok: Callable[[float], bool] = lambda value: True

    def parse(self, value: Any) -> float | None:
        """The value as a float, or None when it breaks the rule."""
        return float(value) if _is_number(value) and self.ok(value) else None


@dataclass(frozen=True)
class Integer:
    """A whole number in low..high (a register field)."""

    low: int
    high: int

    @property
    def says(self) -> str:
        return f"an integer in {self.low}..{self.high}"

    def parse(self, value: Any) -> int | None:
        """The value as an int, or None when it breaks the rule."""
        good = isinstance(value, int) and not isinstance(value, bool) and self.low <= value <= self.high
        return int(value) if good else None


@dataclass(frozen=True)
class Vector:
    """A list of `length` finite numbers, each passing `ok`, the whole passing `ok_all`."""

    length: int
    says: str
    ok: Callable[[float], bool] = lambda value: True
    ok_all: Callable[[tuple], bool] = lambda values: True

    def parse(self, value: Any) -> tuple[float, ...] | None:
        """The value as a tuple of floats, or None when it breaks the rule."""
        if not (isinstance(value, (list, tuple)) and len(value) == self.length):
            return None
        if not all(_is_number(item) and self.ok(item) for item in value):
            return None
        values = tuple(float(item) for item in value)
        return values if self.ok_all(values) else None


def _positive(value: float) -> bool:
    return value > 0


def _increasing(pair: tuple) -> bool:
    return pair[0] < pair[1]


# What each key must be. Every field of the parameter classes has a rule (tests check it); the
# limits are what a physical build can have, not what is typical.
RULES: dict[str, dict[str, Any]] = {
    "whisker": {
        "length_mm": Number("a positive number of mm", _positive),
        "diameter_mm": Number("a positive number of mm", _positive),
        "youngs_modulus_n_per_mm2": Number("a positive number of N/mm²", _positive),
        "root_offset_mm": Number("a number of mm >= 0", lambda v: v >= 0),
        "root_rotational_stiffness_n_mm_per_rad": Number("a positive number of N·mm/rad", _positive),
        "root_translational_stiffness_n_per_mm": Number("a positive number of N/mm", _positive),
    },
    "magnet": {
        "diameter_mm": Number("a positive number of mm", _positive),
        "height_mm": Number("a positive number of mm", _positive),
        # No permanent magnet reaches 2 T (NdFeB: about 1.0-1.5 T); zero would make no field.
        "polarization_T": Number("a non-zero number of T within ±2", lambda v: v != 0 and abs(v) <= 2),
        "magnet_center_mm": Number("a number of mm"),
        "gap_mm": Number("a positive number of mm", _positive),
        "sensor_offset_mm": Vector(3, "a list of 3 numbers of mm (x, y, w)"),
        "sensor_tilt_rad": Number("a number of rad within ±π/2", lambda v: abs(v) < math.pi / 2),
        "grid": {
            "rotation_rad": Vector(2, "an increasing pair of numbers of rad", ok_all=_increasing),
            "shift_mm": Vector(2, "an increasing pair of numbers of mm", ok_all=_increasing),
            "rotation_step_rad": Number("a positive number of rad", _positive),
            "shift_step_mm": Number("a positive number of mm", _positive),
            "pad_cells": Integer(2, 64),
        },
    },
    "magnetometer": {
        "gain": Integer(0, 7),
        "res": Integer(0, 3),
        "osr": Integer(0, 3),
        "filt": Integer(0, 7),
        "rate_hz": Number("a positive number of Hz", _positive),
        "noise_uT_rms": Vector(3, "a list of 3 numbers of µT >= 0 (X, Y, Z)", lambda v: v >= 0),
        "offset_uT": Vector(3, "a list of 3 numbers of µT (X, Y, Z)"),
    },
}


def _shown(value: Any) -> str:
    """A value as the user wrote it (TOML-like: strings quoted, numbers bare)."""
    return json.dumps(value, ensure_ascii=False) if isinstance(value, (str, list, bool)) else repr(value)


def _parse_table(table: Any, rules: dict, default: Any, label: str, where: str) -> Any:
    """`default` with the keys of `table` replaced, each checked against `rules`."""
    if not isinstance(table, dict):
        raise UsageError(f"{where}: [{label}] must be a table of keys, got {_shown(table)}")
    values = {}
    for key, value in table.items():
        rule = rules.get(key)
        if rule is None:
            raise UsageError(f"{where}: [{label}] unknown key {key!r} (known: {', '.join(rules)})")
        if isinstance(rule, dict):
            values[key] = _parse_table(value, rule, getattr(default, key), f"{label}.{key}", where)
            continue
        parsed = rule.parse(value)
        if parsed is None:
            raise UsageError(f"{where}: [{label}] {key} must be {rule.says}, got {_shown(value)}")
        values[key] = parsed
    try:
        return dataclasses.replace(default, **values)
    except UsageError as error:  # a check of the parameter class itself
        raise UsageError(f"{where}: [{label}] {error}") from None


def _sensor_id(data: dict, where: str) -> str:
    if "sensor_id" not in data:
        raise UsageError(f"{where}: sensor_id is missing; name the build (it is written into every "
                         'dataset), e.g. sensor_id = "lab-110mm"')
    sensor_id = data["sensor_id"]
    if not (isinstance(sensor_id, str) and sensor_id.strip() and sensor_id == sensor_id.strip()):
        raise UsageError(f"{where}: sensor_id must be a non-empty string without surrounding "
                         f"spaces, got {_shown(sensor_id)}")
    return sensor_id


def _first_difference(sensor: SensorParams, other: SensorParams) -> str:
    """'[section] key (here vs there)' for the first key where two sensors differ."""
    ours, theirs = sensor_to_dict(sensor), sensor_to_dict(other)
    for section in SECTIONS:
        for key, value in ours[section].items():
            if value != theirs[section][key]:
                return f"[{section}] {key} ({_shown(value)} here, {_shown(theirs[section][key])} there)"
    return "nothing"


def _check_build(sensor: SensorParams, where: str) -> None:
    """Checks across keys: the sample rate, and a shipped id used for another build."""
    meter = sensor.magnetometer
    if not meter.fits_rate():
        raise UsageError(f"{where}: [magnetometer] osr {meter.osr} with filt {meter.filt} takes "
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
    for key in data:
        if key != "sensor_id" and key not in SECTIONS:
            raise UsageError(f"{where}: unknown key {key!r} at the top level "
                             f"(known: sensor_id, {', '.join(SECTIONS)})")
    sensor_id = _sensor_id(data, where)
    parts = {name: _parse_table(data.get(name, {}), RULES[name], getattr(DEFAULT_SENSOR, name), name, where)
             for name in SECTIONS}
    sensor = SensorParams(sensor_id=sensor_id, **parts)
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
