"""Tip accuracy across builds: the level set, the mechanics-informed fit on Y, and on (Y, Z).

For each build of a family (length 45-120 mm, diameter 0.15-0.40 mm, k_θ·L/EI about 1 to 80)
a rod grid is simulated through the twin's physics (``whiskercal.testing.fields``). Every
candidate is fitted to that grid only and then compared with the twin's truth:

- ``level-set``: ``model.calibrate`` as ``whiskercal fit --tip-model level-set`` runs it;
- ``mechanics-y``: ``mechfit`` fitted to Y, its z -> tip lookup (20 samples, cubic);
- ``mechanics-yz``: ``mechfit`` fitted to Y and Z together (polynomial pose map); its z -> tip
  lookup, and its (Y, Z) -> tip table for realistic contacts;
- ``magnet-yz``: the mechanics with the multipole magnet map fitted to Y and Z
  (``mechfit.magnetfit``, what ``fit --field-table`` ships); its z -> tip lookup, and its
  (Y, Z) -> tip table over tip loads of every direction (``mechfit.tables``).

Errors: on the frictionless tip curve (``twin.truth``) over the grid's z range, and on
realistic contacts (planes tilted 0-40° against the tip, friction 0-0.4 sliding either way,
depths 7-53 % of the wire's length) whose Y lies in that range.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Callable

import numpy as np

from whiskercal.bench.timing import machine_info, per_call_s
from whiskercal.errors import WhiskercalError
from whiskercal.mechfit.fit import fit_mechanics
from whiskercal.mechfit.magnetfit import fit_mechanics_magnet
from whiskercal.mechfit.tables import field_tip_table, z_lookup
from whiskercal.model.calibrate import CalibrationOptions, calibrate
from whiskercal.testing.fields import (DEPTH_FRACTIONS, MUS, NOISE_UT, OVERLOAD_UT, ROD_RADIUS_MM,
                                       TILTS_DEG, lookup_errors, realistic_contacts,
                                       realistic_errors, simulate_fields, stiffness_ratio,
                                       truth_tip_curve)
from whiskercal.twin.params import DEFAULT_SENSOR, SECOND_SENSOR, SensorParams
from whiskercal.twin.physics.whisker import WhiskerParams

REALISTIC_GOAL_MM = 0.3  # the goal's RMS on plane contacts with friction (mm)
QUICK_BUILDS = 1  # the default sensor only


def _build(sensor_id: str, **whisker) -> SensorParams:
    return replace(DEFAULT_SENSOR, sensor_id=sensor_id, whisker=WhiskerParams(**whisker))


FAMILY = (
    DEFAULT_SENSOR,
    SECOND_SENSOR,
    _build("long-110x0.20", length_mm=110.0, diameter_mm=0.20),
    _build("short-45x0.35-soft", length_mm=45.0, diameter_mm=0.35,
           root_rotational_stiffness_n_mm_per_rad=1.2),
    _build("default-stiff-root", root_rotational_stiffness_n_mm_per_rad=12.0),
    _build("thin-120x0.15", length_mm=120.0, diameter_mm=0.15,
           root_rotational_stiffness_n_mm_per_rad=1.2),
)


def _timed(call):
    started = time.perf_counter()
    value = call()
    return value, time.perf_counter() - started


def _level_set(sensor, grid):
    options = CalibrationOptions(trace_length_mm=sensor.whisker.reach_mm, allow_extrapolation=True)
    calibration, fit_s = _timed(lambda: calibrate(grid.rod_center_mm, grid.fields_uT[:, 0],
                                                  ROD_RADIUS_MM, options))
    return {"lookup": calibration.lookup, "fit_s": fit_s}


def _mechanics(sensor, grid, axes):
    fields = grid.fields_uT[:, :axes]
    fit, fit_s = _timed(lambda: fit_mechanics(grid.rod_center_mm, fields, ROD_RADIUS_MM,
                                              sensor.whisker.reach_mm, NOISE_UT[:axes]))
    y_range = (float(fields[:, 0].min()), float(fields[:, 0].max()))
    lookup, table_s = _timed(lambda: z_lookup(fit, y_range))
    out = {"lookup": lookup, "fit_s": fit_s + table_s, "fit": fit}
    if axes == 2:
        out["table"], extra_s = _timed(lambda: field_tip_table(fit, y_range))
        out["table_s"] = extra_s
    return out


def _magnet(sensor, grid):
    fit, fit_s = _timed(lambda: fit_mechanics_magnet(grid.rod_center_mm, grid.fields_uT,
                                                     ROD_RADIUS_MM, sensor.whisker.reach_mm,
                                                     NOISE_UT))
    y_range = (float(grid.fields_uT[:, 0].min()), float(grid.fields_uT[:, 0].max()))
    lookup, lookup_s = _timed(lambda: z_lookup(fit, y_range))
    table, table_s = _timed(lambda: field_tip_table(fit, y_range))
    return {"lookup": lookup, "fit_s": fit_s + lookup_s + table_s, "fit": fit, "table": table,
            "table_s": table_s}


def _speeds(candidate) -> dict:
    lookup = candidate["lookup"]
    middle = 0.5 * (lookup.z_min_uT + lookup.z_max_uT)
    out = {"lookup_s": per_call_s(lambda: lookup.tip_scalar(middle))}
    if "table" in candidate:
        table = candidate["table"]
        y, z = float(np.mean(table.y_uT)), float(np.mean(table.z_uT))
        out["table_s"] = per_call_s(lambda: table.tip_scalar(y, z))
    return out


CANDIDATES = {
    "level-set": _level_set,
    "mechanics-y": lambda sensor, grid: _mechanics(sensor, grid, 1),
    "mechanics-yz": lambda sensor, grid: _mechanics(sensor, grid, 2),
    "magnet-yz": _magnet,
}


def measure_build(sensor: SensorParams, candidates=tuple(CANDIDATES), seed: int = 0,
                  say=lambda _row: None) -> list[dict]:
    """One row per candidate for one build: fit and lookup times, errors against the truth."""
    grid = simulate_fields(sensor, seed)
    z_true, tips_true = truth_tip_curve(sensor)
    z_range = (float(grid.fields_uT[:, 0].min()), float(grid.fields_uT[:, 0].max()))
    contacts = realistic_contacts(sensor)
    rows = []
    for name in candidates:
        row = {"build": sensor.sensor_id, "method": name, "grid_points": len(grid.rod_center_mm),
               "stiffness_ratio": stiffness_ratio(sensor.whisker), "z_range_uT": list(z_range)}
        try:
            candidate = CANDIDATES[name](sensor, grid)
        except WhiskercalError as error:
            row["error"] = f"{type(error).__name__}: {error}"
            rows.append(row), say(row)
            continue
        row.update(fit_s=candidate["fit_s"], tip_curve=lookup_errors(
            candidate["lookup"], z_true, tips_true, z_range),
            realistic=realistic_errors(candidate, contacts, z_range), **_speeds(candidate))
        if "fit" in candidate:
            fit = candidate["fit"]
            row["fitted"] = {"stub_mm": fit.suspension.stub_mm,
                             "stiffness_ratio": 1.0 / fit.suspension.rot_compliance,
                             "trans_compliance": fit.suspension.trans_compliance,
                             "residual_rms_uT": fit.rms_uT.tolist(), "evaluations": fit.evaluations,
                             "ratio_profile": (fit.starts[-1].get("ratio_profile")
                                               if fit.starts else None)}
        rows.append(row), say(row)
    return rows


def _chart_keys(row: dict) -> None:
    """The charts' keys: tip-curve and realistic RMS (mm), the runtime's time per sample (s).

    A candidate with a (Y, Z) table is charted as the runtime reads it (the table, the z lookup
    where the table has no tip), with one sample's noise on both axes."""
    row["error_vs_truth_mm"] = row["tip_curve"]["rmse_mm"]
    row["label"] = row["build"]
    realistic = row["realistic"]
    best = realistic.get("y_and_z_sample_noise", realistic["y_only"])
    row["realistic_rmse_mm"] = best["rmse_mm"]
    row["runtime_s"] = row.get("table_s", row.get("lookup_s"))


