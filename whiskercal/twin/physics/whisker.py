"""The whisker's physical parameters and the result of a static solve (`Equilibrium`).

The whisker frame has its origin at the suspension's centre of rotation, x along the undeflected
whisker, y to its left. A rigid stub of length `root_offset_mm` joins the centre of rotation to
the wire's clamp; the wire (an inextensible elastica of length `length_mm`) starts there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from whiskercal.errors import UsageError

# Superelastic nitinol in its austenite phase: 70-83 GPa in suppliers' data sheets. The wire's
# peak bending strain stays near 0.3-0.5 % in the study and the calibration, under the ~1 % where
# the stress-induced transformation starts, so the linear austenite modulus applies.
NITINOL_AUSTENITE_N_PER_MM2 = 75_000.0

EQUILIBRIUM_KINDS = ("free", "shaft", "tip", "tangential")


def _require_positive(name: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise UsageError(f"{name} must be a positive finite number, got {value!r}.")


@dataclass(frozen=True)
class WhiskerParams:
    """A nitinol whisker on a compliant root suspension (planar, quasi-static).

    Attributes
    ----------
    length_mm : float
        Free wire length L beyond the clamp.
    diameter_mm : float
        Wire diameter d.
    youngs_modulus_n_per_mm2 : float
        Young's modulus E of the wire.
    root_offset_mm : float
        Rigid stub from the suspension's centre of rotation to the clamp, along x.
    root_rotational_stiffness_n_mm_per_rad : float
        Suspension stiffness against rotation about its centre.
    root_translational_stiffness_n_per_mm : float
        Suspension stiffness against a shift of its centre (same in x and y).

    Docs/twin.md ("Mechanics") says how the defaults were chosen.
    """

    length_mm: float = 75.0
    diameter_mm: float = 0.25
    youngs_modulus_n_per_mm2: float = NITINOL_AUSTENITE_N_PER_MM2
    root_offset_mm: float = 3.0
    root_rotational_stiffness_n_mm_per_rad: float = 3.0
    root_translational_stiffness_n_per_mm: float = 0.05

    def __post_init__(self) -> None:
        for name in ("length_mm", "diameter_mm", "youngs_modulus_n_per_mm2",
                     "root_rotational_stiffness_n_mm_per_rad",
                     "root_translational_stiffness_n_per_mm"):
            _require_positive(name, getattr(self, name))
        offset = self.root_offset_mm
        if not (isinstance(offset, (int, float)) and math.isfinite(offset) and offset >= 0):
            raise UsageError(f"root_offset_mm must be a finite number >= 0, got {offset!r}.")

    @property
    def bending_stiffness_n_mm2(self) -> float:
        """EI = E·π·d⁴/64 (N·mm²)."""
        return self.youngs_modulus_n_per_mm2 * math.pi * self.diameter_mm ** 4 / 64.0

    @property
    def reach_mm(self) -> float:
        """Distance from the centre of rotation to the undeflected tip (mm)."""
        return self.root_offset_mm + self.length_mm

    @property
    def force_scale_n(self) -> float:
        """EI/L² (N): the natural force unit of the elastica."""
        return self.bending_stiffness_n_mm2 / self.length_mm ** 2


@dataclass(frozen=True)
class Equilibrium:
    """A static equilibrium of the whisker (whisker frame, mm, N, rad).

    Attributes
    ----------
    kind : str
        ``"free"``, ``"shaft"`` (point contact before the tip), ``"tip"`` or ``"tangential"``
        (the shaft lies along a flat surface from `contact_arc_mm` to the tip).
    root_rotation_rad : float
        Rotation of the suspension (negative when pushed toward -y).
    root_shift_mm : ndarray, shape (2,)
        Shift of the suspension's centre of rotation.
    contact_mm : ndarray, shape (2,)
        The contact point on the whisker (NaN when free); for tangential contact, where the
        shaft first meets the surface.
    contact_arc_mm : float
        Arc length of the contact along the wire from the clamp (NaN when free).
    force_n : ndarray, shape (2,)
        Contact force acting on the whisker.
    tip_mm : ndarray, shape (2,)
        The wire's tip.
    sliding : bool
        True when the contact is sliding now, on the kinetic edge of the friction cone
        (tangential contact, the history-free approach, or a plane with mu_s = mu_k).
    slips : int
        Stick-slip contacts (the plane; an object with `physics.shape_friction`): slip events
        since the previous state (the tip broke loose at mu_s, slid and stuck again); the state
        itself sticks.
    whisker : WhiskerParams
        The whisker this equilibrium belongs to.
    anchor_mm : float
        Plane contacts only: where the tip sticks, as a coordinate along the plane's surface in
        the plane's own (moving) frame; carries stick-slip from one solve to the next.
    slipped_past : bool
        Free because the wire slipped past an obstacle that still stands where the undeflected
        wire would be (it would now touch it from the other side, which a one-sided contact
        does not model). Solves from such a state stay free until the obstacle clears the wire.
    """

    kind: str
    root_rotation_rad: float
    root_shift_mm: np.ndarray
    contact_mm: np.ndarray
    contact_arc_mm: float
    force_n: np.ndarray
    tip_mm: np.ndarray
    whisker: WhiskerParams = field(repr=False)
    sliding: bool = False
    anchor_mm: float = math.nan
    slipped_past: bool = False
    slips: int = 0
    # Nondimensional unknowns of the solve and its contact-kind code, for warm starts.
    solution: tuple = field(default=(), repr=False, compare=False)
    # Plane contacts that stuck: how the unknowns changed over the last step (a predictor that
    # saves the next stuck solve one Newton iteration).
    stuck_step: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def in_contact(self) -> bool:
        """True unless the whisker is free."""
        return self.kind != "free"

    def shape_mm(self, n: int = 101) -> np.ndarray:
        """Points along the whisker from the centre of rotation to the tip, shape (n + 1, 2).

        The first point is the (shifted) centre of rotation, the second the clamp, the rest
        `n - 1` points evenly spaced in arc length along the wire.
        """
        from whiskercal.twin.physics.elastica import shape_of

        return shape_of(self, n)
