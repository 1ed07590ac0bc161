"""Ground truth the real rig never has: noise-free z for any pose and the true tip for a given z.

z is the sensor's Y reading minus its static (no-contact) Y reading, in µT, noise-free and not
quantized. The tip curve is z against the true tip for a frictionless contact at the very tip:
the touch rod (radius `TIP_ROD_RADIUS_MM`) is placed at each step so that it meets the wire
exactly at its end, with its surface tangent to the wire there, so the contact force stands
perpendicular to the wire at the tip. Each sample is one `mechanics.solve_rod` equilibrium; the
rod's position for a wanted slope of the wire at its tip is found by a small Newton iteration.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from whiskercal.errors import UsageError
from whiskercal.twin.physics import mechanics
from whiskercal.twin.physics.magnet import field_uT
from whiskercal.twin.params import SensorParams
from whiskercal.twin.physics.whisker import Equilibrium, WhiskerParams

TIP_ROD_RADIUS_MM = 1.0
# Far enough that the default sensor reads beyond -12000 µT; its root rotation saturates near here.
MAX_TIP_SLOPE_RAD = 1.9
_SLOPE_TOL_RAD = 1e-9
_TIP_OFFSET_TOL_MM = 1e-6
_MAX_NEWTON = 20
_MAX_STEP_MM = 3.0
_MAX_SLOPE_STEP_RAD = 0.025
# The shortest sweep accepted when tip contact cannot be held to the wanted slope (rad): a
# quarter of MAX_TIP_SLOPE_RAD, as `describe.held_sweep` tries at the least.
MIN_TIP_SLOPE_RAD = 0.475


def static_field_uT(sensor: SensorParams) -> np.ndarray:
    """Noise-free field at the sensor with the whisker free, sensor axes (X, Y, Z), µT (3,)."""
    free = mechanics.free(sensor.whisker)
    return field_uT(sensor.magnet, free.root_rotation_rad, free.root_shift_mm)


def z_of_pose(sensor: SensorParams, root_rotation_rad, root_shift_mm) -> np.ndarray:
    """Noise-free deflection measurement z for suspension poses, µT.

    Parameters
    ----------
    sensor : SensorParams
    root_rotation_rad : array_like, shape (...)
    root_shift_mm : array_like, shape (..., 2)

    Returns
    -------
    ndarray, shape (...)
        Y field minus the static Y field.
    """
    field = field_uT(sensor.magnet, root_rotation_rad, root_shift_mm)
    return field[..., 1] - static_field_uT(sensor)[1]


def z_of_equilibrium(sensor: SensorParams, equilibrium: Equilibrium) -> float:
    """Noise-free z (µT) of one mechanics equilibrium."""
    return float(z_of_pose(sensor, equilibrium.root_rotation_rad, equilibrium.root_shift_mm))


@dataclass(frozen=True)
class TipSweep:
    """Equilibria with a frictionless contact at the tip, by increasing tip slope magnitude.

    Attributes
    ----------
    tip_slope_rad : ndarray, shape (n,)
        Direction of the wire at its tip (0 undeflected, negative when pushed to -y).
    root_rotation_rad : ndarray, shape (n,)
    root_shift_mm : ndarray, shape (n, 2)
    tip_mm : ndarray, shape (n, 2)
    rod_center_mm : ndarray, shape (n, 2)
        Where the rod stood for each sample (its surface touches the tip).
    """

    tip_slope_rad: np.ndarray
    root_rotation_rad: np.ndarray
    root_shift_mm: np.ndarray
    tip_mm: np.ndarray
    rod_center_mm: np.ndarray


def _tip_tangent(equilibrium: Equilibrium) -> np.ndarray:
    """Unit tangent of the wire at its tip (the moment, hence curvature, vanishes there)."""
    points = equilibrium.shape_mm(400)
    chord = points[-1] - points[-2]
    return chord / np.linalg.norm(chord)


def _tip_per_tip_angle_mm(whisker: WhiskerParams) -> float:
    """Small-load tip deflection per radian of tip slope (beam theory, compliant root)."""
    reach, length, stiffness = whisker.reach_mm, whisker.length_mm, whisker.bending_stiffness_n_mm2
    root_turn_per_n = reach / whisker.root_rotational_stiffness_n_mm_per_rad
    deflection_per_n = root_turn_per_n * reach + length**3 / (3.0 * stiffness)
    slope_per_n = root_turn_per_n + length**2 / (2.0 * stiffness)
    return deflection_per_n / slope_per_n


def _rod_residual(whisker, center, previous, target_angle):
    """(equilibrium, residual): tip slope error (rad) and rod position past the tip (mm)."""
    equilibrium = mechanics.solve_rod(whisker, center, TIP_ROD_RADIUS_MM, previous=previous)
    if equilibrium.kind not in ("shaft", "tip"):
        return equilibrium, None
    tangent = _tip_tangent(equilibrium)
    # Along the tip tangent: negative while the rod touches the shaft before the tip.
    past_tip = float(tangent @ (center - equilibrium.tip_mm))
    return equilibrium, np.array([np.arctan2(tangent[1], tangent[0]) - target_angle, past_tip])


def _jacobian(whisker, center, previous, target, residual, step_mm=1e-3):
    """Finite-difference Jacobian of `_rod_residual` with respect to the rod centre."""
    columns = []
    for axis in range(2):
        moved = center.copy()
        moved[axis] += step_mm
        _, shifted = _rod_residual(whisker, moved, previous, target)
        if shifted is None:
            raise UsageError("the tip-contact sweep lost the contact while probing the rod position.")
        columns.append((shifted - residual) / step_mm)
    return np.column_stack(columns)


def _damped_step(whisker, center, step, previous, target):
    """Take the Newton step, halving it while the rod would lose the contact."""
    step = step * min(1.0, _MAX_STEP_MM / np.linalg.norm(step))
    for _ in range(8):
        equilibrium, residual = _rod_residual(whisker, center + step, previous, target)
        if residual is not None:
            return step, equilibrium, residual
        step = step / 2.0
    raise UsageError(f"tip contact is lost before a tip slope of {target:.3f} rad.")


def _place_rod(whisker, start, guess, previous, target, jacobian):
    """Newton (Broyden updates) for the rod centre giving tip slope `target` with tip contact.

    `start` is the last rod centre that held the contact; the first move goes from there toward
    `guess`, shortened while the contact would be lost.
    """
    step, equilibrium, residual = _damped_step(whisker, start, guess - start, previous, target)
    center = start + step
    for _ in range(_MAX_NEWTON):
        if abs(residual[0]) < _SLOPE_TOL_RAD and abs(residual[1]) < _TIP_OFFSET_TOL_MM:
            return center, equilibrium, jacobian
        if jacobian is None:
            jacobian = _jacobian(whisker, center, previous, target, residual)
        step, equilibrium, new_residual = _damped_step(
            whisker, center, -np.linalg.solve(jacobian, residual), previous, target)
        center = center + step
        # Broyden's rank-one update keeps one solve per iteration.
        jacobian = jacobian + np.outer(new_residual - residual - jacobian @ step, step) / (step @ step)
        residual = new_residual
    raise UsageError(f"the tip-contact sweep did not converge at a tip slope of {target:.3f} rad.")


class _March:
    """The rod's path along the sweep: last states, for extrapolation and warm starts."""

    def __init__(self, whisker: WhiskerParams):
        self.whisker = whisker
        self.centers = [np.array([whisker.reach_mm, TIP_ROD_RADIUS_MM])]
        self.previous: Equilibrium | None = None
        self.jacobian: np.ndarray | None = None

    def advance(self, target: float) -> None:
        """Place the rod for tip slope `target` (rad), just past the last one."""
        whisker, centers = self.whisker, self.centers
        if self.previous is not None:
            # Extrapolate the rod's path from the last two positions, then move it 0.5 mm back
            # along the tip tangent: onto the shaft, where the warm start cannot slip off.
            guess = 2.0 * centers[-1] - centers[-2] - 0.5 * _tip_tangent(self.previous)
        else:  # small-deflection beam theory
            guess = np.array([whisker.reach_mm - 0.5,
                              TIP_ROD_RADIUS_MM + _tip_per_tip_angle_mm(whisker) * target])
        center, self.previous, self.jacobian = _place_rod(
            whisker, centers[-1], guess, self.previous, target, self.jacobian)
        centers.append(center)