def _summary(rows: list[dict]) -> dict:
    """Per method: builds meeting the goals (0.25 mm RMS, 0.5 mm max on the tip curve; 0.3 mm
    RMS on realistic contacts)."""
    out = {}
    for method in CANDIDATES:
        mine = [r for r in rows if r["method"] == method]
        ok = [r for r in mine if "tip_curve" in r and r["tip_curve"]["coverage"] >= 0.95
              and r["tip_curve"]["rmse_mm"] <= 0.25 and r["tip_curve"]["max_mm"] <= 0.5]
        realistic = [r for r in mine if r.get("realistic_rmse_mm", np.inf) <= REALISTIC_GOAL_MM]
        out[method] = {"builds": len(mine), "meeting_tip_goal": [r["build"] for r in ok],
                       "meeting_realistic_goal": [r["build"] for r in realistic]}
    return out


def run(quick: bool = False, progress: Callable[[dict], None] | None = None, seed: int = 0) -> dict:
    """Tip errors, fit and lookup times of every candidate on every build (mm, s).

    ``quick``: the default sensor only, without the polynomial (Y, Z) candidate (a few
    minutes).
    """
    say = progress or (lambda _row: None)
    builds = FAMILY[:QUICK_BUILDS] if quick else FAMILY
    candidates = ("level-set", "mechanics-y", "magnet-yz") if quick else tuple(CANDIDATES)
    rows = []
    for sensor in builds:
        rows += measure_build(sensor, candidates, seed, say)
    for row in rows:
        if "tip_curve" in row:
            _chart_keys(row)
    return {
        "benchmark": "tip-accuracy", "quick": quick, "machine": machine_info(),
        "units": {"time": "s", "error": "mm", "field": "µT"},
        "setup": {"builds": [s.sensor_id for s in builds], "noise_uT": list(NOISE_UT),
                  "rod_radius_mm": ROD_RADIUS_MM, "overload_uT": OVERLOAD_UT,
                  "plane_tilts_deg": list(TILTS_DEG), "mu": list(MUS),
                  "depth_fractions_of_length": list(DEPTH_FRACTIONS)},
        "rows": rows,
        "pareto": {"x": "fit_s", "y": "error_vs_truth_mm", "series": ["method"], "label": "label",
                   "x_label": "fit time (s)", "y_label": "tip RMS error vs twin truth (mm)"},
        "pareto_realistic": {"x": "fit_s", "y": "realistic_rmse_mm", "series": ["method"],
                             "label": "label", "x_label": "fit time (s)",
                             "y_label": "tip RMS on plane contacts with friction (mm)"},
        "pareto_lookup": {"x": "runtime_s", "y": "realistic_rmse_mm", "series": ["method"],
                          "label": "label", "x_label": "lookup time per sample (s)",
                          "y_label": "tip RMS on plane contacts with friction (mm)"},
        "supports": _summary(rows),
    }
