"""Calibration sessions through ``collect``: the same build on fresh sessions, and builds drawn at
random, each calibrated with the default plan and ``fit`` as a lab runs them.

A session is what a user runs: a twin world for the build (its sensor file, a session ``seed``:
the noise, the stage's backlash and encoder, the tip sweep), ``collect`` with the default plan
scaled to the build's trace length (``[rig] trace_length_mm``, nothing else told), ``fit`` with
its defaults. The shipped z lookup is compared with the twin's true tips (the fit's own truth
comparison: tip curve RMS and max), the shipped (Y, Z) table, or the z lookup where none is
written, on realistic contacts held (planes tilted 0-40°, μ 0-0.4, ``testing.fields``), and the
estimate with the truth: an estimate more than ``HONEST_FACTOR`` below the truth is not honest.

Builds are drawn (``draw_builds``) over length 45-130 mm, diameter 0.15-0.40 mm and k_θ·L/EI
1-80 (log-uniform), from a fixed seed. Sessions run in parallel processes, one world each.
"""

from __future__ import annotations

import contextlib
import math
import os
import tempfile
import urllib.parse
import uuid
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Callable

import numpy as np

from whiskercal.testing import fields as twin_data
from whiskercal.twin.params import DEFAULT_SENSOR, SensorParams
from whiskercal.twin.physics.whisker import WhiskerParams

LENGTH_MM = (45.0, 130.0)
DIAMETER_MM = (0.15, 0.40)
STIFFNESS_RATIO = (1.0, 80.0)
# the goals (mm): RMS and max on the tip curve, RMS on realistic contacts held; the default
# sensor's RMS on every seed
GOAL_RMSE_MM, GOAL_MAX_MM, GOAL_REALISTIC_MM, GOAL_DEFAULT_MM = 0.25, 0.5, 0.3, 0.05
# an estimate below the truth by more than this factor is not honest
HONEST_FACTOR = 2.0


def draw_builds(count: int, seed: int = 0) -> list[SensorParams]:
    """``count`` builds on the default suspension and magnet, drawn from ``seed``: length and
    diameter uniform, k_θ·L/EI log-uniform over the ranges above (k_θ follows from it)."""
    rng = np.random.default_rng(seed)
    builds = []
    for index in range(count):
        length = float(rng.uniform(*LENGTH_MM))
        diameter = float(rng.uniform(*DIAMETER_MM))
        ratio = float(math.exp(rng.uniform(*np.log(STIFFNESS_RATIO))))
        wire = WhiskerParams(length_mm=round(length, 1), diameter_mm=round(diameter, 3))
        k_theta = ratio * wire.bending_stiffness_n_mm2 / wire.length_mm
        whisker = replace(wire, root_rotational_stiffness_n_mm_per_rad=round(k_theta, 4))
        builds.append(replace(DEFAULT_SENSOR, sensor_id=f"drawn-{index:02d}", whisker=whisker))
    return builds


def _collect_grid(sensor: SensorParams, seed: int, folder: Path, plan="full",
                  dynamics_modes: int = 0):
    """One ``collect`` of the named ``plan`` (``collect.plans``), scaled to the build's trace
    length, on a new twin world of ``sensor`` (its wire's lowest ``dynamics_modes`` bending
    modes on, 0: quasi-static); the raw grid's path and the run's summary."""
    from whiskercal.collect.config import load_config
    from whiskercal.collect.plan import build_plan
    from whiskercal.collect.run import collect
    from whiskercal.twin.sensor_file import sensor_to_toml

    build_file = folder / "sensor.toml"
    dynamics = f"\n[dynamics]\nmodes = {int(dynamics_modes)}\n" if dynamics_modes else ""
    build_file.write_text(sensor_to_toml(sensor) + dynamics)
    config = folder / "collect.toml"
    config.write_text(f"[rig]\ntrace_length_mm = {sensor.whisker.reach_mm!r}\n")
    world = f"session{uuid.uuid4().hex[:10]}"
    query = urllib.parse.urlencode({"seed": seed, "sensor": str(build_file)})
    raw = folder / "raw.h5"
    run = collect(f"sim://{world}/stage?{query}", f"sim://{world}/sensor", raw,
                  build_plan(load_config(config, plan)))
    return raw, run


def _realistic_held(sensor: SensorParams, result, z_range) -> dict:
    """Realistic contacts held, read as the runtime reads the artifact (``read``): its (Y, Z)
    table where one is written; the loads it follows from first touch where those are written
    instead, on the twin's planes pressed in (``sensor_family``'s pressed contacts); else its
    z lookup."""
    from whiskercal.bench.sensor_family import followed_held
    from whiskercal.model.field_table import FieldTipTable

    if result.load_branches is not None:
        return {**followed_held(sensor, result.load_branches, z_range),
                "read": "loads followed"}
    contacts = twin_data.realistic_contacts(sensor)
    table = result.field_table
    if table is None:
        errors = twin_data.realistic_errors({"lookup": result.calibration.lookup}, contacts,
                                            z_range)
        return {**errors["y_only"], "read": "z lookup"}
    tips = FieldTipTable(table["y_uT"], table["axial_uT"], table["tip_mm"])
    errors = twin_data.realistic_errors({"lookup": result.calibration.lookup, "table": tips},
                                        contacts, z_range)
    return {**errors["y_and_z_held"], "read": "(Y, Z) table"}


