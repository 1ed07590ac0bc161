"""The forward model: a whisker's suspension parameters -> the root's pose under a rod or a tip load.

Everything the grid can tell apart is nondimensional: the pose under a contact depends on the
bending stiffness EI only through the compliances EI/(L·k_θ) and EI/(L³·k_t), so those (and the
rigid stub) are what is fitted; the field never sees a force. The twin's solvers
(``twin.physics``) do the mechanics; here they only ever get the fitted parameters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.twin.physics import elastica as el
from whiskercal.twin.physics import mechanics, rod_batch
from whiskercal.twin.physics.contacts import base_params
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
        """The elastica's nondimensional parameter vector (no contact set), a fresh copy."""
        return self._params.copy()

    @cached_property
    def _params(self) -> np.ndarray:
        # made once: the tip families and load grids solve thousands of loads per suspension
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


@dataclass(frozen=True)
class RodStates:
    """The rod contacts of a grid solved at once (``rod_poses``): root poses (n, 3) as
    ``pose_of`` gives them, which points are in contact (n,), and each point's solution (its
    contact-kind code (n,), ``rod_batch.NO_START`` where free, and unknowns (n, 4), NaN-padded)
    for warm-starting the next solve."""

    poses: np.ndarray
    in_contact: np.ndarray
    codes: np.ndarray
    states: np.ndarray

    def warm_starts(self, fresh: np.ndarray) -> RodStates:
        """These states with the ``fresh`` points' warm starts dropped (solved from rest)."""
        codes = np.where(fresh, rod_batch.NO_START, self.codes)
        return RodStates(self.poses, self.in_contact, codes, self.states)


def rod_poses(suspension: Suspension, rod_center_mm: np.ndarray, rod_radius_mm: float,
              previous: RodStates | None = None) -> RodStates:
    """The root poses under the touch rod at each centre (n, 2) mm: ``rod_equilibria``'s
    solutions, solved in one compiled loop (``twin.physics.rod_batch``), warm-started where a
    start serves and along the rod's path in from first touch where none does; a centre on the
    rigid stub goes to ``mechanics.solve_rod``, which refuses it."""
    whisker = suspension.whisker()
    centers = np.ascontiguousarray(rod_center_mm, dtype=float)
    n = len(centers)
    codes = np.full(n, rod_batch.NO_START, np.int64) if previous is None else previous.codes.copy()
    states = np.full((n, 4), np.nan) if previous is None else previous.states.copy()
    poses, status = np.zeros((n, 3)), np.zeros(n, np.int64)
    base, k = base_params(whisker), 0
    while k < n:
        k = rod_batch.run_rods(base, centers, float(rod_radius_mm), 1, whisker.length_mm,
                               whisker.root_offset_mm, k, previous is None, codes, states,
                               poses, status)
        if k < n:
            _solve_from_rest(whisker, centers[k], rod_radius_mm, k, codes, states, poses, status)
            k += 1
    return RodStates(poses, status == rod_batch.SOLVED, codes, states)


def _solve_from_rest(whisker, center, rod_radius_mm, k, codes, states, poses, status) -> None:
    """Point ``k``, which ``rod_batch.run_rods`` leaves (a centre on the rigid stub, refused
    there with the reason), solved by ``mechanics.solve_rod`` from first touch and stored as
    ``run_rods`` stores its own."""
    equilibrium = mechanics.solve_rod(whisker, center, rod_radius_mm)
    poses[k] = pose_of(equilibrium)
    states[k] = np.nan
    if equilibrium.in_contact:
        code, z = equilibrium.solution[0], equilibrium.solution[1]
        codes[k], states[k, :len(z)], status[k] = code, z, rod_batch.SOLVED
    else:
        codes[k], status[k] = rod_batch.NO_START, rod_batch.FREE


def tip_load(suspension: Suspension, force: np.ndarray, moment_guess: float
             ) -> tuple[np.ndarray, np.ndarray, float] | None:
    """Pose (3,), tip (2,) mm and the root moment for a force (F_x, F_y) in EI/L² on the tip.

    Returns None when Newton does not converge from ``moment_guess`` (nondimensional).
    """
    solved = tip_load_and_angle(suspension, force, moment_guess)
    return None if solved is None else solved[:3]


def tip_load_and_angle(suspension: Suspension, force: np.ndarray, moment_guess: float
                       ) -> tuple[np.ndarray, np.ndarray, float, float] | None:
    """``tip_load`` and the direction of the wire at its tip (rad), from the one end state
    both come from."""
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
    return pose, np.array([tip_x, tip_y]) * length, float(z[0]), float(th)
