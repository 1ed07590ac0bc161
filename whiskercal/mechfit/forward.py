"""The forward model: a whisker's suspension parameters -> the root's pose under a rod or a tip load.

Everything the grid can tell apart is nondimensional: the pose under a contact depends on the
bending stiffness EI only through the compliances EI/(L·k_θ) and EI/(L³·k_t), so those (and the
rigid stub) are what is fitted; the field never sees a force. The twin's solvers
(``twin.physics``) do the mechanics; here they only ever get the fitted parameters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.twin.physics import elastica as el
from whiskercal.twin.physics import mechanics
from whiskercal.twin.physics.whisker import NITINOL_AUSTENITE_N_PER_MM2, Equilibrium, WhiskerParams

# Any EI gives the same poses for the same compliances; this one (a 0.25 mm nitinol wire) only
# makes the WhiskerParams the twin's solvers take.
NOMINAL_DIAMETER_MM = 0.25
TIP_TOLERANCE = 1e-11      # nondimensional moment residual of a tip-load solve
TIP_MAX_ITER = 40


@dataclass(frozen=True)
class Suspension:
    """A whisker's mechanics as the grid sees it.

    Attributes
    ----------
    trace_length_mm : float
        Arc length from the centre of rotation to the tip (stub plus wire), known from the build.
    stub_mm : float
        Rigid stub from the centre of rotation to the clamp.
    rot_compliance : float
        EI/(L·k_θ): 1 / (k_θ·L/EI), how much a push turns the root against bending the wire.
    trans_compliance : float
        EI/(L³·k_t): how far (in L) the root shifts under a force of EI/L².
    """

    trace_length_mm: float
    stub_mm: float
    rot_compliance: float
    trans_compliance: float

    def __post_init__(self) -> None:
        values = (self.trace_length_mm, self.stub_mm, self.rot_compliance, self.trans_compliance)
        if not all(math.isfinite(v) for v in values) or min(values[2:]) <= 0:
            raise UsageError(f"suspension parameters must be finite and positive, got {values}.")
        if not 0.0 <= self.stub_mm < 0.5 * self.trace_length_mm:
            raise UsageError(f"the stub ({self.stub_mm:g} mm) must lie in [0, half the trace "
                             f"length ({self.trace_length_mm:g} mm)).")

    @property
    def length_mm(self) -> float:
        """Free wire length L (mm)."""
        return self.trace_length_mm - self.stub_mm

    def whisker(self) -> WhiskerParams:
        """A WhiskerParams with these compliances (its EI is nominal; poses do not depend on it)."""
        length = self.length_mm
        probe = WhiskerParams(length_mm=length, diameter_mm=NOMINAL_DIAMETER_MM)
        ei = probe.bending_stiffness_n_mm2
        return WhiskerParams(
            length_mm=length, diameter_mm=NOMINAL_DIAMETER_MM,
            youngs_modulus_n_per_mm2=NITINOL_AUSTENITE_N_PER_MM2, root_offset_mm=self.stub_mm,
            root_rotational_stiffness_n_mm_per_rad=ei / (length * self.rot_compliance),
            root_translational_stiffness_n_per_mm=ei / (length ** 3 * self.trans_compliance))

    def params(self) -> np.ndarray:
        """The elastica's nondimensional parameter vector (no contact set)."""
        p = el.new_params()
        p[el.P_STUB] = self.stub_mm / self.length_mm
        p[el.P_CROT] = self.rot_compliance
        p[el.P_CTRANS] = self.trans_compliance
        return p


def pose_of(equilibrium: Equilibrium) -> np.ndarray:
    """(root rotation rad, shift x mm, shift y mm) of one equilibrium."""
    return np.array([equilibrium.root_rotation_rad, *equilibrium.root_shift_mm])


def rod_equilibria(suspension: Suspension, rod_center_mm: np.ndarray, rod_radius_mm: float,
                   previous: list[Equilibrium | None] | None = None) -> list[Equilibrium]:
    """Equilibria under the touch rod at each centre (n, 2) mm, coming from +y.

    ``previous`` (one per point) warm-starts each solve from a nearby suspension's solution;
    without it each column (same x) is followed down from the free whisker, as the stage does.
    """
    whisker = suspension.whisker()
    out, last, column = [], None, None
    for k, center in enumerate(np.asarray(rod_center_mm, float)):
        if previous is not None:
            start = previous[k]
        else:
            if center[0] != column:
                last, column = None, center[0]
            start = last
        equilibrium = mechanics.solve_rod(whisker, center, rod_radius_mm, previous=start)
        out.append(equilibrium)
        last = equilibrium if equilibrium.in_contact else None
    return out


def tip_load(suspension: Suspension, force: np.ndarray, moment_guess: float
             ) -> tuple[np.ndarray, np.ndarray, float] | None:
    """Pose (3,), tip (2,) mm and the root moment for a force (F_x, F_y) in EI/L² on the tip.

    Returns None when Newton does not converge from ``moment_guess`` (nondimensional).
    """
    p = suspension.params()
    p[el.P_FX], p[el.P_FY] = force
    z, converged, _ = el.newton(el.CANTILEVER, np.array([moment_guess]), p, el.DEFAULT_STEPS,
                                TIP_TOLERANCE, TIP_MAX_ITER)
    if not converged or not np.isfinite(z[0]):
        return None
    length = suspension.length_mm
    _, _, th, tip_x, tip_y = el.end_state(el.CANTILEVER, z, p, el.DEFAULT_STEPS)
    pose = np.array([p[el.P_CROT] * z[0], p[el.P_CTRANS] * force[0] * length,
                     p[el.P_CTRANS] * force[1] * length])
    return pose, np.array([tip_x, tip_y]) * length, float(z[0])


def tip_tangent_angle(suspension: Suspension, force: np.ndarray, moment: float) -> float:
    """Direction of the wire at its tip (rad) for a solved tip load."""
    p = suspension.params()
    p[el.P_FX], p[el.P_FY] = force
    return float(el.end_state(el.CANTILEVER, np.array([moment]), p, el.DEFAULT_STEPS)[2])
