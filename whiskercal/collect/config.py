"""The collection run's configuration: documented defaults (default_grid.toml) plus a user file.

A user file overrides any key of the defaults; a key the defaults do not have is refused, so
a typo never silently falls back to a default.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from numbers import Real
from pathlib import Path
from typing import Any

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.tomlconfig import merge_overrides, read_toml

DEFAULT_CONFIG_PATH = Path(__file__).with_name("default_grid.toml")
ON_OVERLOAD = ("end-column", "stop")
MAX_LIST = 16  # the longest list a key may hold (the sweep's offsets)


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
    """Travel (mm), margin inside it (mm), overload |z| limit (µT), encoder tolerance (mm),
    the fraction of sensor frames lost (dropped + corrupt) above which a run warns, and what an
    overload does: ``end-column`` (skip the rest of that column, go on) or ``stop``."""

    travel_mm: tuple[float, float]
    margin_mm: float
    overload_z_uT: float
    encoder_tolerance_mm: float
    max_frame_loss: float = 0.01
    on_overload: str = "end-column"


@dataclass(frozen=True)
class SweepConfig:
    """The tip sweep after the grid: rod centres at ``angles`` directions from the root, evenly
    from ``angle_first_deg`` to ``angle_last_deg``, each at the trace length plus every one of
    ``offsets_mm`` from the root (mm; negative: short of the tip). ``collect.sweep`` plans it."""

    enabled: bool
    angle_first_deg: float
    angle_last_deg: float
    angles: int
    offsets_mm: tuple[float, ...]


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
    sweep: SweepConfig

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
                  "sensor": SensorSettings, "safety": SafetyConfig, "sweep": SweepConfig}


def _section(cls: type, values: dict[str, Any], name: str) -> Any:
    converted = {}
    for spec in fields(cls):
        value = values[spec.name]
        try:
            converted[spec.name] = _convert(value, spec.type)
        except (TypeError, ValueError, OverflowError) as error:
            raise UsageError(f"config [{name}] {spec.name} = {value!r} must be {error}") from None
    return cls(**converted)


def _is_real(value: Any) -> bool:
    # TOML booleans are Python ints: they are not numbers here
    return isinstance(value, Real) and not isinstance(value, (bool, np.bool_))


def _convert(value: Any, type_name: str) -> Any:
    """``value`` as ``type_name``; raises ValueError("what it must be") otherwise.

    Every number must be finite: a NaN compares false with everything, so it would silently
    switch off a limit such as the overload guard.
    """
    if type_name in ("str", "bool"):
        if type(value).__name__ != type_name:
            raise ValueError(f"a {'string' if type_name == 'str' else 'boolean'}")
        return value
    if type_name == "int":
        if not (_is_real(value) and math.isfinite(value) and int(value) == value):
            raise ValueError("a whole number")
        return int(value)
    if type_name == "float":
        if not (_is_real(value) and math.isfinite(value)):
            raise ValueError("a finite number")
        return float(value)
    if type_name == "tuple[float, ...]":
        if not (isinstance(value, (list, tuple)) and 0 < len(value) <= MAX_LIST
                and all(_is_real(v) and math.isfinite(v) for v in value)):
            raise ValueError(f"a list of 1 to {MAX_LIST} finite numbers")
        return tuple(float(v) for v in value)
    if not (isinstance(value, (list, tuple)) and len(value) == 2
            and all(_is_real(v) and math.isfinite(v) for v in value)):
        raise ValueError("a pair of finite numbers")
    return (float(value[0]), float(value[1]))


def config_from_dict(values: dict[str, Any]) -> CollectConfig:
    """Build and validate a configuration from complete nested dicts."""
    config = CollectConfig(**{name: _section(_SECTION_TYPES[name], values[name], name)
                              for name in _SECTION_TYPES})
    _validate(config)
    return config


# keys whose sign is fixed by what they measure; the checks below cover the keys they relate
_POSITIVE = ("rig.rod_radius_mm", "rig.whisker_reach_mm", "rig.trace_length_mm",
             "motion.max_rate_mm_min", "motion.move_timeout_s", "sensor.rate_hz",
             "safety.travel_mm", "safety.overload_z_uT", "safety.encoder_tolerance_mm")
_NON_NEGATIVE = ("grid.expected_points", "grid.reach_min_mm", "approach.overtravel_mm",
                 "safety.margin_mm", "safety.max_frame_loss")


def _sign_problems(config: CollectConfig) -> list[str]:
    problems = []
    for keys, least, says in ((_POSITIVE, False, "> 0"), (_NON_NEGATIVE, True, ">= 0")):
        for key in keys:
            section, name = key.split(".")
            value = getattr(getattr(config, section), name)
            values = value if isinstance(value, tuple) else (value,)
            if not all(v >= 0 if least else v > 0 for v in values):
                problems.append(f"{key} must be {says} (got {value!r})")
    return problems


def _validate(config: CollectConfig) -> None:
    grid, acq, motion = config.grid, config.acquisition, config.motion
    problems = _sign_problems(config)
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
    if config.safety.on_overload not in ON_OVERLOAD:
        problems.append(f"safety.on_overload must be one of {', '.join(ON_OVERLOAD)}")
    if config.safety.max_frame_loss > 1.0:
        problems.append("safety.max_frame_loss is a fraction of the frames, at most 1")
    if config.approach.safe_y_mm <= config.rig.rod_radius_mm:
        problems.append("approach.safe_y_mm must exceed the rod radius to clear the whisker")
    problems += _sweep_problems(config.sweep, config.rig)
    if problems:
        raise UsageError("invalid collect config: " + "; ".join(problems))


def _sweep_problems(sweep: SweepConfig, rig: RigConfig) -> list[str]:
    """The tip sweep must touch the tip from the +y side, as every grid point does."""
    problems = []
    if not 1 <= sweep.angles <= 90:
        problems.append("sweep.angles must be 1..90")
    if not -90.0 <= min(sweep.angle_first_deg, sweep.angle_last_deg) \
            <= max(sweep.angle_first_deg, sweep.angle_last_deg) <= 0.0:
        problems.append("sweep angles must lie in -90..0 deg (the rod pushes the whisker to -y)")
    shortest = -0.25 * rig.trace_length_mm
    if not all(shortest <= offset < rig.rod_radius_mm for offset in sweep.offsets_mm):
        problems.append(f"sweep.offsets_mm must lie in {shortest:g}..{rig.rod_radius_mm:g} mm "
                        "(a quarter of the trace length short of the tip, to under one rod "
                        "radius past it, where the rod still touches it)")
    return problems


# The default bands were chosen for this trace length (mm); other builds get them scaled.
DEFAULT_TRACE_LENGTH_MM = 78.0
# How far past the tip the rod counts as clear of the whisker, mm (the default: 80 for 78).
REACH_PAST_TIP_MM = 2.0


def follow_trace_length(defaults: dict[str, Any], given: dict[str, Any]) -> dict[str, Any]:
    """The defaults for a build whose ``[rig] trace_length_mm`` the user's file gives.

    The reach band and the tip sweep's offsets scale with the trace length (the default's
    22.5..71.75 mm for 78 mm) and the reach past which the rod is clear of the whisker follows
    the tip; the 3 mm lattice, the
    angle band and the overload guard stay (the point count follows the build, so the paper's
    180-point check is off). A key the file gives is kept as given (``merge_overrides``).
    """
    length = given.get("rig", {}).get("trace_length_mm") if isinstance(given.get("rig"), dict) \
        else None
    if not _is_real(length) or not 0 < length < math.inf or length == DEFAULT_TRACE_LENGTH_MM:
        return defaults
    factor = float(length) / DEFAULT_TRACE_LENGTH_MM
    grid = dict(defaults["grid"], expected_points=0,
                reach_min_mm=round(defaults["grid"]["reach_min_mm"] * factor, 2),
                reach_max_mm=round(defaults["grid"]["reach_max_mm"] * factor, 2))
    rig = dict(defaults["rig"], whisker_reach_mm=float(length) + REACH_PAST_TIP_MM)
    # the tip draws back toward the root in proportion to the wire's length as it deflects
    sweep = dict(defaults["sweep"], offsets_mm=[round(offset * factor, 2)
                                                for offset in defaults["sweep"]["offsets_mm"]])
    return {**defaults, "grid": grid, "rig": rig, "sweep": sweep}


def load_config(path: str | Path | None = None) -> CollectConfig:
    """The defaults, overridden by the TOML file at ``path`` when given.

    A file that gives ``[rig] trace_length_mm`` for another build gets defaults that follow it
    (``follow_trace_length``).

    Raises
    ------
    UsageError
        When the file is missing, not TOML, has unknown keys, values of the wrong type, a
        non-finite number (NaN, inf) or a number out of range; one line naming file and key.
    """
    values = read_toml(DEFAULT_CONFIG_PATH)
    if path is None:
        return config_from_dict(values)
    given = read_toml(path)
    values = merge_overrides(follow_trace_length(values, given), given, str(path))
    try:
        return config_from_dict(values)
    except UsageError as error:
        raise UsageError(f"{path}: {error}") from None
