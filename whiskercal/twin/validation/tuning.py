"""The sweep behind the mechanics' defaults: the study's plane at each depth, without history.

docs/twin.md ("Mechanics") tabulates this for several root stiffnesses; `whiskercal twin
plane-study` prints it for any whisker and plane settings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.twin.physics.plane import solve_plane
from whiskercal.twin.physics.obstacles import plane_for_depth
from whiskercal.twin.physics.whisker import WhiskerParams


@dataclass(frozen=True)
class DepthResult:
    """The equilibrium against the study's plane at one contact distance."""

    depth_mm: float
    kind: str
    tip_mm: tuple[float, float]
    root_rotation_deg: float
    root_shift_mm: float
    force_mn: float


def study_sweep(whisker: WhiskerParams, depths_mm, **plane_options) -> list[DepthResult]:
    """Solve the study's plane at each depth (history-free: steady kinetic sliding).

    Parameters
    ----------
    whisker : WhiskerParams
    depths_mm : iterable of float
        Contact distances past the undeflected tip, along the plane's normal.
    **plane_options
        tilt_rad, mu_static, mu_kinetic, motion_sign for `plane_for_depth`.
    """
    results = []
    for depth in depths_mm:
        eq = solve_plane(whisker, plane_for_depth(whisker, float(depth), **plane_options))
        results.append(DepthResult(
            float(depth), eq.kind, (float(eq.tip_mm[0]), float(eq.tip_mm[1])),
            math.degrees(eq.root_rotation_rad), float(np.linalg.norm(eq.root_shift_mm)),
            1e3 * float(np.linalg.norm(eq.force_n))))
    return results


def tangential_onset_mm(results: list[DepthResult]) -> float:
    """The first depth in a sweep with tangential contact (NaN when there is none)."""
    return next((r.depth_mm for r in results if r.kind == "tangential"), math.nan)
