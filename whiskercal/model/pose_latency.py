"""The robot's pose latency, estimated from the data alone: the latency that makes the contacts
placed in the world the smoothest.

A contact point does not jump about because the robot moves: when the base moves toward the
surface the tip bends back by as much, and the world point stays on the surface. With the poses
read late (or early) by δ, every change of the base's motion shows in the world points, moved by
the base's velocity times δ until the reading catches up. So the estimate is the latency whose
world points differ least from their own moving average (``window_samples`` samples), searched
on a grid from ``-max_latency_s`` to ``max_latency_s`` and refined by a parabola through the
best point and its neighbours. The caller places the points for a latency (``place``), so that
a mount or any pose interpolation stays its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from whiskercal.model.errors import ModelError


@dataclass(frozen=True)
class LatencyEstimate:
    """The latency (s; a pose stamped t describes the robot at t - latency), the latencies tried
    (s) and the cost of each (mean squared distance of the world points from their moving
    average, mm²)."""

    latency_s: float
    tried_s: np.ndarray
    cost_mm2: np.ndarray


def roughness_mm2(world_mm: np.ndarray, window_samples: int) -> float:
    """Mean squared distance (mm²) of the finite points (n, 2) from their centred moving average
    over ``window_samples`` (within each run of consecutive finite points; a run shorter than
    the window counts nothing)."""
    finite = np.isfinite(world_mm).all(axis=1)
    edges = np.flatnonzero(np.diff(np.r_[0, finite.astype(int), 0]))
    total, count = 0.0, 0
    kernel = np.ones(window_samples) / window_samples
    for start, stop in zip(edges[::2], edges[1::2]):
        if stop - start < window_samples:
            continue
        run = world_mm[start:stop]
        mean = np.column_stack([np.convolve(run[:, k], kernel, mode="valid") for k in range(2)])
        half = window_samples // 2
        residual = run[half:half + len(mean)] - mean
        total += float(np.sum(residual ** 2))
        count += len(residual)
    return total / count if count else math.nan


def estimate_pose_latency(place: Callable[[float], np.ndarray], sample_period_s: float,
                          max_latency_s: float = 0.25, window_samples: int = 15,
                          step_s: float | None = None) -> LatencyEstimate:
    """The latency that makes ``place(latency_s) -> world points (n, 2) mm`` (NaN: no contact)
    the smoothest (module docstring); the grid's step is ``step_s`` (default: half a sample
    period). Raises ModelError for non-positive periods, windows or limits, or when no latency
    leaves a run of contacts as long as the window."""
    if not (sample_period_s > 0 and max_latency_s > 0 and window_samples >= 3):
        raise ModelError("the sample period and the latency limit must be > 0 s and the window "
                         "at least 3 samples")
    step = step_s or sample_period_s / 2
    tried = np.arange(-max_latency_s, max_latency_s + step / 2, step)
    cost = np.array([roughness_mm2(np.asarray(place(float(t)), float), window_samples)
                     for t in tried])
    if not np.isfinite(cost).any():
        raise ModelError(f"no run of {window_samples} consecutive contacts to estimate the pose "
                         "latency from")
    best = int(np.nanargmin(cost))
    return LatencyEstimate(_refined(tried, cost, best), tried, cost)


def _refined(tried: np.ndarray, cost: np.ndarray, best: int) -> float:
    """The parabola's vertex through the best latency and its two neighbours (the best itself at
    the grid's ends or where the three do not bend upward)."""
    if best == 0 or best == len(tried) - 1 or not np.isfinite(cost[best - 1:best + 2]).all():
        return float(tried[best])
    low, mid, high = cost[best - 1:best + 2]
    bend = low - 2 * mid + high
    if bend <= 0:
        return float(tried[best])
    step = tried[1] - tried[0]
    return float(tried[best] + 0.5 * step * (low - high) / bend)
