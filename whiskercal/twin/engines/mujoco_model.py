"""MJCF models of the whisker for the MuJoCo cross-check engine.

The whisker is built in scaled units so that every model is well conditioned whatever the
whisker: lengths in units of the shaft length L, forces in units of EI/L² (EI the bending
stiffness), hence moments in EI/L and stiffnesses dimensionless. Masses and time are free in a
static problem; they are chosen per representation so that the model settles in few steps
(see :func:`settle_settings`).

Two representations of the same discretization (N segments of length l = L/N, bending
concentrated at the vertices, the root vertex carrying the compliance of half a segment):

- ``"chain"``: N rigid bodies joined by hinges about z whose stiffness is EI/l (2·EI/l at the
  root, whose hinge stands for the first half segment only). Exactly inextensible; joint
  stiffness and damping are integrated implicitly, so an overdamped model settles in a few
  steps.
- ``"flex"``: a 1-D ``flexcomp`` (MuJoCo's discrete elastic rod, bending stiffness
  EI/(l0 + l1) per interior vertex), planar vertices (``dof="2d"``), inextensibility by edge
  equality constraints. Those constraints are soft: the edges stretch in proportion to the
  axial force times timestep²/mass, so an accurate flex needs heavy vertices and many small
  steps. A short ghost edge (1e-4·l) behind the root is clamped with the root so that the
  root vertex bends, with stiffness 2·EI/((1 + 1e-4)·l); with a 1 % ghost edge that missing
  compliance alone cost 2e-3 mm of tip error at 80 segments.

The root suspension is a body at the centre of rotation with slide joints along x and y
(stiffness k_lin) and a hinge about z (stiffness k_theta); the wire is clamped at
``root_offset_mm`` along x from that centre. Frames follow docs/architecture.md: the whisker
frame is MuJoCo's world frame, x along the undeflected whisker, y to its left, z out of plane.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.errors import UsageError

REPRESENTATIONS = ("chain", "flex")

# Ghost edge behind the root, as a fraction of a segment: short enough that the root vertex
# has almost the stiffness of half a segment; it is clamped, so it adds no stiff dof.
_GHOST_FRACTION = 0.0001


@dataclass(frozen=True)
class RodSpec:
    """The whisker as the MuJoCo engine sees it: `WhiskerParams`' fields, plus rigid roots.

    Parameters
    ----------
    length_mm, diameter_mm : float
        Shaft length and wire diameter (mm).
    youngs_modulus_n_per_mm2 : float
        Young's modulus of the wire (N/mm², i.e. MPa).
    root_offset_mm : float
        Distance from the suspension's centre of rotation to the clamped end of the wire, along
        the undeflected axis (mm).
    root_rotational_stiffness_n_mm_per_rad : float or None
        Hinge stiffness of the suspension (N·mm/rad); None clamps the root rigidly.
    root_translational_stiffness_n_per_mm : float or None
        Translational stiffness of the suspension along x and y (N/mm); None forbids translation.
    """

    length_mm: float
    diameter_mm: float
    youngs_modulus_n_per_mm2: float
    root_offset_mm: float = 0.0
    root_rotational_stiffness_n_mm_per_rad: float | None = None
    root_translational_stiffness_n_per_mm: float | None = None

    def __post_init__(self) -> None:
        for name in ("length_mm", "diameter_mm", "youngs_modulus_n_per_mm2"):
            if not getattr(self, name) > 0:
                raise UsageError(f"RodSpec.{name} must be positive, got {getattr(self, name)}.")

    @property
    def bending_stiffness_n_mm2(self) -> float:
        """EI = E·π·d⁴/64 (N·mm²)."""
        return self.youngs_modulus_n_per_mm2 * math.pi * self.diameter_mm**4 / 64.0

    @property
    def force_scale_n(self) -> float:
        """The scaled model's unit of force, EI/L² (N)."""
        return self.bending_stiffness_n_mm2 / self.length_mm**2

    @classmethod
    def from_whisker(cls, whisker) -> RodSpec:
        """The RodSpec of a `whiskercal.twin.physics.whisker.WhiskerParams` (same names and units)."""
        return cls(whisker.length_mm, whisker.diameter_mm, whisker.youngs_modulus_n_per_mm2,
                   whisker.root_offset_mm, whisker.root_rotational_stiffness_n_mm_per_rad,
                   whisker.root_translational_stiffness_n_per_mm)

    def clamped(self) -> RodSpec:
        """The same wire with a rigid root at the centre of rotation (the textbook cantilever)."""
        return RodSpec(self.length_mm, self.diameter_mm, self.youngs_modulus_n_per_mm2)


