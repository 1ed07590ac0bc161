"""Per-trial analysis of the flat-plane study: errors against the plane, contact, slips, failure.

Pure numpy: arrays in, arrays out. The inputs of one trial are the slide's samples (deflection z,
the tip estimates before and after the filter, the plane's line in the whisker frame per sample),
the push-in's depth and z, and, on the twin, the true tip and equilibrium kind per sample. The
error of an estimate is its distance to the plane's line, as in the paper; on the twin it is also
compared with the true tip.

Slips and tangential contact are detected from the data alone, never from the twin's truth
(whiskercal.study.detect): slips are jumps of z; tangential contact shows as a kink of z(depth)
during the push-in, as tip estimates that leave the plane's line (the lookup assumes a contact at
the tip), or, across trials, as a median |z| that stops growing with depth or grows faster than
below (the contact stiffened).
"""

from __future__ import annotations

from dataclasses import dataclass, field, asdict

import numpy as np

from whiskercal.study.detect import (depth_gains, detect_kink, detect_slips, monotone_breaks,
                                     stiffening_breaks)


@dataclass(frozen=True)
class Criteria:
    """Thresholds that decide slips, tangential contact and failing trials (mm, µT)."""

    max_mean_error_mm: float = 2.0
    """A trial whose mean filtered error against the plane reaches this fails (the paper's bound)."""
    min_contact_fraction: float = 0.5
    """A trial in contact for less of its slide than this fails (the tip lost the plane)."""
    off_plane_mm: float = 2.0
    """A raw estimate farther than this from the plane's line has left the plane."""
    max_off_plane_fraction: float = 0.2
    """More of the contact samples off the plane than this means tangential contact."""
    jump_sigma: float = 6.0
    """A slip is a step of z that leaves the median step by this many robust standard deviations
    of the steps: at six every jump of the default sensor's stick-slip at the paper's depth
    stands out of its noise's steps, where eight would miss some
    (docs/research/2026-11-29-study.md) ..."""
    jump_floor_uT: float = 60.0
    """... and by this absolute size, so that quantization never counts as a slip."""
    min_contact_samples: int = 10
    """Fewer contact samples than this cannot give an error statistic."""
    max_unlocalized_fraction: float = 0.1
    """More contact samples than this without a tip estimate (z outside the calibration) fails."""
    min_travel_fraction: float = 0.9
    """A slide shorter than this fraction of the planned travel was cut short."""
    settle_mm: float = 2.0
    """The first part of each slide (mm) is left out of the error statistics: the tip still
    carries the push-in's friction state until it breaks loose into steady sliding."""
    kink_tolerance: float = 0.3
    """During the push-in, a slope dz/d depth that leaves its trend by this fraction (and by
    more than 4 standard errors) means the contact changed kind (tangential contact)."""
    kink_window_mm: float = 1.25
    """Depth window of each slope estimate in the kink test (mm)."""
    stiffening_tolerance: float = 0.02
    """Across trials, a gain of |z| per mm of depth that exceeds the gain below it by this
    fraction means the contact stiffened (tangential contact); in tip contact it only falls."""


@dataclass
class TrialSeries:
    """The samples of one trial's slide, in the whisker frame.

    ``plane_point_mm`` and ``plane_normal`` (n, 2) give the plane's line per sample (a point on it
    and its unit normal). ``contact`` is the collision detector's flag; ``raw_tip_mm`` and
    ``filtered_tip_mm`` are NaN where there is no estimate. ``true_tip_mm`` and ``true_kind``
    exist only on the twin.
    """

    depth_mm: float
    t_s: np.ndarray
    z_uT: np.ndarray
    contact: np.ndarray
    raw_tip_mm: np.ndarray
    filtered_tip_mm: np.ndarray
    plane_point_mm: np.ndarray
    plane_normal: np.ndarray
    true_tip_mm: np.ndarray | None = None
    true_kind: np.ndarray | None = None
    slid_mm: float = float("nan")
    """How far the stage actually slid the plane (mm); NaN when unknown."""
    planned_travel_mm: float = float("nan")
    """How far it was meant to slide (mm)."""
    steady: np.ndarray | None = None
    """Samples past the settling distance (bool per sample); None: all of them."""
    approach_depth_mm: np.ndarray | None = None
    """The push-in's samples: depth past first contact (mm) ..."""
    approach_z_uT: np.ndarray | None = None
    """... and z (µT)."""


