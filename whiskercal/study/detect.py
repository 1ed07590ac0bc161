"""Detectors of slips and of tangential contact, from the measurements alone (never the truth).

- :func:`detect_slips`: jumps of z between consecutive samples far above the stream's own
  sample-to-sample fluctuation: the tip breaking loose and snapping to a new equilibrium. In
  stick-slip the stuck tip is dragged along and z drifts steadily one way between slips, so a
  jump is measured from the typical (median) step, not from zero.
- :func:`detect_kink`: while the plane is pushed in, a tip contact bends the whisker along a
  smooth curve z(depth) whose slope changes by a few percent per mm. When the shaft meets the
  plane before the tip does (tangential contact), the contact moves toward the root, the lever
  arm shortens and the slope jumps (on the twin it about doubles once tangential); when the
  contact snaps to another equilibrium, z stalls
  or falls back. Either way the slope leaves its trend.
- :func:`contact_onset_mm`: where the plane first touched the tip during the contact search. The
  step where |z| first exceeds the collision threshold lies threshold/slope past it (about 1 mm
  on the default sensor, 6 mm on a build that reads 50 µT per mm of depth); in tip contact z
  grows linearly with depth at first, so the steps between the noise and the threshold,
  extrapolated back to z = 0, place the onset.
- :func:`monotone_breaks`: across trials, the median |z| must grow with depth.
- :func:`stiffening_breaks`: across trials, in tip contact |z| grows ever more slowly with depth
  (z(depth) is concave: the bent whisker turns its root less per mm the deeper it is pushed).
  When the shaft lies on the plane the lever arm shortens and |z| grows faster again: the first
  trial whose gain per mm exceeds the gain below it marks tangential contact, and so does every
  deeper trial.
"""

from __future__ import annotations

import numpy as np

MAD_TO_SIGMA = 1.4826
"""Scale from the median absolute deviation to the standard deviation of a normal distribution."""


def robust_sigma(values: np.ndarray) -> float:
    """Standard deviation estimated from the median absolute deviation (ignores outliers, NaN)."""
    values = np.asarray(values, float)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return float("nan")
    return float(MAD_TO_SIGMA * np.median(np.abs(values - np.median(values))))


def detect_slips(z_uT: np.ndarray, contact: np.ndarray, jump_sigma: float = 8.0,
                 jump_floor_uT: float = 60.0) -> np.ndarray:
    """Indices of samples where z jumps: the first sample after each slip.

    Only steps between two samples that are both in contact count (making and losing contact is
    not a slip). A step is a jump when it leaves the median step (the drift of a stuck tip being
    dragged along) by more than ``jump_sigma`` robust standard deviations of the steps, and by
    at least ``jump_floor_uT`` (a floor for quantized, nearly noise-free streams).
    """
    z_uT = np.asarray(z_uT, float)
    contact = np.asarray(contact, bool)
    if z_uT.size < 3:
        return np.zeros(0, dtype=int)
    steps = np.diff(z_uT)
    both_in_contact = contact[1:] & contact[:-1]
    if not both_in_contact.any():
        return np.zeros(0, dtype=int)
    sigma = robust_sigma(steps[both_in_contact])
    drift = float(np.median(steps[both_in_contact]))
    threshold = max(jump_floor_uT, jump_sigma * sigma) if np.isfinite(sigma) else jump_floor_uT
    jumps = both_in_contact & (np.abs(steps - drift) > threshold)
    return np.flatnonzero(jumps) + 1


