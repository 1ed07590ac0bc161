"""The whisker's first bending modes, damped, on top of its quasi-static shape.

The statics (``elastica``, ``contacts``) give the pose of the suspension the wire would rest in
at each moment. A real nitinol wire does not jump there: after a slip or a release it rings, and
while it slides it lags. This module models that with the lowest bending modes of the wire on its
suspension, each a damped second-order response driven by the quasi-static solution.

**Modes.** Euler-Bernoulli beam finite elements (Hermite cubics) of the wire, EI from the build,
linear density ρ·π·d²/4 (nitinol, 6450 kg/m³), clamped through the rigid stub to the
suspension, which turns on k_θ and shifts sideways on k_t. The suspension itself is massless:
a 2 mm magnet a few mm from the axis adds a negligible inertia beside the wire's, and the PLA
arms' mass is not known. The generalized eigenproblem K·v = ω²·M·v gives the frequencies and
shapes.
These are the free wire's modes; in contact the obstacle constrains the wire and raises them, so
the free modes give the longest ring-down and the largest lag (the safe side for a settle time).

**Response.** The sensor reads the suspension's pose: its rotation and its sideways (y) shift.
Each mode i holds a share a_i of the static response of each (the mode's part of the static
deflection under a point load at ``load_arc_mm``, by default the tip: K⁻¹·f = Σ φ_i·φ_iᵀ·f/ω_i²).
Mode i's coordinate y_i follows the quasi-static value r_s through
ÿ_i + 2ζω_i·ẏ_i + ω_i²·y_i = ω_i²·r_s, and the pose read is r_s + Σ a_i·(y_i − r_s): the modes
left out respond quasi-statically (the mode-acceleration method), so with every share at its
static value nothing lags. Between two readings r_s is taken as linear in time and the response
is propagated exactly, so a step (a release, a slip) rings down as exp(−ζω_i·t) and a steady
slide lags by 2ζ·v/ω_i only. The axial shift stays quasi-static (the axial mode is far higher).
The static shapes come from the nonlinear elastica; only the shares and frequencies are linear.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh, expm

from whiskercal.twin.physics.whisker import WhiskerParams

# Nitinol's density (suppliers' data sheets give 6450-6500 kg/m³), in tonnes per mm³: with mm,
# N and s, mass is in tonnes (1 N = 1 t·mm/s²).
NITINOL_DENSITY_KG_M3 = 6450.0
# Assumed: the nitinol wire and the spiral PLA arms damp little; the same ζ the plane's slip
# rebound is derived from (docs/twin.md, "Plane with friction"); no damping was measured.
DEFAULT_DAMPING_RATIO = 0.03
ELEMENTS = 40
ROOT_DOFS = 2  # the suspension's sideways shift and rotation


@dataclass(frozen=True)
class Mode:
    """One bending mode: frequency (Hz), damping ratio, and its share of the static root
    rotation and of the static sideways root shift (fractions)."""

    frequency_hz: float
    damping_ratio: float
    rotation_share: float
    shift_share: float

    @property
    def omega_rad_s(self) -> float:
        """The undamped angular frequency ω (rad/s)."""
        return 2.0 * math.pi * self.frequency_hz

    @property
    def decay_per_s(self) -> float:
        """ζ·ω (1/s): the envelope decays as exp(−ζω·t)."""
        return self.damping_ratio * self.omega_rad_s


def _element_matrices(ei: float, mu: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and consistent mass of one Hermite beam element (w, w', w, w')."""
    k = ei / h ** 3 * np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                                [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
    m = mu * h / 420.0 * np.array([[156, 22 * h, 54, -13 * h], [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                                   [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
    return k, m


def system_matrices(whisker: WhiskerParams, density_kg_m3: float = NITINOL_DENSITY_KG_M3,
                    elements: int = ELEMENTS) -> tuple[np.ndarray, np.ndarray]:
    """K (N/mm) and M (t) over (root shift, root rotation, then w and w' at each wire node but
    the clamp), the clamp's deflection and slope carried by the rigid stub."""
    mu = density_kg_m3 * 1e-12 * math.pi * whisker.diameter_mm ** 2 / 4.0  # t/mm
    h = whisker.length_mm / elements
    k_e, m_e = _element_matrices(whisker.bending_stiffness_n_mm2, mu, h)
    size = 2 * (elements + 1)
    k_beam, m_beam = np.zeros((size, size)), np.zeros((size, size))
    for e in range(elements):
        block = slice(2 * e, 2 * e + 4)
        k_beam[block, block] += k_e
        m_beam[block, block] += m_e
    # the clamp's (w, w') = (u + a·θ, θ): the stub of length a turns with the suspension
    to_beam = np.eye(size)
    to_beam[0, 1] = whisker.root_offset_mm
    stiffness = to_beam.T @ k_beam @ to_beam
    stiffness[0, 0] += whisker.root_translational_stiffness_n_per_mm
    stiffness[1, 1] += whisker.root_rotational_stiffness_n_mm_per_rad
    return stiffness, to_beam.T @ m_beam @ to_beam


def _load_vector(whisker: WhiskerParams, arc_mm: float, elements: int) -> np.ndarray:
    """A unit sideways force at arc length ``arc_mm`` from the clamp, on the element's DOFs."""
    h = whisker.length_mm / elements
    arc = min(max(arc_mm, 0.0), whisker.length_mm)
    e = min(int(arc / h), elements - 1)
    xi = arc / h - e
    shape = [1 - 3 * xi ** 2 + 2 * xi ** 3, h * (xi - 2 * xi ** 2 + xi ** 3), 3 * xi ** 2 - 2 * xi ** 3,
             h * (xi ** 3 - xi ** 2)]
    load = np.zeros(2 * (elements + 1))
    load[2 * e:2 * e + 4] = shape
    return load


def modes(whisker: WhiskerParams, count: int = 2, damping_ratio: float = DEFAULT_DAMPING_RATIO,
          density_kg_m3: float = NITINOL_DENSITY_KG_M3, load_arc_mm: float | None = None,
          elements: int = ELEMENTS) -> tuple[Mode, ...]:
    """The ``count`` lowest bending modes of the wire on its suspension, each with its share of
    the static root response to a point load at ``load_arc_mm`` (default: the tip)."""
    stiffness, mass = system_matrices(whisker, density_kg_m3, elements)
    omega2, shapes = eigh(stiffness, mass)  # mass-normalized: φᵀMφ = 1
    size = len(stiffness)
    to_beam = np.eye(size)
    to_beam[0, 1] = whisker.root_offset_mm
    load = to_beam.T @ _load_vector(whisker, whisker.length_mm if load_arc_mm is None
                                    else load_arc_mm, elements)
    static = np.linalg.solve(stiffness, load)
    found = []
    for i in range(count):
        part = shapes[:, i] * (shapes[:, i] @ load) / omega2[i]
        found.append(Mode(frequency_hz=math.sqrt(omega2[i]) / (2 * math.pi),
                          damping_ratio=damping_ratio,
                          rotation_share=float(part[1] / static[1]),
                          shift_share=float(part[0] / static[0])))
    return tuple(found)


def clamped_free_hz(whisker: WhiskerParams, mode: int = 1,
                    density_kg_m3: float = NITINOL_DENSITY_KG_M3) -> float:
    """The textbook frequency of the same wire rigidly clamped (Hz): (β_n·L)²/(2π)·√(EI/μL⁴)."""
    beta_l = (1.8751040687, 4.6940911330, 7.8547574382)[mode - 1]
    mu = density_kg_m3 * 1e-12 * math.pi * whisker.diameter_mm ** 2 / 4.0
    return beta_l ** 2 / (2 * math.pi) * math.sqrt(whisker.bending_stiffness_n_mm2
                                                   / (mu * whisker.length_mm ** 4))


class RingingRoot:
    """The suspension's pose as the sensor sees it, the modes' response to the quasi-static pose
    (see the module's docstring). Call :meth:`at` in time order."""

    def __init__(self, found: tuple[Mode, ...], rotation_rad: float = 0.0,
                 shift_mm=(0.0, 0.0), t_s: float = 0.0) -> None:
        self.modes = found
        self._shares = np.array([[m.rotation_share, m.shift_share] for m in found]).reshape(-1, 2)
        start = np.array([rotation_rad, float(shift_mm[1])])
        self._y = np.tile(start, (len(found), 1))  # each mode's coordinate, (modes, 2)
        self._v = np.zeros_like(self._y)  # and its rate
        self._input = start
        self._t_s = t_s
        self._transitions: dict[float, list[np.ndarray]] = {}

    def at(self, t_s: float, rotation_rad: float, shift_mm) -> tuple[float, np.ndarray]:
        """The dynamic (rotation rad, shift mm (2,)) at ``t_s`` for the quasi-static pose then."""
        target = np.array([rotation_rad, float(shift_mm[1])])
        dt = t_s - self._t_s
        if dt > 0:
            self._advance(dt, target)
        self._t_s = max(self._t_s, t_s)
        self._input = target
        pose = target + np.sum(self._shares * (self._y - target), axis=0)
        return float(pose[0]), np.array([float(shift_mm[0]), pose[1]])

    def _advance(self, dt: float, target: np.ndarray) -> None:
        """Each mode over ``dt`` s with the input linear from the last to ``target``: exact."""
        slope = (target - self._input) / dt
        for i, mode in enumerate(self.modes):
            lag = 2.0 * mode.damping_ratio * slope / mode.omega_rad_s  # a ramp's steady lag
            x0 = self._y[i] - (self._input - lag)
            v0 = self._v[i] - slope
            phi = self._transition(i, dt)
            self._y[i] = phi[0, 0] * x0 + phi[0, 1] * v0 + target - lag
            self._v[i] = phi[1, 0] * x0 + phi[1, 1] * v0 + slope

    def _transition(self, i: int, dt: float) -> np.ndarray:
        key = round(dt, 12)
        cached = self._transitions.get(key)
        if cached is None:
            if len(self._transitions) > 64:
                self._transitions.clear()
            cached = self._transitions[key] = [self._homogeneous(m, dt) for m in self.modes]
        return cached[i]

    @staticmethod
    def _homogeneous(mode: Mode, dt: float) -> np.ndarray:
        omega, zeta = mode.omega_rad_s, mode.damping_ratio
        return expm(np.array([[0.0, 1.0], [-omega ** 2, -2 * zeta * omega]]) * dt)
