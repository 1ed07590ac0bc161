"""The trace length of a fit: the arc length (mm) from the suspension's centre of rotation to the
tip, given, or recorded for the raw grid's sensor."""

from __future__ import annotations

from whiskercal.errors import UsageError


def twin_sensor(raw):
    """The twin's :class:`~whiskercal.twin.params.SensorParams` a raw grid was collected on, or
    None: the full description the dataset recorded (``devices.twin_sensor``), else the shipped
    sensor of the same id."""
    from whiskercal.twin.params import SENSORS
    from whiskercal.twin.sensor_file import sensor_from_dict

    devices = raw.config.get("devices", {}) if isinstance(raw.config, dict) else {}
    if isinstance(devices, dict) and devices.get("twin_sensor"):
        return sensor_from_dict(devices["twin_sensor"], "the raw grid's devices.twin_sensor")
    return SENSORS.get(raw.sensor_id)


def recorded_trace_lengths_mm(raw) -> list[tuple[float, str]]:
    """Every trace length (mm) known for this grid, most authoritative first, with its source:
    the raw file's rig config, then the twin sensor of the same id."""
    found = []
    rig = raw.config.get("rig", {}) if isinstance(raw.config, dict) else {}
    if "trace_length_mm" in rig:
        found.append((float(rig["trace_length_mm"]), "the raw grid's rig config"))
    sensor = twin_sensor(raw)
    if sensor is not None:
        found.append((float(sensor.whisker.reach_mm), f"the twin sensor {raw.sensor_id!r}"))
    return found


def resolve_trace_length(raw, given_mm: float | None) -> tuple[float, list[str]]:
    """The trace length (mm) and any warnings: ``given_mm`` (--trace-length-mm), else the raw
    file's rig config, else the twin sensor of the same id; each source that disagrees with the
    one used is named.

    Raises
    ------
    UsageError
        When no length is given and none is recorded for the grid's sensor.
    """
    known = recorded_trace_lengths_mm(raw)
    if given_mm is None and not known:
        raise UsageError("the trace length is unknown for this sensor: give --trace-length-mm "
                         "(arc length from the suspension's centre of rotation to the tip)")
    used, source = (given_mm, "--trace-length-mm") if given_mm is not None else known[0]
    warnings = [f"the trace length {used:g} mm of {source} overrides the {value:g} mm of {where}"
                for value, where in known if abs(value - used) > 1e-6]
    return used, warnings
