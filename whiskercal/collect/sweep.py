"""The tip sweep: a few rod positions at the whisker's tip itself, taken after the grid.

The grid's rod only ever touches the shaft, short of the tip, so every load it applies is the
shaft contact's (perpendicular to the wire, some way in). On many builds that does not pin the
suspension down: the root's compliance and the map from its pose to the field trade against
each other, and the tip curve comes out millimetres wrong (docs/calibration.md). At the tip the
rod shows the model z where the tip is nearly known (within a rod radius of the rod), and,
where the tip bears on the rod's flank, under a load tilted toward the root.

The positions follow the trace length only: rays from the root at a few directions, the rod's
centre at the trace length plus each configured offset. Each is approached in -y from above,
like a grid point; which contact it makes (the shaft's last millimetres, the tip, or none when
the wire slips past the rod) depends on the build, and the mechanics-informed fit solves the
same approach for whatever it makes.
"""

from __future__ import annotations

import numpy as np

from whiskercal.collect.config import SweepConfig


def sweep_points(sweep: SweepConfig, trace_length_mm: float) -> np.ndarray:
    """Rod centres (n, 2) mm of the tip sweep, whisker frame, in visiting order.

    Ray by ray from ``angle_first_deg`` to ``angle_last_deg``, each ray from its shortest offset
    out (empty when the sweep is off).
    """
    if not sweep.enabled:
        return np.zeros((0, 2))
    angles = np.radians(np.linspace(sweep.angle_first_deg, sweep.angle_last_deg, sweep.angles))
    radii = trace_length_mm + np.sort(np.asarray(sweep.offsets_mm, float))
    return np.array([radius * np.array([np.cos(angle), np.sin(angle)])
                     for angle in angles for radius in radii])