@dataclass
class TrialMetrics:
    """The per-trial table row (errors in mm, z in µT). NaN where a quantity does not exist."""

    depth_mm: float
    n_samples: int
    contact_fraction: float
    median_z_uT: float
    raw_mean_mm: float
    raw_std_mm: float
    filtered_mean_mm: float
    filtered_std_mm: float
    off_plane_fraction: float
    n_slips: int
    unlocalized_fraction: float = float("nan")
    slid_mm: float = float("nan")
    kink_depth_mm: float = float("nan")
    slip_indices: list[int] = field(default_factory=list)
    tangential: bool = False
    true_raw_mean_mm: float = float("nan")
    true_filtered_mean_mm: float = float("nan")
    true_tangential_fraction: float = float("nan")
    failing: bool = False
    reasons: list[str] = field(default_factory=list)

    def as_dict(self) -> dict:
        """JSON-able row (NaN becomes None)."""
        row = asdict(self)
        return {key: (None if isinstance(value, float) and np.isnan(value) else value)
                for key, value in row.items()}


def distance_to_line_mm(points_mm: np.ndarray, line_point_mm: np.ndarray,
                        line_normal: np.ndarray) -> np.ndarray:
    """Unsigned distance (mm) of points (n, 2) to lines given per point by a point and a unit normal.

    NaN points give NaN.
    """
    offset = np.asarray(points_mm, float) - np.asarray(line_point_mm, float)
    return np.abs(np.sum(offset * np.asarray(line_normal, float), axis=-1))


def _mean_std(values: np.ndarray) -> tuple[float, float]:
    values = values[np.isfinite(values)]
    if values.size == 0:
        return float("nan"), float("nan")
    return float(np.mean(values)), float(np.std(values))


def analyse_trial(series: TrialSeries, criteria: Criteria = Criteria()) -> TrialMetrics:
    """Errors, contact, slips and tangential contact of one trial; flags it failing with reasons.

    Parameters
    ----------
    series
        The slide's samples of one trial (and its push-in).
    criteria
        Thresholds for slips, tangential contact and failure.

    Returns
    -------
    TrialMetrics
        The trial's row; failing trials carry one short reason each in ``reasons``.
    """
    contact = np.asarray(series.contact, bool)
    steady = np.ones(contact.size, bool) if series.steady is None else np.asarray(series.steady, bool)
    judged = contact & steady
    raw_error = np.where(judged, distance_to_line_mm(series.raw_tip_mm, series.plane_point_mm,
                                                     series.plane_normal), np.nan)
    filtered_error = np.where(judged, distance_to_line_mm(
        series.filtered_tip_mm, series.plane_point_mm, series.plane_normal), np.nan)
    raw_mean, raw_std = _mean_std(raw_error)
    filtered_mean, filtered_std = _mean_std(filtered_error)
    measured = np.isfinite(raw_error)
    slips = detect_slips(series.z_uT, contact, criteria.jump_sigma, criteria.jump_floor_uT)
    metrics = TrialMetrics(
        depth_mm=float(series.depth_mm), n_samples=int(contact.size),
        contact_fraction=float(contact.mean()) if contact.size else 0.0,
        median_z_uT=float(np.median(series.z_uT[judged])) if judged.any() else float("nan"),
        raw_mean_mm=raw_mean, raw_std_mm=raw_std,
        filtered_mean_mm=filtered_mean, filtered_std_mm=filtered_std,
        off_plane_fraction=float(np.mean(raw_error[measured] > criteria.off_plane_mm))
        if measured.any() else float("nan"),
        n_slips=int(slips.size), slip_indices=slips.tolist(), slid_mm=float(series.slid_mm),
        unlocalized_fraction=_unlocalized(series.raw_tip_mm, contact))
    metrics.kink_depth_mm = _kink(series, criteria)
    metrics.tangential = bool(metrics.off_plane_fraction > criteria.max_off_plane_fraction
                              or np.isfinite(metrics.kink_depth_mm))
    _add_truth(metrics, series, judged)
    _judge(metrics, int(judged.sum()), criteria)
    if series.slid_mm < criteria.min_travel_fraction * series.planned_travel_mm:
        metrics.reasons.insert(0, f"cut short: slid {series.slid_mm:.1f} of "
                                  f"{series.planned_travel_mm:g} mm")
        metrics.failing = True
    return metrics


def _unlocalized(raw_tip_mm: np.ndarray, contact: np.ndarray) -> float:
    """Share of the contact samples without a raw tip estimate."""
    if not contact.any():
        return float("nan")
    return float(np.mean(~np.isfinite(np.asarray(raw_tip_mm, float)[contact, 0])))