def window_slopes(depth_mm: np.ndarray, z_uT: np.ndarray, window_mm: float,
                  min_samples: int = 6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares slope dz/d depth (µT/mm) in consecutive depth windows.

    Returns the windows' centres (mm), slopes (µT/mm) and the slopes' standard errors (µT/mm);
    windows with fewer than ``min_samples`` samples, or spanning less than half a window, get NaN.
    """
    depth_mm, z_uT = np.asarray(depth_mm, float), np.asarray(z_uT, float)
    if depth_mm.size == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    edges = np.arange(np.min(depth_mm), np.max(depth_mm) + window_mm, window_mm)
    rows = []
    for low, high in zip(edges[:-1], edges[1:]):
        inside = (depth_mm >= low) & (depth_mm < high)
        rows.append((0.5 * (low + high), *_slope(depth_mm[inside], z_uT[inside], window_mm, min_samples)))
    if not rows:  # all depths equal (within rounding): no window spans any depth
        return np.zeros(0), np.zeros(0), np.zeros(0)
    centres, slopes, errors = (np.asarray(column) for column in zip(*rows))
    return centres, slopes, errors


def _slope(x: np.ndarray, y: np.ndarray, window: float, min_samples: int) -> tuple[float, float]:
    """Slope and its standard error of a straight-line fit, NaN when the data cannot tell."""
    if x.size < min_samples or np.ptp(x) < 0.5 * window:
        return float("nan"), float("nan")
    spread = np.sum((x - x.mean()) ** 2)
    slope = float(np.sum((x - x.mean()) * (y - y.mean())) / spread)
    residual = y - y.mean() - slope * (x - x.mean())
    return slope, float(np.sqrt(np.sum(residual ** 2) / (x.size - 2) / spread))


def detect_kink(depth_mm: np.ndarray, z_uT: np.ndarray, window_mm: float = 1.25,
                tolerance: float = 0.3, sigmas: float = 4.0, start_mm: float = 2.5,
                history: int = 4, wander_sigmas: float = 3.0) -> float:
    """Depth (mm) where z(depth) of a push-in leaves its smooth course, or NaN if it never does.

    In tip contact the slope dz/d depth changes slowly (a few percent per mm). The slope of each
    depth window is compared with the median slope of the ``history`` windows before it; a
    window whose slope differs from that trend by more than ``tolerance`` of it, by more than
    ``sigmas`` standard errors of its own estimate (so noise never counts) and by more than
    ``wander_sigmas`` times the slopes' wander before it (``_wander``), and whose next window
    does too on the same side (the tip's stick-slip on a weak build moves one window, a change
    of contact lasts), marks a change of
    contact: stiffening when the shaft meets the plane (the lever arm shortens), or z stalling or
    falling back when the contact jumps to another equilibrium.

    Parameters
    ----------
    depth_mm, z_uT
        The push-in's samples: depth past first contact (mm) and z (µT).
    window_mm
        Depth window of each slope estimate (mm).
    tolerance
        Relative change of slope that counts as a kink.
    sigmas
        Noise guard, in standard errors of the window's slope.
    start_mm
        Depths below this are ignored (the first contact's own transition).
    history
        Windows that form the trend.
    wander_sigmas
        Guard against the slopes' own scatter, in robust standard deviations of it.
    """
    depth_mm, z_uT = np.asarray(depth_mm, float), np.asarray(z_uT, float)
    keep = np.isfinite(depth_mm) & np.isfinite(z_uT) & (depth_mm >= start_mm)
    centres, slopes, errors = window_slopes(depth_mm[keep], z_uT[keep], window_mm)
    valid = np.isfinite(slopes)
    centres, slopes, errors = centres[valid], slopes[valid], errors[valid]
    # a change of contact lasts; the tip's stick-slip on a weak build moves one window. So the
    # next window must confirm, and the push-in's last window, which has none, cannot kink alone.
    for i in range(history, slopes.size - 1):
        trend = float(np.median(slopes[i - history:i]))
        wander = _wander(slopes[:i])
        following = (i, i + 1)
        if all(_leaves(slopes[j] - trend, trend, max(sigmas * errors[j], wander_sigmas * wander),
                       tolerance) for j in following) and len({np.sign(slopes[j] - trend) for j in following}) == 1:
            return float(centres[i])
    return float("nan")


def _leaves(deviation: float, trend: float, guard: float, tolerance: float) -> bool:
    """Is a window's slope off the trend by ``tolerance`` of it and by more than ``guard``?"""
    return abs(deviation) > tolerance * abs(trend) and abs(deviation) > guard


def _wander(slopes: np.ndarray) -> float:
    """How much a window's slope (µT/mm) scatters about its neighbours' in smooth tip contact.

    A window's own standard error sees only the noise within it. The tip also sticks and slips
    on the plane as it is pushed in, and z wanders about its smooth course by tens of µT over a
    few mm, more than the noise alone; on a build that reads little per mm of depth that moves
    a window's slope by a large share. The
    scatter of the differences between consecutive slopes measures it from the push-in itself.
    """
    return robust_sigma(np.diff(slopes)) / np.sqrt(2.0) if slopes.size >= 3 else 0.0


def contact_onset_mm(distance_mm: np.ndarray, z_uT: np.ndarray, noise_uT: float,
                     sigmas: float = 5.0) -> float:
    """Where contact began (mm, in ``distance_mm``'s units) from a stepped contact search.

    ``distance_mm`` and ``z_uT`` are the search's steps up to the first one past the threshold
    (the last), ``noise_uT`` the standard error of a step's mean z. A straight line through the
    steps whose |z| stands ``sigmas`` noise above zero (the lower half of their rise, when that
    holds two), extrapolated to z = 0, gives the onset; it is kept between the first and the
    last step. With fewer than two such steps the last step is the estimate.
    """
    distance_mm, magnitude = np.asarray(distance_mm, float), np.abs(np.asarray(z_uT, float))
    touching = magnitude > sigmas * max(float(noise_uT), 0.0)
    # the steps in contact: the run of touching steps that ends at the last one
    start = distance_mm.size
    while start > 0 and touching[start - 1]:
        start -= 1
    last = float(distance_mm[-1])
    # z(depth) is concave (the gain per mm falls with depth): the lower half of the rise keeps
    # the line's extrapolation nearest the onset
    near = np.arange(start, distance_mm.size)
    lower_half = near[magnitude[near] <= 0.5 * magnitude[-1]]
    near = lower_half if lower_half.size >= 2 else near
    if near.size < 2:
        return last
    slope, intercept = np.polyfit(distance_mm[near], magnitude[near], 1)
    if not slope > 0:
        return last
    # a step below the noise guard may already touch (weak builds read a few µT per 0.1 mm),
    # so the onset is only kept within the search
    return float(np.clip(-intercept / slope, distance_mm[0], last))


def monotone_breaks(depths_mm: np.ndarray, median_z_uT: np.ndarray,
                    min_step_uT: float = 0.0) -> np.ndarray:
    """Which trials break the growth of |z| with depth (bool per trial, in the given order).

    Pushing the plane deeper bends a tip contact further, so the median |z| must grow from one
    depth to the next. A trial whose median |z| does not exceed the largest |z| of every shallower
    trial by ``min_step_uT`` has changed its kind of contact (or lost it). Trials without a median
    (NaN) are not judged here.
    """
    order = np.argsort(depths_mm)
    magnitude = np.abs(np.asarray(median_z_uT, float))[order]
    breaks_sorted = np.zeros(magnitude.size, bool)
    deepest_so_far = -np.inf
    for i, value in enumerate(magnitude):
        if not np.isfinite(value):
            continue
        breaks_sorted[i] = value <= deepest_so_far + min_step_uT
        deepest_so_far = max(deepest_so_far, value)
    breaks = np.zeros_like(breaks_sorted)
    breaks[order] = breaks_sorted
    return breaks


def depth_gains(depths_mm: np.ndarray, median_z_uT: np.ndarray) -> np.ndarray:
    """Growth of the median |z| per mm of depth from the previous trial (µT/mm, NaN for the
    shallowest trial and next to trials without a median), in the given order."""
    depths_mm = np.asarray(depths_mm, float)
    magnitude = np.abs(np.asarray(median_z_uT, float))
    order = np.argsort(depths_mm)
    gains_sorted = np.full(depths_mm.size, np.nan)
    gains_sorted[1:] = np.diff(magnitude[order]) / np.diff(depths_mm[order])
    gains = np.empty_like(gains_sorted)
    gains[order] = gains_sorted
    return gains


def stiffening_breaks(depths_mm: np.ndarray, median_z_uT: np.ndarray,
                      tolerance: float = 0.02) -> np.ndarray:
    """Which trials show |z| growing faster with depth than below them (bool per trial).

    A trial is flagged when its gain (µT/mm from the previous trial) exceeds the previous gain by
    more than ``tolerance`` of it; every deeper trial is flagged too (the contact has changed kind
    and stays so). Needs three consecutive trials with a median z; others are not judged.
    """
    depths_mm = np.asarray(depths_mm, float)
    gains = depth_gains(depths_mm, median_z_uT)
    order = np.argsort(depths_mm)
    flagged_sorted = np.zeros(depths_mm.size, bool)
    for i in range(2, order.size):
        previous, current = gains[order[i - 1]], gains[order[i]]
        if np.isfinite(previous) and np.isfinite(current) and previous > 0 \
                and current > previous * (1.0 + tolerance):
            flagged_sorted[i:] = True
            break
    flagged = np.zeros_like(flagged_sorted)
    flagged[order] = flagged_sorted
    return flagged
