"""The collection run's configuration: documented defaults (default_grid.toml) plus a user file.

A user file overrides any key of the defaults; each table is a typed model
(``whiskercal.typedconfig``): a value of the wrong type, a non-finite or out-of-range number and
a key the defaults do not have are refused, so a typo never silently falls back to a default.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import model_validator

from whiskercal.collect.plans import DEFAULT_PLAN, NamedPlan, named_plan
from whiskercal.tomlconfig import merge_overrides, read_toml
from whiskercal.typedconfig import Flag, Table, Text, choice, integer, number, numbers, validate

DEFAULT_CONFIG_PATH = Path(__file__).with_name("default_grid.toml")
ON_OVERLOAD = ("end-column", "stop")
MAX_LIST = 16  # the longest list a key may hold (the sweep's offsets)
MAX_REACH_MM = 1000.0
"""A whisker longer than this (mm) is a unit error (metres read as mm), not a build."""

Number = number()
Positive = number(gt=0)
NonNegative = number(ge=0)
Pair = numbers(2)
Reach = number(gt=0, le=MAX_REACH_MM)


class RigConfig(Table):
    """Rig geometry: whisker frame origin in stage coordinates (mm), frame angle (deg), rod (mm).

    ``trace_length_mm`` is the whisker's arc length from the centre of rotation to the tip, which
    `whiskercal fit` traces; ``sensor_id`` names the whisker sensor (empty: taken from the device).
    """

    origin_stage_mm: Pair
    angle_deg: Number
    rod_radius_mm: Positive
    whisker_reach_mm: Positive
    trace_length_mm: Reach
    sensor_id: Text


class GridConfig(Table):
    """Lattice step (mm), reach band (mm from the root) and angle band (deg from the whisker axis).

    The angle band's lower edge runs linearly from ``angle_min_near_deg`` at ``reach_min_mm``
    to ``angle_min_far_deg`` at ``reach_max_mm``.
    """

    step_mm: Positive
    reach_min_mm: NonNegative
    reach_max_mm: Number
    angle_min_near_deg: number(ge=-90.0)
    angle_min_far_deg: number(ge=-90.0)
    angle_max_deg: number(le=90.0)
    expected_points: integer(ge=0)

    @model_validator(mode="after")
    def _bands(self) -> "GridConfig":
        if self.reach_min_mm >= self.reach_max_mm:
            raise ValueError("needs reach_min_mm < reach_max_mm")
        if max(self.angle_min_near_deg, self.angle_min_far_deg) >= self.angle_max_deg:
            raise ValueError("needs angle_min_near_deg and angle_min_far_deg < angle_max_deg")
        return self


class ApproachConfig(Table):
    """Retract height (whisker-frame y, mm), x overtravel (mm) and baseline park position (mm)."""

    safe_y_mm: Number
    overtravel_mm: NonNegative
    park_mm: Pair


class MotionConfig(Table):
    """Feeds (mm/min), estimate acceleration (mm/s²) and rate (mm/min), timeout (s), homing."""

    travel_feed_mm_min: Positive
    approach_feed_mm_min: Positive
    accel_mm_s2: Positive
    max_rate_mm_min: Positive
    move_timeout_s: Positive
    home: Flag


class AcquisitionConfig(Table):
    """Settle time (s, sensor clock) and sample counts per point and per baseline."""

    settle_s: NonNegative
    samples_per_point: integer(ge=1)
    baseline_samples: integer(ge=2)


class SensorSettings(Table):
    """Sample rate (Hz) and the MLX90393 GAIN_SEL, RES, OSR, DIG_FILT codes."""

    rate_hz: integer(ge=1)
    gain: integer(ge=0, le=7)
    res: integer(ge=0, le=3)
    osr: integer(ge=0, le=3)
    filt: integer(ge=0, le=7)


class SafetyConfig(Table):
    """Travel (mm), margin inside it (mm), overload |z| limit (µT), encoder tolerance (mm),
    the fraction of sensor frames lost (dropped + corrupt) above which a run warns, and what an
    overload does: ``end-column`` (skip the rest of that column, go on) or ``stop``."""

    travel_mm: numbers(2, gt=0)
    margin_mm: NonNegative
    overload_z_uT: Positive
    encoder_tolerance_mm: Positive
    max_frame_loss: number(ge=0, le=1, says="a fraction of the frames, in 0..1") = 0.01
    on_overload: choice(*ON_OVERLOAD) = "end-column"


SweepAngle = number(ge=-90.0, le=0.0, says="a number of deg in -90..0 (the rod pushes the whisker to -y)")


class SweepConfig(Table):
    """The tip sweep after the grid: rod centres at ``angles`` directions from the root, evenly
    from ``angle_first_deg`` to ``angle_last_deg``, each at the trace length plus every one of
    ``offsets_mm`` from the root (mm; negative: short of the tip). ``collect.sweep`` plans it.
    The angles lie in -90..0 deg: the rod touches the tip from the +y side, as every grid point
    does."""

    enabled: Flag
    angle_first_deg: SweepAngle
    angle_last_deg: SweepAngle
    angles: integer(ge=1, le=90)
    offsets_mm: numbers(least=1, most=MAX_LIST)


class CollectConfig(Table):
    """Every setting of a collection run, one frozen table per TOML table."""

    rig: RigConfig
    grid: GridConfig
    approach: ApproachConfig
    motion: MotionConfig
    acquisition: AcquisitionConfig
    sensor: SensorSettings
    safety: SafetyConfig
    sweep: SweepConfig

    def replace(self, **sections: dict[str, Any]) -> "CollectConfig":
        """A copy with some keys changed, e.g. ``replace(acquisition={"samples_per_point": 5})``."""
        return config_from_dict(merge_overrides(self.to_dict(), sections))

    @model_validator(mode="after")
    def _across_tables(self) -> "CollectConfig":
        if self.approach.safe_y_mm <= self.rig.rod_radius_mm:
            raise ValueError("approach.safe_y_mm must exceed the rod radius to clear the whisker")
        shortest, radius = -0.25 * self.rig.trace_length_mm, self.rig.rod_radius_mm
        if not all(shortest <= offset < radius for offset in self.sweep.offsets_mm):
            raise ValueError(f"sweep.offsets_mm must lie in {shortest:g}..{radius:g} mm (a quarter "
                             "of the trace length short of the tip, to under one rod radius past "
                             "it, where the rod still touches it)")
        return self


def config_from_dict(values: dict[str, Any], where: str = "config") -> CollectConfig:
    """Build and validate a configuration from complete nested dicts (one UsageError line
    naming ``where``, the table and the key otherwise)."""
    return validate(CollectConfig, values, where)


def _is_real(value: Any) -> bool:
    # TOML booleans are Python ints: they are not numbers here
    return isinstance(value, (int, float)) and not isinstance(value, bool)


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
    if not _is_real(length) or not 0 < length <= MAX_REACH_MM or length == DEFAULT_TRACE_LENGTH_MM:
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


def _trace_length_given(given: dict[str, Any]) -> float:
    """The trace length (mm) a user's file gives, the default's where it gives none usable
    (its own validation then names a bad one)."""
    rig = given.get("rig") if isinstance(given.get("rig"), dict) else {}
    length = rig.get("trace_length_mm")
    return float(length) if _is_real(length) and 0 < length <= MAX_REACH_MM \
        else DEFAULT_TRACE_LENGTH_MM


def load_config(path: str | Path | None = None,
                plan: str | NamedPlan = DEFAULT_PLAN) -> CollectConfig:
    """The defaults, changed by the named ``plan`` (``collect.plans``), overridden by the TOML
    file at ``path`` when given.

    A file that gives ``[rig] trace_length_mm`` for another build gets defaults that follow it
    (``follow_trace_length``), and the plan's lengths scaled to it.

    Raises
    ------
    UsageError
        When the plan has no such name; when the file is missing, not TOML, has unknown keys,
        values of the wrong type, a non-finite number (NaN, inf) or a number out of range; one
        line naming file and key.
    """
    chosen = named_plan(plan) if isinstance(plan, str) else plan
    given = {} if path is None else read_toml(path)
    values = follow_trace_length(read_toml(DEFAULT_CONFIG_PATH), given)
    values = merge_overrides(values, chosen.overrides(_trace_length_given(given)))
    if path is None:
        return config_from_dict(values, "config" if chosen.name == DEFAULT_PLAN
                                else f"plan {chosen.name}")
    return config_from_dict(merge_overrides(values, given), str(path))