@functools.lru_cache(maxsize=16)
def tip_contact_sweep(whisker: WhiskerParams, n: int, max_tip_slope_rad: float = MAX_TIP_SLOPE_RAD) -> TipSweep:
    """Frictionless tip-contact equilibria at n tip slopes evenly spaced in [-max, 0].

    The first sample is the free whisker. On a soft suspension (k_θ·L/EI about 1) a push mostly
    turns the root, and the wire swings round it before its tip turns that far: the rod would
    have to stand at the clamp. The sweep then ends short, at the largest tip slope whose
    contact the march held less one march step (``tip_slope_rad[-1]`` says where). Raises
    UsageError if tip contact cannot be held even to :data:`MIN_TIP_SLOPE_RAD`.
    """
    if n < 4:
        raise UsageError(f"a tip curve needs at least 4 samples, got {n}.")
    while True:
        sweep, held_rad = _march_sweep(whisker, n, max_tip_slope_rad)
        if sweep is not None:
            return sweep
        # another march, to what the first held: its in-between slopes differ, hence the margin
        max_tip_slope_rad = held_rad - _MAX_SLOPE_STEP_RAD
        if max_tip_slope_rad < MIN_TIP_SLOPE_RAD:
            raise UsageError(f"tip contact cannot be held even to a tip slope of "
                             f"{MIN_TIP_SLOPE_RAD:g} rad (it is lost at {held_rad:.3f} rad).")


