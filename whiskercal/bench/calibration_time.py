"""The calibration's stage time against its shipped tip error, plan by plan, on the family.

For each plan (``collect.plans``: ``full``, ``quick``, and ``COARSE`` between them) and
each build (the default 75 mm, the short 60 mm and the long 110 mm sensor, ``BUILDS``), a
session runs as a lab runs it (``bench.sessions.session_row``): ``collect`` of the plan on a
fresh twin world with the wire's two lowest bending modes on (``twin.physics.dynamics``, so a
point sampled too soon after a move reads the ringing), ``fit`` with its defaults, and the
shipped model against the twin's truth in the world frame: the tip curve (RMS, max) and
realistic contacts held. The stage time is the run's own, on the sensor's clock from the rod
leaving the first baseline to the last point's last sample (``RunSummary.points_time_s``).

A plan meets the goal on a build when its points take at most ``GOAL_POINTS_TIME_S``, its
worst seed's true RMS on the tip curve and on realistic contacts is within ``GOAL_MARGIN_MM``
of the full plan's worst, and its estimate stays as honest as the full plan's: the truth over the
estimate, worst seed, no larger than the sessions' honesty factor (``sessions.HONEST_FACTOR``)
or the full plan's own worst ratio where that is larger. How far (mm) each falls below the
truth is reported beside it (``underestimate_mm``).

Beside the sessions, ``settle`` rows give the ring-down after a stop at the stage's
acceleration (``settle_after_stop``): the time after which the average of a point's samples
stays within its own noise, the floor a plan's settle time needs.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from whiskercal.bench import sessions
from whiskercal.bench.sensor_family import FAMILY
from whiskercal.bench.timing import machine_info
from whiskercal.collect.plans import FULL, QUICK, NamedPlan

BUILDS = ("twin-paper-75mm", "twin-short-60mm", "long-110x0.20")
SEEDS = (1, 2)
DYNAMICS_MODES = 2
# between the two: the quick plan's lattice, settle and feeds with the full plan's whole tip
# sweep, which tells the lattice's share of the error from the sweep's
COARSE = NamedPlan("coarse-lattice", "the quick plan's 7 mm lattice, settle and feeds with the "
                   "full 28-point tip sweep", step_mm=QUICK.step_mm, settle_s=QUICK.settle_s,
                   approach_feed_mm_min=QUICK.approach_feed_mm_min,
                   travel_feed_mm_min=QUICK.travel_feed_mm_min)
PLANS = (FULL, COARSE, QUICK)
QUICK_PLANS = (FULL, QUICK)
GOAL_POINTS_TIME_S = 60.0  # the goal's stage time, first point to last
GOAL_MARGIN_MM = 0.01      # the shipped error may exceed the full plan's by this much
SETTLE_SPEEDS_MM_S = (10.0, 25.0)  # the default approach feed (600 mm/min) and quick's (1500)
STAGE_ACCEL_MM_S2 = 200.0


def settle_after_stop(sensor, speed_mm_s: float, samples: int,
                      accel_mm_s2: float = STAGE_ACCEL_MM_S2) -> dict:
    """The wire's ring-down after the rod slides along it at ``speed_mm_s`` and stops at the
    stage's acceleration (``bench.dynamics.slide``'s path): the time after the stop (s) from
    which the mean of ``samples`` consecutive samples of the dynamic z stays within the
    averaged reading's noise (σ_Y / √samples) of the quasi-static z, and the largest
    difference of one sample at the stop (µT)."""
    from whiskercal.bench import dynamics
    from whiskercal.twin.physics.dynamics import DEFAULT_DAMPING_RATIO, RingingRoot, modes

    found = modes(sensor.whisker, DYNAMICS_MODES, DEFAULT_DAMPING_RATIO)
    xs, rotations, shifts = dynamics.slide_path(sensor.whisker)
    period = 1.0 / sensor.magnetometer.rate_hz
    distance = xs[-1] - xs[0]
    _, stop_s = dynamics.travelled_mm(np.zeros(1), distance, speed_mm_s, accel_mm_s2)
    times = np.arange(1, int((stop_s + dynamics.REST_AFTER_S) / period) + 1) * period
    x = xs[0] + dynamics.travelled_mm(times, distance, speed_mm_s, accel_mm_s2)[0]
    rotation = np.interp(x, xs, rotations)
    shift = np.column_stack([np.interp(x, xs, shifts[:, 0]), np.interp(x, xs, shifts[:, 1])])
    ringing = RingingRoot(found, rotations[0], shifts[0])
    poses = [ringing.at(t, r, s) for t, r, s in zip(times, rotation, shift)]
    error = dynamics._z_uT(sensor, [p[0] for p in poses], np.array([p[1] for p in poses])) \
        - dynamics._z_uT(sensor, rotation, shift)
    after = times > stop_s
    averaged = np.convolve(error[after], np.ones(samples) / samples, "valid")
    noise = dynamics._noise_uT(sensor) / math.sqrt(samples)
    late = np.flatnonzero(np.abs(averaged) > noise)
    since_stop = times[after] - stop_s
    return {"build": sensor.sensor_id, "speed_mm_s": speed_mm_s, "samples": samples,
            "averaged_noise_uT": noise, "stop_error_uT": float(np.max(np.abs(error[after][:3]))),
            "settle_s": float(since_stop[late[-1] + 1]) if len(late) else 0.0}


def _realistic_mm(row: dict) -> float:
    return row.get("realistic_held", {}).get("rmse_mm", math.inf)


def underestimate_mm(row: dict) -> float:
    """How far the session's estimate falls below its true tip-curve RMS (mm, 0 when not; inf
    when refused or not estimated)."""
    if "refused" in row or not math.isfinite(row["estimated_tip_error_mm"]):
        return math.inf
    return max(0.0, row["tip_curve_rmse_mm"] - row["estimated_tip_error_mm"])


def truth_over_estimate(row: dict) -> float:
    """The session's true tip-curve RMS over its estimate (inf when refused or estimated 0)."""
    if "refused" in row or not math.isfinite(row["estimated_tip_error_mm"]) \
            or not row["estimated_tip_error_mm"] > 0:
        return math.inf
    return row["tip_curve_rmse_mm"] / row["estimated_tip_error_mm"]


