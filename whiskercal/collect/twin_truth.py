"""Ground truth from the digital twin, for the /truth group of a raw dataset.

Only a simulated sensor port carries the world (``port.world``); on a real rig there is no
truth and :func:`twin_truth` returns None. The world records the truth of every sample its
sensor board converts (``world.truth``); a point's truth is taken from the samples converted
between the board times of the point's first and last averaged sample (the stage stands still
then, so they all describe one equilibrium): the middle one's state and their mean noise-free z.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

# The board stamps whole µs: a sample's time may differ from its truth row's by up to half this.
_BOARD_TICK_S = 1e-6
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


def twin_truth(port) -> Callable[[float, float], dict[str, Any]] | None:
    """A callable giving the twin's truth over the board times (s) of a point's first and last
    averaged sample, or None on a real rig.

    The twin's board stamps each sample with the simulated time of its conversion, so the
    samples' own times find their truth rows, however late the host read them.
    """
    world = getattr(port, "world", None)
    if world is None or not hasattr(world, "truth") or not hasattr(world, "lock"):
        return None

    def truth_over(t_start_s: float, t_end_s: float) -> dict[str, Any]:
        with world.lock:
            record = world.truth.arrays()
        return truth_over_window(record, t_start_s - _BOARD_TICK_S, t_end_s + _BOARD_TICK_S)

    return truth_over