@dataclass(frozen=True)
class SettleSettings:
    """Pseudo-dynamics used to reach the static equilibrium (all in scaled units)."""

    timestep: float
    total_mass: float
    damping_time: float
    max_steps: int
    step_tolerance: float
    load_softening: float

    def timestep_for(self, load_sensitivity: float) -> float:
        """Timestep for a load whose moments change by ``load_sensitivity`` (scaled) per radian.

        The dead load is explicit in the integrator, so its geometric stiffness must stay small
        against the implicit elastic and damping terms over one step; a step of
        ``timestep / (1 + load_softening·sensitivity)`` keeps the settling monotone.
        """
        return self.timestep / (1.0 + self.load_softening * load_sensitivity)


def settle_settings(representation: str, segments: int = 40) -> SettleSettings:
    """Masses, damping and timestep that settle a representation quickly to statics.

    Parameters
    ----------
    representation : {"chain", "flex"}
    segments : int
        Resolution; the flex's mass grows with it to hold the edge stretch constant.

    Returns
    -------
    SettleSettings
        For the chain: nearly massless bodies, overdamped (damping time 0.1), a timestep of
        twice the damping time divided by (1 + load sensitivity): a full step without load,
        shorter as the explicit dead load's geometric stiffness grows (at alpha = 10 a step ten
        times the damping time made the chain wander without settling).
        For the flex: a 0.01 timestep and a total mass of (N/40)², because the edge constraints
        stretch by about 0.075·T·dt²/M·(N/40)² (T the axial force; a scaling read off the
        flex's settled stretch), which holds the stretch near 8e-6·T at every N.
        A heavier flex settles more slowly (its lowest mode scales as 1/√M).
    """
    if representation == "chain":
        return SettleSettings(timestep=0.2, total_mass=1e-3, damping_time=0.1,
                              max_steps=5000, step_tolerance=1e-11, load_softening=1.0)
    if representation == "flex":
        return SettleSettings(timestep=0.01, total_mass=(segments / 40.0) ** 2, damping_time=0.6,
                              max_steps=20000, step_tolerance=1e-9, load_softening=0.0)
    raise UsageError(f"unknown MuJoCo representation {representation!r}; "
                     f"use one of {REPRESENTATIONS}.")


def build_mjcf(spec: RodSpec, segments: int, representation: str = "chain",
               rod_radius_mm: float | None = None) -> str:
    """MJCF text of the whisker on its root, in scaled units.

    Parameters
    ----------
    spec : RodSpec
    segments : int
        Number of segments N along the shaft (at least 2).
    representation : {"chain", "flex"}
    rod_radius_mm : float, optional
        Add a touch rod (a cylinder along z, the geom ``rod``, placed at run time) that the
        chain meets through MuJoCo's contact: the segments carry capsules of the wire's radius
        and the cylinder is thinner by that radius, so that contact happens where the wire's
        centreline meets the rod, as in the quasi-static engine. Chain only.

    Returns
    -------
    str
        A complete ``<mujoco>`` document; the wire's bodies are named ``seg0``..``seg{N-1}``
        (chain) or the flexcomp ``wire`` (flex), the suspension body ``suspension``.
    """
    if segments < 2:
        raise UsageError(f"the whisker needs at least 2 segments, got {segments}.")
    settings = settle_settings(representation, segments)
    offset = spec.root_offset_mm / spec.length_mm
    contact = rod_radius_mm is not None
    if contact and (representation != "chain" or not rod_radius_mm > 0.5 * spec.diameter_mm):
        raise UsageError("a touch rod needs the chain representation and a radius larger "
                         "than the wire's.")
    if representation == "chain":
        capsule = 0.5 * spec.diameter_mm / spec.length_mm if contact else None
        wire = _chain_body(segments, 0, settings, offset, capsule)
    else:
        wire = _flexcomp(spec, segments, settings, offset)
    root = _suspension(spec, settings, wire)
    rod = _rod_geom(spec, rod_radius_mm) if contact else ""
    # Soft constraints (flex edges, rod contact) get time constants far below the timestep,
    # which MuJoCo's `refsafe` would otherwise raise to two timesteps.
    flags = ('contact="disable"' if not contact else "") + (
        ' refsafe="disable"' if representation == "flex" or contact else "")
    return (
        '<mujoco model="whisker">\n'
        f'  <option timestep="{settings.timestep}" integrator="discrete" solver="Newton" '
        f'gravity="0 0 0" iterations="100" tolerance="1e-12"><flag {flags}/></option>\n'
        f"  <worldbody>\n{rod}{root}\n  </worldbody>\n</mujoco>\n"
    )


