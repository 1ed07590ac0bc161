"""What a plan will cost and whether it fits: stage time from trapezoidal moves, limit checks.

This is what ``whiskercal collect --dry-run`` prints, without moving anything.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from whiskercal.collect.plan import GridPlan, Move, inside_bands


def trapezoid_time_s(distance_mm: float, feed_mm_min: float, accel_mm_s2: float) -> float:
    """Time of a straight move that starts and ends at rest, s.

    Accelerates at ``accel_mm_s2`` to the feed (mm/min), cruises, decelerates; a move too short
    to reach the feed is a triangle profile.
    """
    if distance_mm <= 0:
        return 0.0
    speed_mm_s = feed_mm_min / 60.0
    ramp_mm = speed_mm_s**2 / accel_mm_s2  # accelerating plus decelerating
    if distance_mm >= ramp_mm:
        return distance_mm / speed_mm_s + speed_mm_s / accel_mm_s2
    return 2.0 * np.sqrt(distance_mm / accel_mm_s2)


def moves_time_s(moves: list[Move], accel_mm_s2: float, max_rate_mm_min: float) -> float:
    """Total time of the moves, each from rest to rest, feeds capped at the stage's rate, s."""
    return float(sum(trapezoid_time_s(m.length_mm, min(m.feed_mm_min, max_rate_mm_min), accel_mm_s2)
                     for m in moves))


def dwell_time_s(plan: GridPlan, n_points: int) -> float:
    """Time spent standing still: settling and averaging at each point plus both baselines, s."""
    acq, rate_hz = plan.config.acquisition, plan.config.sensor.rate_hz
    per_point_s = acq.settle_s + acq.samples_per_point / rate_hz
    return n_points * per_point_s + 2 * (acq.settle_s + acq.baseline_samples / rate_hz)


def points_time_s(plan: GridPlan, accel_mm_s2: float | None = None,
                  max_rate_mm_min: float | None = None, start_index: int = 0) -> float:
    """Estimated stage time from the first point to the last, s: every move from the park
    position onto each point and every point's settle and samples; homing, the baselines and
    the way back to the park position aside."""
    config = plan.config
    accel = config.motion.accel_mm_s2 if accel_mm_s2 is None else accel_mm_s2
    rate = config.motion.max_rate_mm_min if max_rate_mm_min is None else max_rate_mm_min
    moves, here = [], plan.park_mm
    for target in plan.rod_center_mm[start_index:]:
        moves += plan.moves_to(here, target)
        here = target
    acq = config.acquisition
    per_point_s = acq.settle_s + acq.samples_per_point / config.sensor.rate_hz
    return moves_time_s(moves, accel, rate) + (len(plan) - start_index) * per_point_s


def limit_problems(plan: GridPlan, travel_mm, margin_mm: float) -> list[str]:
    """Every waypoint outside the stage travel (less the margin), as readable lines."""
    problems = []
    low, high = margin_mm, np.asarray(travel_mm, float) - margin_mm
    waypoints = {tuple(np.round(m.end_mm, 6)) for m in plan.path()} | {tuple(plan.park_mm)}
    for point in sorted(waypoints):
        stage = plan.to_stage(np.array(point))
        if np.any(stage < low) or np.any(stage > high):
            problems.append(f"whisker-frame ({point[0]:.1f}, {point[1]:.1f}) mm is stage "
                            f"({stage[0]:.1f}, {stage[1]:.1f}) mm, outside the travel "
                            f"{margin_mm:g}..{high[0]:g} x {margin_mm:g}..{high[1]:g} mm")
    return problems


def band_problems(plan: GridPlan) -> list[str]:
    """Points outside the configured reach and angle bands (a plan built elsewhere)."""
    outside = ~inside_bands(plan.config.grid, plan.rod_center_mm[:plan.sweep_from])
    return [f"{int(outside.sum())} points lie outside the reach or angle band"] if outside.any() else []


def plan_summary(plan: GridPlan, travel_mm=None, accel_mm_s2: float | None = None,
                 max_rate_mm_min: float | None = None, start_index: int = 0) -> dict[str, Any]:
    """Points, ranges, path length, estimated stage time and limit checks of a plan.

    The time counts every move (from machine zero when the run homes) and every dwell, but not
    the homing cycle itself, whose speed only the stage knows. Travel (mm), acceleration (mm/s²)
    and maximum rate (mm/min) default to the config; pass the stage's own settings when it is
    connected. ``start_index`` skips points already taken.
    """
    config = plan.config
    travel_mm = config.safety.travel_mm if travel_mm is None else travel_mm
    accel = config.motion.accel_mm_s2 if accel_mm_s2 is None else accel_mm_s2
    rate = config.motion.max_rate_mm_min if max_rate_mm_min is None else max_rate_mm_min
    moves = plan.path(start_index)
    if config.motion.home:  # homing leaves the stage at machine zero, far from the park position
        moves = plan.moves_to(plan.to_whisker(np.zeros(2)), plan.park_mm, to_park=True) + moves
    move_s = moves_time_s(moves, accel, rate)
    problems = limit_problems(plan, travel_mm, config.safety.margin_mm) + band_problems(plan)
    return {
        "points": len(plan),
        "points_to_take": len(plan) - start_index,
        "tip_sweep_points": plan.sweep_count,
        "columns": int(len(np.unique(plan.rod_center_mm[:, 0]))),
        "whisker_x_mm": [float(plan.rod_center_mm[:, 0].min()), float(plan.rod_center_mm[:, 0].max())],
        "whisker_y_mm": [float(plan.rod_center_mm[:, 1].min()), float(plan.rod_center_mm[:, 1].max())],
        "stage_x_mm": [float(plan.stage_mm[:, 0].min()), float(plan.stage_mm[:, 0].max())],
        "stage_y_mm": [float(plan.stage_mm[:, 1].min()), float(plan.stage_mm[:, 1].max())],
        "path_length_mm": float(sum(m.length_mm for m in moves)),
        "moves": len(moves),
        "estimated_move_time_s": move_s,
        "estimated_stage_time_s": move_s + dwell_time_s(plan, len(plan) - start_index),
        "estimated_points_time_s": points_time_s(plan, accel, rate, start_index),
        "travel_mm": [float(v) for v in travel_mm],
        "limits_ok": not problems,
        "problems": problems,
    }