def plan_rows(session_rows: list[dict]) -> list[dict]:
    """One row per build and plan: the worst seed's stage time, true errors and
    underestimate, and the differences from the full plan's on the same build."""
    rows = []
    for build in dict.fromkeys(r["build"] for r in session_rows):
        for plan in dict.fromkeys(r["plan"] for r in session_rows if r["build"] == build):
            mine = [r for r in session_rows if r["build"] == build and r["plan"] == plan]
            rows.append({"build": build, "plan": plan, "sessions": len(mine),
                         "points": max(r.get("points", 0) for r in mine),
                         "points_time_s": max(r.get("points_time_s") or math.nan for r in mine),
                         "worst_rmse_mm": max(r.get("tip_curve_rmse_mm", math.inf) for r in mine),
                         "worst_max_mm": max(r.get("tip_curve_max_mm", math.inf) for r in mine),
                         "worst_realistic_held_mm": max(_realistic_mm(r) for r in mine),
                         "worst_estimate_mm": max(r.get("estimated_tip_error_mm", math.inf)
                                                  for r in mine),
                         "worst_underestimate_mm": max(underestimate_mm(r) for r in mine),
                         "worst_truth_over_estimate": max(truth_over_estimate(r) for r in mine),
                         "refused": [r["seed"] for r in mine if "refused" in r],
                         "tip_models": sorted({str(r.get("tip_model")) for r in mine})})
    _against_full(rows)
    return rows


