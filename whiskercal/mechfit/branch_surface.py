"""The fitted model's tip loads for the branch follower, and the follower's error estimated on
the model's own presses (no truth).

``load_branches`` solves the model's space-fixed tip loads (``loadgrid.load_grid``) on a
(direction, size) grid, 1° apart in direction, and keeps those whose root pose lies near the
poses the magnet map was fitted on (``near_fitted_poses``). ``followed_tip_error_mm``
presses the model along each direction from rest, as a plane sliding on the tip does, reads
the noisy (Y, Z) it gives through a follower and compares the tips: one reading's error, and
a held contact's (``table_error.HELD_SAMPLES`` samples averaged).
"""

from __future__ import annotations

import math

import numpy as np

from whiskercal.mechfit.loadgrid import load_grid
from whiskercal.mechfit.table_error import HELD_SAMPLES
from whiskercal.model.load_branches import LoadBranches

ALPHAS_DEG = tuple(np.arange(0.0, 115.01, 1.0))
# one press per this many directions in the estimate; a sample every this many noise units
PRESS_EVERY_ROWS = 2
PRESS_STEP_SIGMAS = 1.0
HELD_POINTS = 6  # places along each press where a contact is held
# a press ends where the tip has moved this fraction of the trace length from rest: the study's
# deepest plane (45 mm on the 75 mm whisker), the range the runtime is calibrated for
DEEPEST_PRESS = 0.6
SNAP_MM = 2.0  # a tip moving this far between neighbouring sizes has snapped
LOST_MM = 5.0  # a press on which a reading's tip is this far off has lost its branch
MIN_ANSWERED = 0.95  # or on which fewer of its readings (all on the model's loads) got a tip
# a load is kept where each component of its root pose lies within the fitted contacts' range
# widened by this share of that range either way
POSE_MARGIN = 0.25


def load_branches(fit, y_range_uT, noise_uT) -> LoadBranches:
    """The model's tip loads as a :class:`LoadBranches` (Y, Z µT from rest, tips mm)."""
    grid = load_grid(fit.suspension, alphas_deg=ALPHAS_DEG)
    sizes = np.unique(grid.magnitude)
    rows = np.rint(np.degrees(grid.alpha_rad) - ALPHAS_DEG[0]).astype(int)
    cols = np.searchsorted(sizes, grid.magnitude) + 1  # column 0: rest
    inside = near_fitted_poses(grid.pose, fit.poses)
    fields = np.full((len(ALPHAS_DEG), len(sizes) + 1, 2), np.nan)
    tips = np.full_like(fields, np.nan)
    # at rest every direction reads nothing (the fields are from rest) and the tip is straight
    fields[:, 0] = 0.0
    tips[:, 0] = (fit.suspension.trace_length_mm, 0.0)
    fields[rows[inside], cols[inside]] = fit.pose_map(grid.pose[inside])[:, :2]
    tips[rows[inside], cols[inside]] = grid.tip_mm[inside]
    return LoadBranches(fields, tips, noise_uT, y_range_uT)


def near_fitted_poses(poses: np.ndarray, fitted: np.ndarray) -> np.ndarray:
    """Which ``poses`` (n, 3) lie within the ``fitted`` poses' range on every component,
    widened by ``POSE_MARGIN`` of it.

    Signed, unlike the table's envelope (``tables.POSE_ENVELOPE`` times the largest pose either
    way): a grid pushes the wire one way, so every contact turns and shifts the root one way,
    while a push past the axis bends the wire the other way, where the map was never fitted.
    With the table's symmetric envelope a stiff root's follower, fed an end-on plane dragged
    the other way with friction, drifts to loads bent the other way and reads the deepest tips
    millimetres off (docs/calibration.md, "Where one reading folds"); such readings get no
    tip."""
    low, high = fitted.min(axis=0), fitted.max(axis=0)
    margin = POSE_MARGIN * (high - low)
    return np.all((poses >= low - margin) & (poses <= high + margin), axis=1)