def _kink(series: TrialSeries, criteria: Criteria) -> float:
    """Depth where the push-in kinked (tangential contact), NaN if it did not or is unknown."""
    if series.approach_depth_mm is None or series.approach_z_uT is None:
        return float("nan")
    return detect_kink(series.approach_depth_mm, series.approach_z_uT,
                       criteria.kink_window_mm, criteria.kink_tolerance)


def _add_truth(metrics: TrialMetrics, series: TrialSeries, contact: np.ndarray) -> None:
    """Errors against the twin's true tip, and how much of the slide was truly tangential."""
    if series.true_tip_mm is None:
        return
    true_tip = np.asarray(series.true_tip_mm, float)
    raw = np.linalg.norm(np.asarray(series.raw_tip_mm, float) - true_tip, axis=1)
    filtered = np.linalg.norm(np.asarray(series.filtered_tip_mm, float) - true_tip, axis=1)
    metrics.true_raw_mean_mm = _mean_std(np.where(contact, raw, np.nan))[0]
    metrics.true_filtered_mean_mm = _mean_std(np.where(contact, filtered, np.nan))[0]
    if series.true_kind is not None and contact.any():
        kinds = np.asarray(series.true_kind).astype(str)
        metrics.true_tangential_fraction = float(np.mean(kinds[contact] == "tangential"))


def _judge(metrics: TrialMetrics, n_contact: int, criteria: Criteria) -> None:
    """Flag the trial failing, with a reason for each criterion it misses."""
    reasons = metrics.reasons
    if n_contact < criteria.min_contact_samples:
        reasons.append(f"no contact ({n_contact} samples above the collision threshold)")
    elif metrics.contact_fraction < criteria.min_contact_fraction:
        reasons.append(f"in contact for only {metrics.contact_fraction:.0%} of the slide")
    if metrics.unlocalized_fraction > criteria.max_unlocalized_fraction:
        reasons.append(f"{metrics.unlocalized_fraction:.0%} of the contact samples have no tip "
                       "estimate (z outside the calibrated range)")
    if np.isfinite(metrics.kink_depth_mm):
        reasons.append(f"tangential contact: z(depth) kinked at {metrics.kink_depth_mm:.1f} mm "
                       "during the push-in (the contact changed kind)")
    if metrics.off_plane_fraction > criteria.max_off_plane_fraction:
        reasons.append(f"tangential contact: {metrics.off_plane_fraction:.0%} of the estimates "
                       f"more than {criteria.off_plane_mm:g} mm off the plane")
    if np.isfinite(metrics.filtered_mean_mm) and metrics.filtered_mean_mm >= criteria.max_mean_error_mm:
        reasons.append(f"mean filtered error {metrics.filtered_mean_mm:.2f} mm "
                       f">= {criteria.max_mean_error_mm:g} mm")
    metrics.failing = bool(reasons)


def analyse_study(trials: list[TrialSeries], criteria: Criteria = Criteria()) -> list[TrialMetrics]:
    """Analyse every trial and add the across-trial monotonicity check (failing trials flagged).

    Returns the rows in order of depth.
    """
    rows = sorted((analyse_trial(series, criteria) for series in trials), key=lambda r: r.depth_mm)
    depths = np.array([r.depth_mm for r in rows])
    medians = np.array([r.median_z_uT for r in rows])
    breaks = monotone_breaks(depths, medians)
    for row, broken in zip(rows, breaks):
        if broken:
            row.reasons.append("median |z| does not grow with depth (contact changed kind)")
            row.failing = True
    _flag_stiffening(rows, depths, medians, criteria)
    return rows


def _flag_stiffening(rows: list[TrialMetrics], depths: np.ndarray, medians: np.ndarray,
                     criteria: Criteria) -> None:
    """Mark the trials where |z| grows faster with depth than below them as tangential."""
    gains = depth_gains(depths, medians)
    flagged = stiffening_breaks(depths, medians, criteria.stiffening_tolerance)
    first = int(np.argmax(flagged))  # flagged trials are this one and every deeper one
    for row, stiffened in zip(rows, flagged):
        if not stiffened:
            continue
        row.tangential = True
        row.failing = True
        row.reasons.append(
            f"tangential contact: median |z| grew {gains[first]:.0f} µT/mm from "
            f"{depths[first - 1]:g} to {depths[first]:g} mm, faster than the "
            f"{gains[first - 1]:.0f} µT/mm below (the contact stiffened)")
