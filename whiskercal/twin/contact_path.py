"""The whisker's equilibrium as the stage carries a scene along its path.

Equilibria depend on the path, not only on the pose: the plane's stick-slip carries friction
from one pose to the next, and a rod that sweeps in stays on its branch. So the path since the
last request is followed in steps of at most ``max_step_mm``, each solve warm-started from the
previous one. A solver failure keeps the previous equilibrium (and is counted), so one bad step
cannot take the rig down.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from whiskercal.twin.physics.sensor import SensorPhysics
from whiskercal.twin.scenes.base import Scene


def clearance_points_mm(equilibrium) -> np.ndarray:
    """Points along the free whisker, root stub included, densely enough for clearance tests (mm)."""
    shape = np.asarray(equilibrium.shape_mm(400), float)
    return np.vstack([np.linspace([0.0, 0.0], shape[1], 20), shape[1:]])


class ContactPath:
    """The equilibrium along the end effector's path through ``scene`` (call in time order).

    ``tool_at(t)`` is the end effector in the whisker frame at time t (mm);
    ``path_length_mm(t0, t1)`` how far the carriage really travelled between two times, so a
    move out and back between two requests is still followed.
    """

    def __init__(self, scene: Scene, physics: SensorPhysics, tool_at: Callable[[float], np.ndarray],
                 path_length_mm: Callable[[float, float], float], max_step_mm: float) -> None:
        self.scene = scene
        self.physics = physics
        self.max_step_mm = max_step_mm
        self._tool_at = tool_at
        self._path_length_mm = path_length_mm
        self.equilibrium = physics.free()
        self._clearance_mm = clearance_points_mm(self.equilibrium)
        self._time_s = 0.0
        self._tool_mm = tool_at(0.0)
        self.failures = 0  # solves that raised, over the rig's life
        self.last_solve_failed = False  # the last solve since the previous ``at`` raised
        self._slips = 0

    def use_path_length(self, path_length_mm: Callable[[float, float], float]) -> None:
        """Follow another stage's travel from now on (the emulated firmware took over)."""
        self._path_length_mm = path_length_mm

    def at(self, t: float, tool_mm: np.ndarray | None = None):
        """The equilibrium at time ``t`` s (non-decreasing); ``tool_mm``: the end effector at
        ``t`` (whisker frame, mm) when the caller already has it."""
        self.last_solve_failed = False
        tool = self._tool_at(t) if tool_mm is None else tool_mm
        # the stage may have gone somewhere and back since the last call: step along its path
        travel = max(float(np.hypot(*(tool - self._tool_mm))), self._path_length_mm(self._time_s, t))
        if travel < 1e-9 and t >= self._time_s:
            self._time_s = t
            return self.equilibrium
        steps = max(1, math.ceil(travel / self.max_step_mm))
        start_s, previous_tool = self._time_s, self._tool_mm
        for k in range(1, steps + 1):
            step_tool = tool if k == steps else self._tool_at(start_s + (t - start_s) * k / steps)
            self._step(step_tool, previous_tool)
            previous_tool = step_tool
        self._time_s, self._tool_mm = t, tool
        return self.equilibrium

    def take_slips(self) -> int:
        """Stick-slip events since the last call (the plane's; 0 for frictionless scenes)."""
        slips, self._slips = self._slips, 0
        return slips

    def _step(self, tool: np.ndarray, previous_tool: np.ndarray) -> None:
        self.scene.moved(previous_tool, tool)
        if not self.equilibrium.in_contact and not self.scene.touches(self._clearance_mm, tool):
            if getattr(self.equilibrium, "slipped_past", False):
                self.equilibrium = self.physics.free()  # the obstacle has cleared the wire
            return  # nothing touches: no solve (the solver refuses far-off poses)
        try:
            self.equilibrium = self.scene.solve(self.physics, tool, self.equilibrium)
        except Exception:  # noqa: BLE001  (a solver failure must not take the rig down)
            # keep the last equilibrium; the truth record marks these samples "failed"
            self.failures += 1
            self.last_solve_failed = True
            return
        self._slips += self.equilibrium.slips
        self.last_solve_failed = False