def followed_tip_error_mm(branches: LoadBranches, sample_noise_uT, seed: int = 0) -> dict:
    """The follower's tip error (mm RMS) on the model's own presses with one sample's noise.

    Returns ``estimate_mm`` per reading and ``held_estimate_mm`` for contacts held
    ``HELD_SAMPLES`` samples, over the presses the follower kept to their branch (NaN with
    none); ``presses``, how many directions were pressed; ``lost_directions_deg``, those on
    which a reading's tip strayed ``LOST_MM`` or more or under ``MIN_ANSWERED`` of the readings
    got one (a press whose readings retrace their own path, where going on and going back read
    alike), left out of the two estimates and named instead."""
    rng = np.random.default_rng(seed)
    noise = np.asarray(sample_noise_uT, float)
    one, held, lost, presses = [], [], [], 0
    for row in range(0, branches.shape[0], PRESS_EVERY_ROWS):
        path = _press(branches, row, noise)
        if path is None:
            continue
        presses += 1
        errors, held_errors = _press_errors(branches, path, noise, rng)
        answered = np.isfinite(errors)
        if answered.mean() < MIN_ANSWERED or np.max(errors[answered]) >= LOST_MM:
            lost.append(float(ALPHAS_DEG[row]))
        else:
            one.append(errors)
            held.extend(held_errors)
    return {"estimate_mm": _rms(np.concatenate(one) if one else np.array([])),
            "held_estimate_mm": _rms(np.array(held)), "presses": presses,
            "lost_directions_deg": lost}


def _press_errors(branches, path, noise, rng):
    """A press's per-reading tip errors (mm), and a held contact's at ``HELD_POINTS`` places
    along it (held as the press reaches them, then pressed on)."""
    fields, tips = path
    holds = set(np.linspace(0, len(fields) - 1, HELD_POINTS + 1)[1:].astype(int).tolist())
    follower, errors, held = branches.follower(), [], []
    for k in range(len(fields)):
        repeats = HELD_SAMPLES if k in holds else 1
        readings = fields[k] + rng.normal(0.0, 1.0, (repeats, 2)) * noise
        read = _read(follower, readings)
        errors.append(float(np.linalg.norm(read[0] - tips[k])))
        if k in holds:
            held.append(float(np.linalg.norm(_mean_tip(read) - tips[k])))
    return np.array(errors), held


def _press(branches: LoadBranches, row: int, noise: np.ndarray):
    """(fields (n, 2), tips (n, 2)) of a press along one direction from its first load until
    its loads stop, leave the Y range or move the tip ``DEEPEST_PRESS`` of the trace length, a
    sample every ``PRESS_STEP_SIGMAS``; None if short."""
    fields, tips = branches.fields_uT[row], branches.tips_mm[row]
    low, high = branches.y_range_uT
    reach = np.linalg.norm(tips[0])
    ok = (np.isfinite(fields[:, 0]) & (fields[:, 0] >= low) & (fields[:, 0] <= high)
          & (np.linalg.norm(tips - tips[0], axis=1) <= DEEPEST_PRESS * reach))
    end = int(np.argmin(ok)) if not ok.all() else len(ok)
    if end < 3 or not ok[1]:
        return None
    out_f, out_t = [fields[1]], [tips[1]]
    for k in range(2, end):
        steps = max(1, math.ceil(np.linalg.norm((fields[k] - fields[k - 1]) / noise)
                                 / PRESS_STEP_SIGMAS))
        if np.linalg.norm(tips[k] - tips[k - 1]) > SNAP_MM:
            steps = 1  # the wire snaps (a push along it buckling): the readings jump too
        t = (np.arange(1, steps + 1) / steps)[:, None]
        out_f.extend(fields[k - 1] + t * (fields[k] - fields[k - 1]))
        out_t.extend(tips[k - 1] + t * (tips[k] - tips[k - 1]))
    return np.array(out_f), np.array(out_t)


def _read(follower, readings: np.ndarray) -> np.ndarray:
    return np.array([follower.tip_scalar(float(y), float(z)) for y, z in readings])


def _mean_tip(tips: np.ndarray) -> np.ndarray:
    answered = np.isfinite(tips[:, 0])
    return tips[answered].mean(axis=0) if answered.any() else np.full(2, np.nan)


def _rms(errors: np.ndarray) -> float:
    errors = errors[np.isfinite(errors)]
    return float(np.sqrt(np.mean(errors ** 2))) if len(errors) else float("nan")
