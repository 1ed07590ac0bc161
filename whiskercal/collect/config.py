"""The collection run's configuration: documented defaults (default_grid.toml) plus a user file.

A user file overrides any key of the defaults; a key the defaults do not have is refused, so
a typo never silently falls back to a default.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

from whiskercal.errors import UsageError
from whiskercal.tomlconfig import merge_overrides, read_toml

DEFAULT_CONFIG_PATH = Path(__file__).with_name("default_grid.toml")


@dataclass(frozen=True)
class RigConfig:
    """Rig geometry: whisker frame origin in stage coordinates (mm), frame angle (deg), rod (mm).

    ``trace_length_mm`` is the whisker's arc length from the centre of rotation to the tip, which
    `whiskercal fit` traces; ``sensor_id`` names the whisker sensor (empty: taken from the device).
    """

    origin_stage_mm: tuple[float, float]
    angle_deg: float
    rod_radius_mm: float
    whisker_reach_mm: float
    trace_length_mm: float
    sensor_id: str


@dataclass(frozen=True)
class GridConfig:
    """Lattice step (mm), reach band (mm from the root) and angle band (deg from the whisker axis).

    The angle band's lower edge runs linearly from ``angle_min_near_deg`` at ``reach_min_mm``
    to ``angle_min_far_deg`` at ``reach_max_mm``.
    """

    step_mm: float
    reach_min_mm: float
    reach_max_mm: float
    angle_min_near_deg: float
    angle_min_far_deg: float
    angle_max_deg: float
    expected_points: int


@dataclass(frozen=True)
class ApproachConfig:
    """Retract height (whisker-frame y, mm), x overtravel (mm) and baseline park position (mm)."""

    safe_y_mm: float
    overtravel_mm: float
    park_mm: tuple[float, float]


@dataclass(frozen=True)
class MotionConfig:
    """Feeds (mm/min), estimate acceleration (mm/s²) and rate (mm/min), timeout (s), homing."""

    travel_feed_mm_min: float
    approach_feed_mm_min: float
    accel_mm_s2: float
    max_rate_mm_min: float
    move_timeout_s: float
    home: bool


@dataclass(frozen=True)
class AcquisitionConfig:
    """Settle time (s, sensor clock) and sample counts per point and per baseline."""

    settle_s: float
    samples_per_point: int
    baseline_samples: int


@dataclass(frozen=True)
class SensorSettings:
    """Sample rate (Hz) and the MLX90393 GAIN_SEL, RES, OSR, DIG_FILT codes."""

    rate_hz: int
    gain: int
    res: int
    osr: int
    filt: int


@dataclass(frozen=True)
class SafetyConfig:
    """Travel (mm), margin inside it (mm), overload |z| limit (µT), encoder tolerance (mm)."""

    travel_mm: tuple[float, float]
    margin_mm: float
    overload_z_uT: float
    encoder_tolerance_mm: float


@dataclass(frozen=True)
class CollectConfig:
    """Every setting of a collection run, one frozen dataclass per TOML table."""

    rig: RigConfig
    grid: GridConfig
    approach: ApproachConfig
    motion: MotionConfig
    acquisition: AcquisitionConfig
    sensor: SensorSettings
    safety: SafetyConfig

    def to_dict(self) -> dict[str, Any]:
        """The configuration as JSON-able nested dicts (tuples become lists)."""
        return _lists(asdict(self))

    def replace(self, **sections: dict[str, Any]) -> "CollectConfig":
        """A copy with some keys changed, e.g. ``replace(acquisition={"samples_per_point": 5})``."""
        return config_from_dict(merge_overrides(self.to_dict(), sections, "config"))


def _lists(value: Any) -> Any:
    if isinstance(value, dict):
        return {key: _lists(item) for key, item in value.items()}
    if isinstance(value, (tuple, list)):
        return [_lists(item) for item in value]
    return value


_SECTION_TYPES = {"rig": RigConfig, "grid": GridConfig, "approach": ApproachConfig,
                  "motion": MotionConfig, "acquisition": AcquisitionConfig,
                  "sensor": SensorSettings, "safety": SafetyConfig}


def _section(cls: type, values: dict[str, Any], name: str) -> Any:
    converted = {}
    for spec in fields(cls):
        value = values[spec.name]
        try:
            converted[spec.name] = _convert(value, spec.type)
        except (TypeError, ValueError):
            raise UsageError(f"config [{name}] {spec.name} = {value!r} is not a valid {spec.type}") from None
    return cls(**converted)


def _convert(value: Any, type_name: str) -> Any:
    if type_name == "str":
        if not isinstance(value, str):
            raise TypeError(value)
        return value
    if type_name == "bool":
        if not isinstance(value, bool):
            raise TypeError(value)
        return value
    if type_name == "int":
        if isinstance(value, bool) or int(value) != value:
            raise ValueError(value)
        return int(value)
    if type_name == "float":
        if isinstance(value, bool):
            raise TypeError(value)
        return float(value)
    pair = tuple(float(v) for v in value)
    if len(pair) != 2:
        raise ValueError(value)
    return pair


def config_from_dict(values: dict[str, Any]) -> CollectConfig:
    """Build and validate a configuration from complete nested dicts."""
    config = CollectConfig(**{name: _section(_SECTION_TYPES[name], values[name], name)
                              for name in _SECTION_TYPES})
    _validate(config)
    return config


def _validate(config: CollectConfig) -> None:
    grid, acq, motion = config.grid, config.acquisition, config.motion
    problems = []
    if grid.step_mm <= 0 or grid.reach_min_mm >= grid.reach_max_mm:
        problems.append("grid needs step_mm > 0 and reach_min_mm < reach_max_mm")
    lowest = min(grid.angle_min_near_deg, grid.angle_min_far_deg)
    highest = max(grid.angle_min_near_deg, grid.angle_min_far_deg)
    if not (-90.0 <= lowest and highest < grid.angle_max_deg <= 90.0):
        problems.append("grid needs -90 <= angle_min_near_deg, angle_min_far_deg < angle_max_deg <= 90")
    if acq.samples_per_point < 1 or acq.baseline_samples < 2 or acq.settle_s < 0:
        problems.append("acquisition needs samples_per_point >= 1, baseline_samples >= 2, settle_s >= 0")
    if min(motion.travel_feed_mm_min, motion.approach_feed_mm_min, motion.accel_mm_s2) <= 0:
        problems.append("motion feeds and acceleration must be positive")
    if config.approach.safe_y_mm <= config.rig.rod_radius_mm:
        problems.append("approach.safe_y_mm must exceed the rod radius to clear the whisker")
    if problems:
        raise UsageError("invalid collect config: " + "; ".join(problems))


def load_config(path: str | Path | None = None) -> CollectConfig:
    """The defaults, overridden by the TOML file at ``path`` when given.

    Raises
    ------
    UsageError
        When the file is missing, not TOML, has unknown keys or values of the wrong type.
    """
    values = read_toml(DEFAULT_CONFIG_PATH)
    if path is not None:
        values = merge_overrides(values, read_toml(path), str(path))
    return config_from_dict(values)
