"""Choosing the deflection target from the study's per-trial table.

The rule (documented in docs/study.md and stated in every report):

1. Candidates are the trials that pass and whose two neighbours in depth (the next shallower and
   the next deeper trial of the study) were measured and pass: the target must leave tested room
   on both sides for the active controller, which holds z near the target but not on it. So the
   shallowest and the deepest trial are never the target, nor any trial next to a failing one.
2. Each candidate gets a score in mm, smaller is better::

       score = mean + 2 * std + margin_weight_mm * step_mm / margin_mm

   ``mean`` and ``std`` are the filtered error against the plane (accuracy and stability: mean +
   2 std bounds ~95 % of the estimates), and ``margin_mm`` is the distance in depth to the nearest
   failing trial (infinite when none fails), so the penalty is ``margin_weight_mm`` one step from a
   failure and falls off with distance.
3. Scores within ``tie_mm`` of the lowest are a tie: the plane cannot tell those depths apart.
   Among them the shallowest wins: the smaller deflection presses the object less and leaves
   the most room before the whisker slips past an edge, where the contour loop fails first as
   the target deepens (docs/contour.md). The target z is the winner's median z.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from whiskercal.checks import number
from whiskercal.errors import WhiskercalError
from whiskercal.study.analysis import TrialMetrics

RULE_TEXT = ("lowest mean + 2*std of the filtered error against the plane, plus "
             "margin_weight_mm*step/margin to the nearest failing depth, among passing trials "
             "whose two neighbouring depths were measured and pass; scores within tie_mm of the "
             "lowest tie, and the shallowest of them wins")
# A fifth of the 0.25 mm tip goal: score differences this small are not what decides a target.
TIE_MM = 0.05


class NoTargetError(WhiskercalError):
    """No trial qualifies as the deflection target."""


@dataclass(frozen=True)
class TargetChoice:
    """The chosen target and why."""

    depth_mm: float
    z_uT: float
    score_mm: float
    margin_mm: float
    rule: str
    reason: str
    scores_mm: dict[float, float]

    def as_dict(self) -> dict:
        """JSON-able form (infinite margins become None)."""
        return {"depth_mm": self.depth_mm, "z_uT": self.z_uT, "score_mm": self.score_mm,
                "margin_mm": self.margin_mm if np.isfinite(self.margin_mm) else None,
                "rule": self.rule, "reason": self.reason,
                "scores_mm": {str(depth): score for depth, score in self.scores_mm.items()}}


def _margins_mm(depths: np.ndarray, failing: np.ndarray) -> np.ndarray:
    """Distance in depth (mm) from each trial to the nearest failing one (inf if none fails)."""
    if not failing.any():
        return np.full(depths.size, np.inf)
    failing_depths = depths[failing]
    return np.min(np.abs(depths[:, None] - failing_depths[None, :]), axis=1)


def _next_to_failure(failing: np.ndarray) -> np.ndarray:
    """True for trials whose neighbour in depth order fails or was not measured (the ends)."""
    left = np.concatenate([[True], failing[:-1]])
    right = np.concatenate([failing[1:], [True]])
    return left | right


def choose_target(rows: list[TrialMetrics], margin_weight_mm: float = 0.1,
                  tie_mm: float = TIE_MM) -> TargetChoice:
    """Pick the deflection target from the per-trial rows (any order).

    Parameters
    ----------
    rows
        The per-trial table from :func:`whiskercal.study.analysis.analyse_study`.
    margin_weight_mm
        Penalty (mm) for a candidate one depth step away from a failing trial; halves at two
        steps. Candidates adjacent to a failure are excluded outright.
    tie_mm
        Scores within this of the lowest tie; the shallowest tied depth wins.

    Raises
    ------
    NoTargetError
        When every trial fails or is adjacent to a failure.
    UsageError
        When ``margin_weight_mm`` or ``tie_mm`` is negative or not finite.
    """
    margin_weight_mm = number(margin_weight_mm, "the margin weight", low=0, unit="mm")
    tie_mm = number(tie_mm, "the tie tolerance", low=0, unit="mm")
    rows = sorted(rows, key=lambda row: row.depth_mm)
    depths = np.array([row.depth_mm for row in rows], float)
    failing = np.array([row.failing for row in rows], bool)
    margins = _margins_mm(depths, failing)
    step_mm = float(np.min(np.diff(depths))) if depths.size > 1 else 1.0
    eligible = ~failing & ~_next_to_failure(failing)
    scores = {}
    for row, margin, ok in zip(rows, margins, eligible):
        if ok:
            penalty = margin_weight_mm * step_mm / margin if np.isfinite(margin) else 0.0
            scores[row.depth_mm] = row.filtered_mean_mm + 2 * row.filtered_std_mm + penalty
    scores = {depth: score for depth, score in scores.items() if np.isfinite(score)}
    if not scores:
        raise NoTargetError("no trial qualifies as the target: every trial fails, is next to a "
                            "failing one, or is at an end of the measured depths")
    margin_of = dict(zip(depths.tolist(), margins.tolist()))
    lowest = min(scores.values())
    tied = [depth for depth, score in scores.items() if score <= lowest + tie_mm]
    best = min(tied)
    winner = rows[int(np.flatnonzero(depths == best)[0])]
    return TargetChoice(
        depth_mm=best, z_uT=winner.median_z_uT, score_mm=scores[best], margin_mm=margin_of[best],
        rule=RULE_TEXT, reason=_reason(winner, margin_of[best], rows, len(tied), tie_mm),
        scores_mm=scores)


def _reason(winner: TrialMetrics, margin_mm: float, rows: list[TrialMetrics], n_tied: int,
            tie_mm: float) -> str:
    """One sentence saying why this depth won."""
    failing = [row.depth_mm for row in rows if row.failing]
    where = (f"{margin_mm:g} mm from the nearest failing depth ({', '.join(f'{d:g}' for d in failing)} mm)"
             if failing else "no trial failed")
    why = ("lowest score among the eligible depths" if n_tied == 1 else
           f"the shallowest of {n_tied} eligible depths whose scores lie within {tie_mm:g} mm "
           "of the lowest")
    return (f"{winner.depth_mm:g} mm: filtered error {winner.filtered_mean_mm:.3f} ± "
            f"{winner.filtered_std_mm:.3f} mm, {where}; {why}")