def _rod_geom(spec: RodSpec, rod_radius_mm: float) -> str:
    """The touch rod, parked far from the whisker until a solve places it."""
    radius = (rod_radius_mm - 0.5 * spec.diameter_mm) / spec.length_mm
    return (f'    <geom name="rod" type="cylinder" pos="0 10 0" size="{radius:.12g} 0.05" '
            f'contype="0" conaffinity="1" {_CONTACT}/>\n')


# Frictionless (condim 1), stiff contact: penetration about 3e-3 mm at the rod's forces.
_CONTACT = 'condim="1" solref="1e-4 1" solimp="0.9999 0.9999 0.001"'


def _suspension(spec: RodSpec, settings: SettleSettings, wire: str) -> str:
    """The suspension body around the wire: slides and hinge when the root is compliant."""
    joints = []
    length, ei = spec.length_mm, spec.bending_stiffness_n_mm2
    if spec.root_translational_stiffness_n_per_mm is not None:
        k_lin = spec.root_translational_stiffness_n_per_mm * length**3 / ei
        for name, axis in (("root_x", "1 0 0"), ("root_y", "0 1 0")):
            joints.append(_joint(name, "slide", axis, k_lin, settings))
    if spec.root_rotational_stiffness_n_mm_per_rad is not None:
        k_theta = spec.root_rotational_stiffness_n_mm_per_rad * length / ei
        joints.append(_joint("root_theta", "hinge", "0 0 1", k_theta, settings))
    # The suspension's own mass is small next to the wire's: it only has to keep the
    # pseudo-dynamics regular.
    mass = 0.01 * settings.total_mass
    inertial = (f'<inertial pos="0 0 0" mass="{mass:.6g}" '
                f'diaginertia="{mass:.6g} {mass:.6g} {mass:.6g}"/>')
    return f'    <body name="suspension">{"".join(joints)}{inertial}\n{wire}\n    </body>'


def _joint(name: str, kind: str, axis: str, stiffness: float, settings: SettleSettings) -> str:
    damping = settings.damping_time * stiffness
    return (f'<joint name="{name}" type="{kind}" axis="{axis}" stiffness="{stiffness:.12g}" '
            f'damping="{damping:.12g}"/>')


def _chain_body(segments: int, index: int, settings: SettleSettings, offset: float,
                capsule_radius: float | None = None) -> str:
    """Segment ``index`` and, nested inside it, the rest of the chain."""
    seg = 1.0 / segments
    # The root hinge stands for the first half segment only, so it is twice as stiff.
    stiffness = (2.0 if index == 0 else 1.0) / seg
    pos = f"{offset:.12g} 0 0" if index == 0 else f"{seg:.12g} 0 0"
    mass = settings.total_mass / segments
    inner = (_chain_body(segments, index + 1, settings, offset, capsule_radius)
             if index + 1 < segments else "")
    geom = "" if capsule_radius is None else (
        f'<geom type="capsule" fromto="0 0 0 {seg:.12g} 0 0" size="{capsule_radius:.12g}" '
        f'contype="1" conaffinity="0" mass="0" {_CONTACT}/>')
    # Point masses at the segment ends lump the wire's mass at the vertices, like the flex.
    tiny = 1e-6 * mass * seg**2
    return (
        f'<body name="seg{index}" pos="{pos}">'
        f'{_joint(f"bend{index}", "hinge", "0 0 1", stiffness, settings)}'
        f'<inertial pos="{seg:.12g} 0 0" mass="{mass:.6g}" '
        f'diaginertia="{tiny:.3g} {tiny:.3g} {tiny:.3g}"/>'
        f"{geom}{inner}</body>"
    )


def _flexcomp(spec: RodSpec, segments: int, settings: SettleSettings, offset: float) -> str:
    """The wire as a planar 1-D flexcomp clamped (ghost edge + root vertex) to the suspension."""
    seg = 1.0 / segments
    xs = np.concatenate([[-_GHOST_FRACTION * seg], np.linspace(0.0, 1.0, segments + 1)]) + offset
    points = " ".join(f"{x:.12g} 0 0" for x in xs)
    elements = " ".join(f"{i} {i + 1}" for i in range(segments + 1))
    radius = 0.5 * spec.diameter_mm / spec.length_mm
    # EI = E·π·r⁴/4 = 1 in scaled units fixes the flex's Young's modulus.
    young = 4.0 / (math.pi * radius**4)
    return (
        f'      <flexcomp name="wire" type="direct" dim="1" dof="2d" point="{points}" '
        f'element="{elements}" radius="{radius:.12g}" mass="{settings.total_mass:.6g}">'
        '<edge equality="true" solref="1e-4 1" solimp="0.9999 0.9999 0.001"/>'
        f'<elasticity young="{young:.12g}" poisson="0.3" damping="{settings.damping_time}"/>'
        '<pin id="0 1"/></flexcomp>'
    )