def _march_sweep(whisker: WhiskerParams, n: int, max_tip_slope_rad: float,
                 ) -> tuple[TipSweep | None, float]:
    """(the sweep, None) when the march holds tip contact to the end, else (None, the largest
    tip slope magnitude it held, rad)."""
    targets = -np.linspace(0.0, max_tip_slope_rad, n)
    free = mechanics.free(whisker)
    states, centers = [free], [np.array([whisker.reach_mm, TIP_ROD_RADIUS_MM])]
    march, held = _March(whisker), 0.0
    for low, high in zip(targets[:-1], targets[1:]):
        # Warm starts only hold over small moves of the rod: step through in-between slopes.
        n_steps = int(np.ceil(abs(high - low) / _MAX_SLOPE_STEP_RAD))
        for target in np.linspace(low, high, n_steps + 1)[1:]:
            try:
                march.advance(target)
            except (UsageError, np.linalg.LinAlgError):  # lost, or the rod reached the clamp
                return None, held
            held = abs(float(target))
        states.append(march.previous)
        centers.append(march.centers[-1])
    return TipSweep(
        tip_slope_rad=targets,
        root_rotation_rad=np.array([state.root_rotation_rad for state in states]),
        root_shift_mm=np.array([state.root_shift_mm for state in states]),
        tip_mm=np.array([state.tip_mm for state in states]),
        rod_center_mm=np.array(centers),
    ), None


def tip_curve(sensor: SensorParams, n: int = 161) -> tuple[np.ndarray, np.ndarray]:
    """Dense noise-free ground truth of z against the true tip for tip contact.

    Parameters
    ----------
    sensor : SensorParams
    n : int
        Number of samples, evenly spaced in the wire's slope at the tip from the free whisker
        to `MAX_TIP_SLOPE_RAD`, or as far as tip contact holds (`tip_contact_sweep`).

    Returns
    -------
    z_uT : ndarray, shape (n,)
        Deflection measurement, from 0 down (more negative with more deflection).
    tip_mm : ndarray, shape (n, 2)
        The wire's tip in the whisker frame.
    """
    sweep = tip_contact_sweep(sensor.whisker, int(n))
    return z_of_pose(sensor, sweep.root_rotation_rad, sweep.root_shift_mm), sweep.tip_mm.copy()


@functools.lru_cache(maxsize=16)
def _tip_interpolant(sensor: SensorParams, n: int) -> tuple[CubicSpline, float]:
    """The tip as a function of z over the curve's first branch, and that branch's lowest z.

    On a soft suspension z folds back (the wire swings round its root and the magnet turns past
    its steepest reading): beyond the fold two tips share one z, so the truth ends there.
    """
    z, tip = first_branch(*tip_curve(sensor, n))
    if z.size < 4:
        raise UsageError(f"z of sensor {sensor.sensor_id!r} is not monotonic in the deflection; "
                         "its tip curve cannot be inverted.")
    return CubicSpline(z[::-1], tip[::-1], axis=0), float(z[-1])


def first_branch(z_uT: np.ndarray, tip_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A tip curve's samples (z µT, tips mm) up to where z folds back.

    On a soft suspension z stops falling as the wire swings round its root, and past that fold
    a second branch of tips shares the first one's z: the truth of a z is its first-branch tip,
    which is what :func:`true_tip` inverts.
    """
    turned = np.flatnonzero(np.diff(z_uT) >= 0)
    end = int(turned[0]) if turned.size else len(z_uT) - 1  # the last sample of the first branch
    return z_uT[:end + 1], tip_mm[:end + 1]


def true_tip(sensor: SensorParams, z_uT, n: int = 161) -> np.ndarray:
    """True tip (mm) for tip contact at deflection measurement z, interpolating `tip_curve`.

    Parameters
    ----------
    sensor : SensorParams
    z_uT : array_like, shape (...)
        Must lie within [z at `MAX_TIP_SLOPE_RAD` or at the fold, whichever comes first, 0].
    n : int
        Samples of the underlying tip curve.

    Returns
    -------
    ndarray, shape (..., 2)
    """
    spline, z_min = _tip_interpolant(sensor, int(n))
    z = np.asarray(z_uT, dtype=float)
    if np.any(~np.isfinite(z)) or np.any(z > 0.0) or np.any(z < z_min):
        raise UsageError(f"z must lie within the tip curve's range [{z_min:.0f}, 0] µT "
                         f"for sensor {sensor.sensor_id!r}.")
    return spline(z)
