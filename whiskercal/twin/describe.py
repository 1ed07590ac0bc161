"""The numbers a builder needs before calibrating a sensor (``whiskercal twin describe``).

- EI and the ratio k_θ·L/EI: the suspension's stiffness against turning over the wire's against
  bending. Under a small tip load P the root's turn moves the tip by about P·L·R/k_θ (R the reach)
  and bending by P·L³/(3·EI), so a large ratio means a push mostly bends the wire, a small one
  that it mostly turns the root.
- The paper's deflection: its chosen target is the flat plane (the study's, tilted 20°, with
  friction) at a contact distance of 40 mm past the undeflected tip. The solve is history-free
  (steady kinetic sliding), as `twin plane-study`'s.
- The one-to-one range: z along the twin's frictionless tip-contact sweep (`truth`), from the
  free whisker to the largest tip slope the sweep reaches, up to where z stops being monotonic.
- Saturation: the noise-free reading (field plus the chip's offset) along the same sweep against
  the count range of the configured GAIN_SEL and RES; the first axis to reach it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.checks import positive
from whiskercal.errors import UsageError
from whiskercal.twin.params import SensorParams
from whiskercal.twin.physics.magnet import field_uT
from whiskercal.twin.physics.magnetometer import count_range
from whiskercal.twin.physics.obstacles import (DEFAULT_MU_KINETIC, DEFAULT_MU_STATIC,
                                               DEFAULT_PLANE_TILT_RAD, plane_for_depth)
from whiskercal.twin.physics.plane import solve_plane
from whiskercal.twin.truth import MAX_TIP_SLOPE_RAD, TipSweep, static_field_uT, tip_contact_sweep, z_of_pose

# The paper (Methodology, "optimal contact deflection target") settles on the plane at 40 mm.
PAPER_DEPTH_MM = 40.0
AXES = ("X", "Y", "Z")
# Samples of the full tip-contact sweep, as `truth.tip_curve` takes it (one shared cache entry).
_SWEEP_SAMPLES = 161
# Shorter sweeps tried, as fractions of MAX_TIP_SLOPE_RAD, when the rod cannot hold the tip that far.
_SWEEP_FRACTIONS = (1.0, 0.75, 0.5, 0.25)


@dataclass(frozen=True)
class Push:
    """The study's plane at `depth_mm` past the undeflected tip (mm, N, µT)."""

    depth_mm: float
    tilt_deg: float
    mu_static: float
    mu_kinetic: float
    kind: str                  # "tip", "tangential", "free", or "failed" (no equilibrium found)
    tip_mm: tuple[float, float]
    force_n: float             # magnitude of the contact force
    z_uT: float


@dataclass(frozen=True)
class OneToOne:
    """Where the tip is a one-to-one function of z along the tip-contact sweep.

    ``ends_at`` says why the range ends: ``"fold"`` (z turns back), ``"sweep_end"`` (z is
    monotonic over the whole sweep, to `MAX_TIP_SLOPE_RAD`) or ``"contact_lost"`` (monotonic
    over a shorter sweep, because the rod could not hold the tip further).
    """

    z_range_uT: tuple[float, float]
    ends_at: str
    tip_slope_rad: float       # the tip's slope where the range ends
    tip_mm: tuple[float, float]
    swept_to_rad: float        # the largest tip slope the sweep reached


@dataclass(frozen=True)
class Saturation:
    """Where the noise-free reading first reaches the count range along the tip-contact sweep."""

    gain: int
    res: int
    axis: str | None           # None: no axis saturates over the sweep
    z_uT: float | None
    at_rest: bool
    full_scale_uT: tuple[float, float, float]
    peak_fraction: tuple[float, float, float]  # largest share of each axis' range used on the sweep


@dataclass(frozen=True)
class SensorDescription:
    """Everything `describe` computes for one sensor."""

    sensor: SensorParams
    bending_stiffness_n_mm2: float
    root_ratio: float          # k_θ·L/EI
    static_field_uT: tuple[float, float, float]
    push: Push
    one_to_one: OneToOne
    saturation: Saturation


def root_ratio(sensor: SensorParams) -> float:
    """k_θ·L/EI: the suspension's stiffness against turning over the wire's against bending."""
    whisker = sensor.whisker
    return whisker.root_rotational_stiffness_n_mm_per_rad * whisker.length_mm / whisker.bending_stiffness_n_mm2


def push(sensor: SensorParams, depth_mm: float = PAPER_DEPTH_MM) -> Push:
    """The study's plane (20°, μ_s 0.30, μ_k 0.22) `depth_mm` past the tip, solved without history."""
    # past the wire's length the plane would cross behind the root: no contact is left to solve
    positive(depth_mm, "the depth (mm past the undeflected tip)", high=sensor.whisker.length_mm, unit="mm")
    settings = (depth_mm, math.degrees(DEFAULT_PLANE_TILT_RAD), DEFAULT_MU_STATIC, DEFAULT_MU_KINETIC)
    try:
        eq = solve_plane(sensor.whisker, plane_for_depth(sensor.whisker, depth_mm))
    except UsageError:  # no equilibrium (e.g. a push far beyond the wire's length)
        return Push(*settings, "failed", (math.nan, math.nan), math.nan, math.nan)
    z = float(z_of_pose(sensor, eq.root_rotation_rad, eq.root_shift_mm))
    tip = (float(eq.tip_mm[0]), float(eq.tip_mm[1]))
    return Push(*settings, eq.kind, tip, float(np.linalg.norm(eq.force_n)), z)