def session_row(sensor: SensorParams, seed: int, plan="full", dynamics_modes: int = 0) -> dict:
    """One session of ``sensor``: collect (the named ``plan``, the wire's ``dynamics_modes``),
    fit, and the shipped model against the twin's truth; a fit that refuses gives its reason
    (``refused``). The collect's points and stage times (s) are in the row."""
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.errors import WhiskercalError
    from whiskercal.fit.options import FitOptions
    from whiskercal.fit.run import fit

    row = {"build": sensor.sensor_id, "seed": seed, "length_mm": sensor.whisker.length_mm,
           "diameter_mm": sensor.whisker.diameter_mm,
           "stiffness_ratio": twin_data.stiffness_ratio(sensor.whisker)}
    with tempfile.TemporaryDirectory(prefix="whiskercal-session-") as folder:
        try:
            path, run = _collect_grid(sensor, seed, Path(folder), plan, dynamics_modes)
            raw = read_raw_grid(path)
        except WhiskercalError as error:  # the plan cannot be collected on this build
            return {**row, "refused": f"collect: {type(error).__name__}: {error}"}
        row.update(points=run.points, points_time_s=run.points_time_s,
                   stage_time_s=run.stage_time_s)
        try:
            result = fit(raw, FitOptions())
        except WhiskercalError as error:
            return {**row, "refused": f"{type(error).__name__}: {error}"}
    grid_z = raw.without_sweep().z_uT if np.any(raw.sweep) else raw.z_uT
    metrics = result.metrics
    truth_rmse = float(metrics.get("lookup_vs_truth_rmse_mm", math.nan))
    estimate = float(metrics.get("estimated_tip_error_mm", math.nan))
    realistic = _realistic_held(sensor, result, (float(grid_z.min()), float(grid_z.max())))
    return {**row, "tip_model": metrics.get("tip_model"), "estimated_tip_error_mm": estimate,
            "tip_curve_rmse_mm": truth_rmse,
            "tip_curve_max_mm": float(metrics.get("lookup_vs_truth_max_mm", math.nan)),
            "realistic_held": realistic, "warnings": result.warnings,
            "honest": bool(truth_rmse <= HONEST_FACTOR * estimate),
            "fit_s": float(sum(result.timings_s.values()))}


def meets_goal(row: dict) -> bool:
    """The session's shipped model within every goal, its estimate honest."""
    if "refused" in row:
        return False
    goal = GOAL_DEFAULT_MM if row["build"] == DEFAULT_SENSOR.sensor_id else GOAL_RMSE_MM
    return (row["tip_curve_rmse_mm"] <= goal and row["tip_curve_max_mm"] <= GOAL_MAX_MM
            and row["realistic_held"]["rmse_mm"] <= GOAL_REALISTIC_MM and row["honest"])


def _one(args) -> dict:
    return session_row(*args)


def run_sessions(builds: list[SensorParams], seeds: tuple[int, ...], workers: int | None = None,
                 progress: Callable[[dict], None] | None = None) -> list[dict]:
    """Every build on every seed, in ``workers`` processes (the CPUs by default); rows in the
    order given, each told to ``progress`` as it ends."""
    return run_jobs([(sensor, seed) for sensor in builds for seed in seeds], workers, progress)


def run_jobs(jobs: list[tuple], workers: int | None = None,
             progress: Callable[[dict], None] | None = None) -> list[dict]:
    """Sessions of ``session_row``'s arguments (build, seed[, plan, dynamics modes]), in
    ``workers`` processes (the CPUs by default); rows in the order given, each told to
    ``progress`` as it ends."""
    say = progress or (lambda _row: None)
    workers = max(1, min(workers or os.cpu_count() or 1, len(jobs)))
    with ProcessPoolExecutor(workers) if workers > 1 else contextlib.nullcontext() as pool:
        rows = []
        for row in (pool.map(_one, jobs) if pool is not None else map(_one, jobs)):
            rows.append(row)
            say(row)
    return rows


def summary(rows: list[dict]) -> dict:
    """The sessions' rows with each build's worst seed and spread (``per_build``), the sessions
    that miss a goal, and of those the ones that shipped a calibration anyway
    (``shipped_off_goal``: a refusal says what to change, a shipped one is off unannounced)."""
    name = "{build} seed {seed}".format
    return {"rows": rows, "per_build": per_build(rows),
            "missing_goal": [name(**r) for r in rows if not meets_goal(r)],
            "shipped_off_goal": [name(**r) for r in rows if _shipped_off_goal(r)]}


def _shipped_off_goal(row: dict) -> bool:
    """A session that shipped a calibration missing a goal (not refused)."""
    return "refused" not in row and not meets_goal(row)


def per_build(rows: list[dict]) -> list[dict]:
    """Each build's worst seed and spread over its sessions (mm), and which sessions miss."""
    summary = []
    for build in dict.fromkeys(r["build"] for r in rows):
        mine = [r for r in rows if r["build"] == build]
        rmse = [r.get("tip_curve_rmse_mm", math.inf) for r in mine]
        worst = mine[int(np.argmax(rmse))]
        summary.append({"build": build, "sessions": len(mine),
                        "stiffness_ratio": mine[0]["stiffness_ratio"],
                        "worst_seed": worst["seed"], "worst_rmse_mm": max(rmse),
                        "best_rmse_mm": min(rmse), "spread_mm": max(rmse) - min(rmse),
                        "worst_max_mm": max(r.get("tip_curve_max_mm", math.inf) for r in mine),
                        "worst_realistic_held_mm": max(
                            r.get("realistic_held", {}).get("rmse_mm", math.inf) for r in mine),
                        "refused": [r["seed"] for r in mine if "refused" in r],
                        "missing_goal": [r["seed"] for r in mine if not meets_goal(r)],
                        "shipped_off_goal": [r["seed"] for r in mine if _shipped_off_goal(r)],
                        "tip_models": sorted({str(r.get("tip_model")) for r in mine})})
    return summary
