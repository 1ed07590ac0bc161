"""An estimate of the (Y, Z) table's tip error made without the truth.

One reading of Y and Z carries one sample's noise. Two parts, added in quadrature:

- the noise carried through the table's slope (``noise_propagation_mm``): on a smooth
  one-to-one table, the error a reading's noise makes (hundredths of a millimetre on the
  default sensor);
- the table's ambiguity (``ambiguity_tip_error_mm``): the table's tip loads whose fields lie
  within twice one reading's noise of each other cannot be told apart by the runtime, so the
  spread of their tips is an error the table must make; where different loads give the same
  (Y, Z) (a thin wire bent both ways past the axis, a suspension fitted wrong whose loads fold
  over) it is the distance between the branches.

The same two parts at the noise of a contact held for ``HELD_SAMPLES`` samples (one reading's
noise over the square root of their number) give the held estimate: the part of the error that
averaging readings cannot remove (folds between loads stay; noise through the slope shrinks).

It cannot see a model that is wrong everywhere in the same smooth way: the fit's residual and
identification profile are the checks for that (``fit.field_table``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

# a reading lies within this many standard deviations (scaled per axis) 86 % of the time
AMBIGUITY_RADIUS = 2.0
# loads used at most (a random, seeded subset keeps the estimate well under a second)
MAX_POINTS = 4000
# a held contact's samples (0.1 s at 300 Hz) whose tips are averaged; once settled, the
# runtime's filter (q 1e-5 mm²) weighs about σ/√q samples: 300 for tips scattered by 1 mm
HELD_SAMPLES = 30


def ambiguity_tip_error_mm(fields_uT: np.ndarray, tips_mm: np.ndarray, sample_noise_uT,
                           seed: int = 0) -> float:
    """RMS distance (mm) between a load's tip and the tips of the loads whose (Y, Z) lie within
    twice one sample's noise ``sample_noise_uT`` (Y, Z µT) of its own; NaN with under two loads."""
    fields, tips = np.asarray(fields_uT, float), np.asarray(tips_mm, float)
    keep = np.all(np.isfinite(fields), axis=1) & np.all(np.isfinite(tips), axis=1)
    fields, tips = fields[keep], tips[keep]
    if len(fields) < 2:
        return float("nan")
    scaled = fields / np.broadcast_to(np.asarray(sample_noise_uT, float), (2,))
    tree = cKDTree(scaled)
    rng = np.random.default_rng(seed)
    chosen = rng.choice(len(fields), min(MAX_POINTS, len(fields)), replace=False)
    squares = []
    for index in chosen:
        near = tree.query_ball_point(scaled[index], AMBIGUITY_RADIUS)
        squares.append(np.mean(np.sum((tips[near] - tips[index]) ** 2, axis=1)))
    return float(np.sqrt(np.mean(squares)))


def noise_propagation_mm(y_uT: np.ndarray, z_uT: np.ndarray, tips_mm: np.ndarray,
                         sample_noise_uT) -> float:
    """RMS over the table's answered cells of the tip error (mm) one reading's noise makes
    through the table's slope (central differences; NaN when no cell has a slope)."""
    noise = np.broadcast_to(np.asarray(sample_noise_uT, float), (2,))
    along_y = np.gradient(tips_mm, y_uT, axis=0)
    along_z = np.gradient(tips_mm, z_uT, axis=1)
    squares = (np.sum(along_y ** 2, axis=-1) * noise[0] ** 2
               + np.sum(along_z ** 2, axis=-1) * noise[1] ** 2)
    finite = np.isfinite(squares)
    return float(np.sqrt(np.mean(squares[finite]))) if finite.any() else float("nan")


def z_lookup_tip_error_mm(fields_uT: np.ndarray, tips_mm: np.ndarray, lookup) -> float:
    """RMS distance (mm) between the table's loads' tips and the z lookup's tip at their Y:
    what reading Y alone costs on the loads the table covers (NaN where it answers none)."""
    y = np.asarray(fields_uT, float)[:, 0]
    covered = (y >= lookup.z_min_uT) & (y <= lookup.z_max_uT)
    if not covered.any():
        return float("nan")
    miss = lookup(y[covered]) - np.asarray(tips_mm, float)[covered]
    return float(np.sqrt(np.mean(np.sum(miss ** 2, axis=1))))


def estimated_tip_error_mm(fields_uT, tips_mm, table, sample_noise_uT, lookup=None) -> dict:
    """The table's estimated tip error (mm RMS) for one reading, and its two parts; the same for
    a contact held ``HELD_SAMPLES`` samples (``held_estimate_mm``); with the model's z
    ``lookup``, the same loads' error read from Y alone (``z_lookup_mm``)."""
    one = _estimate(fields_uT, tips_mm, table, np.asarray(sample_noise_uT, float))
    held = _estimate(fields_uT, tips_mm, table,
                     np.asarray(sample_noise_uT, float) / np.sqrt(HELD_SAMPLES))
    out = {**one, "held_estimate_mm": held["estimate_mm"], "held_samples": HELD_SAMPLES}
    if lookup is not None:
        out["z_lookup_mm"] = z_lookup_tip_error_mm(fields_uT, tips_mm, lookup)
    return out


def _estimate(fields_uT, tips_mm, table, noise_uT) -> dict:
    """The two parts at a reading's noise ``noise_uT`` (Y, Z µT), and their sum in quadrature."""
    spread = ambiguity_tip_error_mm(fields_uT, tips_mm, noise_uT)
    slope = noise_propagation_mm(table.y_uT, table.z_uT, table.tips_mm, noise_uT)
    return {"estimate_mm": float(np.hypot(spread, slope)), "ambiguity_mm": spread,
            "noise_through_slope_mm": slope}