def held_sweep(sensor: SensorParams) -> TipSweep:
    """The tip-contact sweep to `MAX_TIP_SLOPE_RAD`, or as far as the rod holds the tip.

    Raises UsageError when even a quarter of it cannot be held.
    """
    for fraction in _SWEEP_FRACTIONS:
        try:
            if fraction == 1.0:
                return tip_contact_sweep(sensor.whisker, _SWEEP_SAMPLES)
            n = int(round((_SWEEP_SAMPLES - 1) * fraction)) + 1
            return tip_contact_sweep(sensor.whisker, n, MAX_TIP_SLOPE_RAD * fraction)
        except (UsageError, np.linalg.LinAlgError):  # the rod lost the tip, or Newton could not go on
            continue
    raise UsageError(f"sensor {sensor.sensor_id!r}: the rod cannot hold tip contact even to a tip "
                     f"slope of {MAX_TIP_SLOPE_RAD * _SWEEP_FRACTIONS[-1]:.2f} rad.")


def one_to_one(sensor: SensorParams, sweep: TipSweep) -> OneToOne:
    """The z range, from the free whisker on, over which z is strictly monotonic on the sweep."""
    z = z_of_pose(sensor, sweep.root_rotation_rad, sweep.root_shift_mm)
    steps = np.diff(z)
    sign = np.sign(steps[0]) if steps[0] != 0 else -1.0  # the magnet's polarity sets z's sign
    turned = np.flatnonzero(sign * steps <= 0)
    swept_to = float(abs(sweep.tip_slope_rad[-1]))
    if turned.size:
        end, ends_at = int(turned[0]), "fold"
    else:
        end = z.size - 1
        ends_at = "sweep_end" if swept_to >= MAX_TIP_SLOPE_RAD - 1e-12 else "contact_lost"
    low, high = sorted((0.0, float(z[end])))
    tip = sweep.tip_mm[end]
    return OneToOne((low, high), ends_at, float(sweep.tip_slope_rad[end]), (float(tip[0]), float(tip[1])), swept_to)


def _first_crossing(reading: np.ndarray, low: np.ndarray, high: np.ndarray) -> tuple[int, float] | None:
    """(axis, sample position as a float index) where any axis first reaches its limit, or None."""
    over = (reading >= high) | (reading <= low)
    rows = np.flatnonzero(over.any(axis=1))
    if rows.size == 0:
        return None
    row = int(rows[0])
    if row == 0:
        return int(np.flatnonzero(over[0])[0]), 0.0
    before, after = reading[row - 1], reading[row]
    limit = np.where(after >= high, high, low)
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(over[row], (limit - before) / (after - before), np.inf)
    axis = int(np.argmin(share))
    return axis, row - 1 + float(share[axis])


def saturation(sensor: SensorParams, sweep: TipSweep) -> Saturation:
    """The first axis whose noise-free reading reaches the count range along the sweep."""
    meter = sensor.magnetometer
    reading = field_uT(sensor.magnet, sweep.root_rotation_rad, sweep.root_shift_mm) + np.asarray(meter.offset_uT)
    low_count, high_count = count_range(meter.res)
    # A reading rounds to the end count (and is flagged saturated) half a count before it.
    low, high = meter.lsb_uT() * (low_count + 0.5), meter.lsb_uT() * (high_count - 0.5)
    peak = np.maximum(np.maximum(reading / high, reading / low).max(axis=0), 0.0) + 0.0  # no -0.0
    full_scale = tuple(float(v) for v in meter.full_scale_uT())
    shares = tuple(float(v) for v in peak)
    crossing = _first_crossing(reading, low, high)
    if crossing is None:
        return Saturation(meter.gain, meter.res, None, None, False, full_scale, shares)
    axis, position = crossing
    z = z_of_pose(sensor, sweep.root_rotation_rad, sweep.root_shift_mm)
    z_at = float(np.interp(position, np.arange(z.size), z))
    return Saturation(meter.gain, meter.res, AXES[axis], z_at, position == 0.0, full_scale, shares)


def describe(sensor: SensorParams, depth_mm: float = PAPER_DEPTH_MM) -> SensorDescription:
    """All of the module's numbers for `sensor`; the plane pushed `depth_mm` past the tip."""
    sweep = held_sweep(sensor)
    static = tuple(float(v) for v in static_field_uT(sensor))
    return SensorDescription(sensor, sensor.whisker.bending_stiffness_n_mm2, root_ratio(sensor), static,
                             push(sensor, depth_mm), one_to_one(sensor, sweep), saturation(sensor, sweep))


def _no_nan(value):
    """NaN (a failed solve) as None, so that the JSON stays standard."""
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, (tuple, list)):
        return [_no_nan(item) for item in value]
    if isinstance(value, dict):
        return {key: _no_nan(item) for key, item in value.items()}
    return value


def description_to_dict(description: SensorDescription) -> dict:
    """The description as JSON-able data with stable keys (``twin describe --json``)."""
    from dataclasses import asdict

    from whiskercal.twin.sensor_file import sensor_to_dict

    sensor = description.sensor
    return _no_nan({
        "sensor_id": sensor.sensor_id,
        "reach_mm": sensor.whisker.reach_mm,
        "bending_stiffness_n_mm2": description.bending_stiffness_n_mm2,
        "root_ratio_k_theta_l_over_ei": description.root_ratio,
        "static_field_uT": description.static_field_uT,
        "paper_deflection": asdict(description.push),
        "one_to_one": asdict(description.one_to_one),
        "saturation": asdict(description.saturation),
        "sensor": sensor_to_dict(sensor),
    })