def _against_full(rows: list[dict]) -> None:
    """Each row's differences from the full plan's row of its build, and the goal's verdict."""
    full = {r["build"]: r for r in rows if r["plan"] == FULL.name}
    for row in rows:
        base = full.get(row["build"])
        if base is None:
            continue
        row["rmse_over_full_mm"] = row["worst_rmse_mm"] - base["worst_rmse_mm"]
        row["realistic_over_full_mm"] = (row["worst_realistic_held_mm"]
                                         - base["worst_realistic_held_mm"])
        allowed = max(sessions.HONEST_FACTOR, base["worst_truth_over_estimate"])
        row["as_honest_as_full"] = row["worst_truth_over_estimate"] <= allowed
        row["meets_goal"] = bool(row["points_time_s"] <= GOAL_POINTS_TIME_S
                                 and row["rmse_over_full_mm"] <= GOAL_MARGIN_MM
                                 and row["realistic_over_full_mm"] <= GOAL_MARGIN_MM
                                 and row["as_honest_as_full"])


def _sessions(builds, seeds, plans, progress) -> list[dict]:
    """Every build on every seed with every plan, in two processes at most (a session's fit is
    the bulk of it); rows in build, plan, seed order."""
    jobs = [(sensor, seed, plan, DYNAMICS_MODES) for sensor in builds for plan in plans
            for seed in seeds]
    rows = sessions.run_jobs(jobs, workers=2, progress=progress)
    return [{**row, "plan": job[2].name} for row, job in zip(rows, jobs)]


def run(quick: bool = False, progress: Callable[[dict], None] | None = None) -> dict:
    """The sessions, their per-plan rows and the settle rows (quick: every build on one seed,
    the full and the quick plan, the settle at the quick plan's approach only)."""
    family = {sensor.sensor_id: sensor for sensor in FAMILY}
    builds = [family[name] for name in BUILDS]
    plans = QUICK_PLANS if quick else PLANS
    seeds = SEEDS[:1] if quick else SEEDS
    speeds = SETTLE_SPEEDS_MM_S[-1:] if quick else SETTLE_SPEEDS_MM_S
    session_rows = _sessions(builds, seeds, plans, progress)
    rows = plan_rows(session_rows)
    settle = [settle_after_stop(sensor, speed, 30) for sensor in builds for speed in speeds]
    quick_rows = [r for r in rows if r["plan"] == QUICK.name]
    return {
        "benchmark": "calibration-time", "quick": quick, "machine": machine_info(),
        "units": {"time": "s", "error": "mm"},
        "setup": {"builds": [b.sensor_id for b in builds], "seeds": list(seeds),
                  "plans": {p.name: {"summary": p.summary, "overrides": p.overrides()}
                            for p in plans},
                  "dynamics_modes": DYNAMICS_MODES, "goal_points_time_s": GOAL_POINTS_TIME_S,
                  "goal_margin_mm": GOAL_MARGIN_MM, "honest_factor": sessions.HONEST_FACTOR},
        "rows": rows, "sessions": session_rows, "settle": settle,
        "pareto": {"x": "points_time_s", "y": "worst_rmse_mm", "series": ["build"],
                   "label": "plan", "x_label": "stage time, first point to last (s)",
                   "y_label": "worst seed's tip RMS vs twin truth (mm)"},
        "supports": {"plan": QUICK.name,
                     "quick_meets_goal_on": [r["build"] for r in quick_rows if r.get("meets_goal")],
                     "quick_misses_goal_on": [r["build"] for r in quick_rows
                                              if not r.get("meets_goal")],
                     "longest_settle_s": max(s["settle_s"] for s in settle),
                     "rule": "a plan of at most 60 s first point to last whose worst tip RMS "
                             "and realistic RMS stay within 0.01 mm of the full plan's, the "
                             "truth at most 2x its estimate (or the full plan's ratio), on "
                             "every build"},
    }
