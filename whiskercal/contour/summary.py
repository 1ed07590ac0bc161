"""The numbers of a contour run against the object's true outline (world frame, mm).

Only the samples the controller was following with (phase "follow") count as reconstructed
contacts. docs/contour.md explains each number.
"""

from __future__ import annotations

import math

import numpy as np

from whiskercal.artifacts.contour_run import ContourRunFile
from whiskercal.contour.metrics import contour_metrics
from whiskercal.errors import UsageError
from whiskercal.twin.outlines import recorded


def outline_of(run: ContourRunFile):
    """The run's object, as recorded; a run on a robot has none (UsageError)."""
    if len(run.core_mm) == 0:
        raise UsageError(f"{run.path or 'the run'} was run on a robot and records no object: "
                         "measure it against the object's outline instead")
    return recorded(run.shape, run.core_mm, run.radius_mm)


def followed(run: ContourRunFile) -> np.ndarray:
    """Mask of the samples with a reconstructed contact while following."""
    estimate = run.columns["estimate_mm"]
    return (run.columns["phase"] == "follow") & np.isfinite(estimate[:, 0])


def time_to_go_round_s(run: ContourRunFile) -> float | None:
    """Robot time (s) until the contacts have swept 360° about the object's centre (NaN: never;
    None for an open outline, the wall, which has no round)."""
    if not outline_of(run).closed:
        return None
    mask = followed(run)
    if mask.sum() < 2:
        return float("nan")
    points = run.columns["estimate_mm"][mask] - np.mean(run.core_mm, axis=0)
    swept = np.abs(np.unwrap(np.arctan2(points[:, 1], points[:, 0])) - math.atan2(points[0, 1], points[0, 0]))
    done = np.flatnonzero(swept >= 2 * math.pi)
    return float(run.columns["t_s"][mask][done[0]] - run.columns["t_s"][mask][0]) if done.size else float("nan")


# the phase of a follower stopped for good ("gave-up" in runs written before the phases were named)
STOPPED = ("stopped", "gave-up")
_PRESSED = ("follow", "round-edge", "enter-corner")  # touching, the target reached (or turning)


def contacts_lost(phase: np.ndarray) -> int:
    """How often the follower backed off from following, or from turning about a corner."""
    return int(np.sum((phase[1:] == "back-off") & np.isin(phase[:-1], _PRESSED)))


def reachable(run: ContourRunFile, dense: np.ndarray) -> np.ndarray:
    """The part of the (densely sampled) outline the run can follow: all of a closed one; an
    open one's from where the twin's tip first touched it to its end (the follower keeps the
    object on its left, so it never goes back past its start)."""
    if outline_of(run).closed:
        return dense
    touched = run.columns["true_contact_mm"]
    touched = touched[np.isfinite(touched[:, 0])] if len(touched) else touched
    if not len(touched):
        return dense
    return dense[int(np.argmin(np.linalg.norm(dense - touched[0], axis=1))):]


def rules_fired(run: ContourRunFile) -> dict[str, int]:
    """How often each rule changed the controller's phase (``follow.phases.RULES``; empty for
    runs recorded before the phases were)."""
    rules, counts = np.unique(run.transitions.get("rule", np.zeros(0, str)), return_counts=True)
    return {str(rule): int(count) for rule, count in zip(rules, counts)}


def summarize(run: ContourRunFile) -> dict:
    """Every number of the report (JSON-able)."""
    mask, columns = followed(run), run.columns
    dense = outline_of(run).dense()
    metrics = contour_metrics(columns["estimate_mm"][mask], dense, reachable(run, dense))
    duration = float(columns["t_s"][-1]) if len(columns["t_s"]) else 0.0
    return {"shape": run.shape, "sensor_id": run.sensor_id, "target_z_uT": run.target_z_uT,
            **metrics, "slips": int(np.sum(columns["slip"])),
            "twin_slips": int(np.sum(columns["twin_slips"])) if "twin_slips" in columns else None,
            "contacts_lost": contacts_lost(columns["phase"]),
            "gave_up": bool(np.any(np.isin(columns["phase"], STOPPED))),
            "collided": bool(np.any(columns["kind"] == "collision")),
            "time_to_go_round_s": time_to_go_round_s(run), "duration_s": duration,
            "follow_share": float(np.mean(mask)) if len(mask) else 0.0,
            "z_mean_follow_uT": float(np.mean(columns["z_uT"][mask])) if mask.any() else float("nan"),
            "tip_contact_share": float(np.mean(columns["kind"][mask] == "tip")) if mask.any() else float("nan"),
            "control_ms_mean": 1e3 * float(np.mean(columns["control_s"])) if len(columns["control_s"]) else 0.0,
            "control_ms_max": 1e3 * float(np.max(columns["control_s"])) if len(columns["control_s"]) else 0.0,
            "realtime_factor": duration / run.wall_s if run.wall_s > 0 else float("nan"),
            "rules_fired": rules_fired(run), "complete": run.complete, "seed": run.seed}
