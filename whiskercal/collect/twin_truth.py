"""Ground truth from the digital twin, for the /truth group of a raw dataset.

Only a simulated sensor port carries the world (``port.world``); on a real rig there is no
truth and :func:`twin_truth` returns None. The world records the truth of every sample its
sensor board converts (``world.truth``, twin/world.py); a point's truth is taken from the
samples converted while the point was being averaged (the stage stands still then, so they
all describe one equilibrium): the middle one's state and their mean noise-free z.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

# Fields of the world's truth record that map one-to-one onto TRUTH_FIELDS.
_SAME = {"stage_mm": "stage_mm", "tool_mm": "rod_center_mm", "contact_mm": "contact_mm",
         "tip_mm": "tip_mm", "root_rotation_rad": "root_rotation_rad"}


def truth_over_window(record: dict[str, np.ndarray], t_start_s: float, t_end_s: float) -> dict[str, Any]:
    """A point's truth from the world's per-sample record between two simulated times (s).

    Falls back to the latest converted sample when none lies in the window.
    """
    t_s = record["t_s"]
    inside = np.flatnonzero((t_s >= t_start_s) & (t_s <= t_end_s))
    if len(inside) == 0:
        if len(t_s) == 0:
            return {}
        inside = np.array([len(t_s) - 1])
    middle = inside[len(inside) // 2]
    fields: dict[str, Any] = {ours: np.asarray(record[theirs][middle], float)
                              for theirs, ours in _SAME.items() if theirs in record}
    fields["z_uT"] = float(np.mean(record["z_true_uT"][inside]))
    fields["kind"] = str(record["kind"][middle])
    return fields


def twin_truth(port, window_s: float) -> Callable[[], dict[str, Any]] | None:
    """A callable giving the twin's truth for the samples just averaged, or None on a real rig.

    ``window_s`` is how long (s) averaging one point takes, counted back from the world's now.
    """
    world = getattr(port, "world", None)
    if world is None or not hasattr(world, "truth") or not hasattr(world, "now_s"):
        return None

    def truth_now() -> dict[str, Any]:
        with world.lock:
            now_s = float(world.now_s)
            record = world.truth.arrays()
        return truth_over_window(record, now_s - window_s, now_s)

    return truth_now
