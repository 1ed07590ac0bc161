"""(Y, Z) calibration data simulated through the twin's physics for any build, and its truth.

A rod grid (the default plan's bands scaled by the build's trace length, points past the
overload guard dropped, averaged-reading noise on Y and Z) and collect's tip sweep are solved
with the rods off the recorded places by the stage's constant offset, as a real stage leaves
them. The truth to read a calibration against: the frictionless tip curve, the twin's own
suspension and field in a fit's parameters (a perfect calibration), and tip contacts against
tilted planes with friction, each read as the runtime reads it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from whiskercal.collect.config import (DEFAULT_CONFIG_PATH, SweepConfig, config_from_dict,
                                       follow_trace_length)
from whiskercal.collect.plan import lattice_points, visiting_order
from whiskercal.collect.sweep import sweep_points
from whiskercal.errors import WhiskercalError
from whiskercal.mechfit.fit import MechanicsFit
from whiskercal.mechfit.forward import Suspension
from whiskercal.mechfit.table_error import HELD_SAMPLES
from whiskercal.mechfit.tables import field_tip_table
from whiskercal.mechfit.tipcurve import tip_family
from whiskercal.testing.twin_grid import default_grid_config, tip_error_mm
from whiskercal.tomlconfig import read_toml
from whiskercal.twin import truth
from whiskercal.twin.params import SensorParams
from whiskercal.twin.physics import mechanics
from whiskercal.twin.physics.magnet import field_uT
from whiskercal.twin.physics.whisker import WhiskerParams

ROD_RADIUS_MM = 1.5
NOISE_UT = (1.0, 1.6)    # averaged Y and Z readings (5.6 and 9.0 µT over 30 samples)
SAMPLE_NOISE_UT = (5.6, 9.0)  # one sample of Y and Z, as the runtime sees a contact
OVERLOAD_UT = 15000.0    # collect's default overload guard on |Y|
# where a rod sits less where the stage records it (x, y) mm: half the belt's dead band (the
# twin's 0.02 mm) against the drive's approach, taken up the same way at every point
# (``collect.plan``); the recorded datasets and a collect through the twin both show it
STAGE_OFFSET_MM = (-0.01, 0.01)
DEFAULT_TRACE_MM = 78.0  # the trace length the default plan's bands were chosen for
TILTS_DEG = (0, 10, 20, 30, 40)
MUS = (0.0, 0.2, 0.4)
DEPTH_FRACTIONS = (0.07, 0.16, 0.25, 0.34, 0.43, 0.53)


def stiffness_ratio(whisker: WhiskerParams) -> float:
    """k_θ·L/EI: how much a push turns the root against bending the wire (large: the wire bends)."""
    return (whisker.root_rotational_stiffness_n_mm_per_rad * whisker.length_mm
            / whisker.bending_stiffness_n_mm2)


@dataclass(frozen=True)
class FieldGrid3:
    """A simulated rod grid: centres (n, 2) mm in visiting order, noise-free and measured
    (Y, Z) minus the static reading (n, 2) µT."""

    rod_center_mm: np.ndarray
    fields_true_uT: np.ndarray
    fields_uT: np.ndarray


def static_fields(sensor: SensorParams) -> np.ndarray:
    """(X, Y, Z) field of the free whisker, µT."""
    return field_uT(sensor.magnet, 0.0, np.zeros(2))


def pose_fields(sensor: SensorParams, equilibria) -> np.ndarray:
    """(Y, Z) minus the static reading (n, 2) µT of equilibria."""
    rotation = np.array([e.root_rotation_rad for e in equilibria])
    shift = np.array([e.root_shift_mm for e in equilibria])
    return (field_uT(sensor.magnet, rotation, shift) - static_fields(sensor))[:, 1:]


def scaled_grid(sensor: SensorParams):
    """The default plan's bands scaled by the build's trace length (any number of points)."""
    factor = sensor.whisker.reach_mm / DEFAULT_TRACE_MM
    grid = default_grid_config()
    return grid.replace(step_mm=grid.step_mm * factor, reach_min_mm=grid.reach_min_mm * factor,
                        reach_max_mm=grid.reach_max_mm * factor, expected_points=0)


def simulate_fields(sensor: SensorParams, seed: int = 0,
                    stage_offset_mm=STAGE_OFFSET_MM) -> FieldGrid3:
    """Solve every rod position of the scaled plan, each rod ``stage_offset_mm`` off the place
    recorded for it; keep contacts under the overload guard."""
    points = lattice_points(scaled_grid(sensor))
    points = points[visiting_order(points)]
    offset = np.asarray(stage_offset_mm, float)
    kept, equilibria, previous, column, stopped = [], [], None, None, False
    for center in points:
        if center[0] != column:
            previous, column, stopped = None, center[0], False
        if stopped:
            continue  # past the overload guard the rest of the column is deeper still
        equilibrium = mechanics.solve_rod(sensor.whisker, center + offset, ROD_RADIUS_MM,
                                          previous=previous)
        previous = equilibrium if equilibrium.in_contact else None
        stopped = abs(pose_fields(sensor, [equilibrium])[0, 0]) >= OVERLOAD_UT
        if equilibrium.kind == "shaft" and not stopped:
            kept.append(center), equilibria.append(equilibrium)
    fields = pose_fields(sensor, equilibria)
    noise = np.random.default_rng(seed).normal(0.0, 1.0, fields.shape) * np.array(NOISE_UT)
    return FieldGrid3(np.array(kept), fields, fields + noise)


def tip_sweep_config(trace_length_mm: float = DEFAULT_TRACE_MM) -> SweepConfig:
    """The tip sweep of collect's default configuration for a trace length (its offsets scaled
    as ``collect.config.follow_trace_length`` scales them), switched on."""
    given = {"rig": {"trace_length_mm": float(trace_length_mm)}}
    values = follow_trace_length(read_toml(DEFAULT_CONFIG_PATH), given)
    return config_from_dict(values).sweep.replace(enabled=True)


def simulate_sweep(sensor: SensorParams, seed: int = 0, config: SweepConfig | None = None,
                   stage_offset_mm=STAGE_OFFSET_MM) -> FieldGrid3:
    """The tip sweep (``collect.sweep``) from the build's trace length: each position reached
    from the free whisker in -y, as the stage approaches it, the rod ``stage_offset_mm`` off it;
    contacts under the overload guard kept (a position where the wire slips past the rod reads
    no contact and is left out)."""
    config = config or tip_sweep_config(sensor.whisker.reach_mm)
    points = sweep_points(config, sensor.whisker.reach_mm)
    offset = np.asarray(stage_offset_mm, float)
    kept, equilibria = [], []
    for center in points:
        equilibrium = mechanics.solve_rod(sensor.whisker, center + offset, ROD_RADIUS_MM)
        if equilibrium.in_contact and abs(pose_fields(sensor, [equilibrium])[0, 0]) < OVERLOAD_UT:
            kept.append(center), equilibria.append(equilibrium)
    fields = pose_fields(sensor, equilibria).reshape(-1, 2)
    # its own noise stream: the grid's draws stay the same with or without the sweep
    noise = np.random.default_rng([seed, 1]).normal(0.0, 1.0, fields.shape) * np.array(NOISE_UT)
    return FieldGrid3(np.array(kept).reshape(-1, 2), fields, fields + noise)


def true_suspension(sensor: SensorParams) -> Suspension:
    """The twin's own mechanics in the fit's parameters (for checks only, never for fitting)."""
    w = sensor.whisker
    ei = w.bending_stiffness_n_mm2
    return Suspension(w.reach_mm, w.root_offset_mm, ei / (w.length_mm * w.root_rotational_stiffness_n_mm_per_rad),
                      ei / (w.length_mm ** 3 * w.root_translational_stiffness_n_per_mm))


def truth_tip_curve(sensor: SensorParams) -> tuple[np.ndarray, np.ndarray]:
    """The twin's z (µT) and true tips (mm) for frictionless tip contact, one-to-one part."""
    try:
        z, tips = truth.tip_curve(sensor)
    except WhiskercalError:  # the truth's rod march fails on soft suspensions: same physics
        family = tip_family(true_suspension(sensor))
        z = pose_fields_of_poses(sensor, family.pose)[:, 0]
        tips = family.tip_mm
    # past the fold z turns back and a second branch of tips shares the first one's z; a z
    # lookup answers the first branch (``truth.first_branch``), which is the truth of its z
    return truth.first_branch(z, tips)


def pose_fields_of_poses(sensor: SensorParams, poses: np.ndarray) -> np.ndarray:
    return (field_uT(sensor.magnet, poses[:, 0], poses[:, 1:]) - static_fields(sensor))[:, 1:]


class TwinPoseMap:
    """The twin's own (Y, Z) µT from rest of root poses, in a fitted pose map's place."""

    coefficients = np.zeros((1, 2))  # two field axes, Y and Z, as ``mechfit.tables`` checks

    def __init__(self, sensor: SensorParams):
        self.sensor = sensor

    def __call__(self, pose: np.ndarray) -> np.ndarray:
        return pose_fields_of_poses(self.sensor, np.atleast_2d(pose))


def perfect_fit(sensor: SensorParams, fit: MechanicsFit) -> MechanicsFit:
    """``fit`` with the twin's own suspension and field, its loads' envelope kept: a perfect
    calibration, whose table's error on noisy readings is the noise's and the table's own, not
    the fit's (for checks only)."""
    return replace(fit, suspension=true_suspension(sensor), pose_map=TwinPoseMap(sensor))


def plane_conditions():
    """(tilt °, mu, sliding sense) of every realistic plane."""
    for tilt in TILTS_DEG:
        for mu in MUS:
            for sign in (1, -1):
                if tilt == 0 and mu == 0.0:
                    continue  # an end-on push on the straight wire: the twin has no buckling
                yield tilt, mu, sign


def plane_tip_contact(sensor: SensorParams, tilt, mu, sign, fraction):
    """The equilibrium of a plane pushed in to ``fraction`` of the length while sliding, or
    None where it is no reachable tip contact."""
    whisker = sensor.whisker
    plane = mechanics.plane_for_depth(whisker, fraction * whisker.length_mm, 0.0,
                                      math.radians(tilt), mu_static=mu, mu_kinetic=mu,
                                      motion_sign=sign)
    try:
        eq = mechanics.solve_plane(whisker, plane)
    except WhiskercalError:
        return None
    return eq if eq.kind == "tip" and _reachable(sensor, eq) else None


def _plane_contacts(sensor: SensorParams):
    """(tilt, mu, sign, depth fraction, equilibrium) of every reachable plane tip contact."""
    rows = []
    for tilt, mu, sign in plane_conditions():
        for fraction in DEPTH_FRACTIONS:
            eq = plane_tip_contact(sensor, tilt, mu, sign, fraction)
            if eq is not None:
                rows.append((tilt, mu, sign, fraction, eq))
    return rows


def realistic_contacts(sensor: SensorParams) -> dict:
    """Tip contacts against tilted planes with friction: (Y, Z) µT, true tips mm, conditions."""
    rows = _plane_contacts(sensor)
    fields = pose_fields(sensor, [r[4] for r in rows])
    return {"fields_uT": fields, "tip_mm": np.array([r[4].tip_mm for r in rows]),
            "conditions": np.array([r[:4] for r in rows], float)}


def realistic_pose_contacts(sensor: SensorParams, y_range_uT) -> np.ndarray:
    """True root poses (n, 3) of the realistic contacts whose Y lies in ``y_range_uT``."""
    rows = _plane_contacts(sensor)
    poses = np.array([[r[4].root_rotation_rad, *r[4].root_shift_mm] for r in rows])
    y = pose_fields_of_poses(sensor, poses)[:, 0]
    return poses[(y >= y_range_uT[0]) & (y <= y_range_uT[1])]


def _reachable(sensor: SensorParams, equilibrium) -> bool:
    """False for the twin's far branches whose root shifts by more than the magnet's gap to the
    chip (the magnet would strike it; a real sensor cannot take that pose)."""
    return bool(np.linalg.norm(equilibrium.root_shift_mm) < sensor.magnet.gap_mm)


def lookup_errors(lookup, z_true, tips_true, z_range) -> dict:
    inside = (z_true >= z_range[0]) & (z_true <= z_range[1])
    z, tips = z_true[inside], tips_true[inside]
    covered = (z >= lookup.z_min_uT) & (z <= lookup.z_max_uT)
    estimate = np.full_like(tips, np.nan)
    estimate[covered] = lookup(z[covered])
    errors = tip_error_mm(estimate, tips)
    errors["coverage"] = float(covered.mean()) if len(z) else float("nan")
    return errors


def realistic_errors(candidate, contacts, z_range, seed: int = 0) -> dict:
    """Errors (mm) on the realistic contacts whose Y lies in the grid's range: Y only (the
    lookup), and with a (Y, Z) table as the runtime reads it (the lookup where the table has no
    tip, none past every load it tabulated: ``beyond_loads`` counts those), noise-free, with
    one sample's noise (``SAMPLE_NOISE_UT``), and held (``HELD_SAMPLES`` noisy samples' tips
    averaged)."""
    y, z = contacts["fields_uT"][:, 0], contacts["fields_uT"][:, 1]
    inside = (y >= z_range[0]) & (y <= z_range[1])
    lookup, tips = candidate["lookup"], contacts["tip_mm"][inside]
    out = {"y_only": tip_error_mm(lookup_tips(lookup, y[inside]), tips), "n": int(inside.sum())}
    if "table" in candidate:
        rng = np.random.default_rng(seed)
        noises = [rng.normal(0.0, 1.0, (int(inside.sum()), 2)) * np.array(SAMPLE_NOISE_UT)
                  for _ in range(HELD_SAMPLES)]
        y, z = y[inside], z[inside]
        reads = [_read_as_runtime(candidate["table"], lookup, y + n[:, 0], z + n[:, 1])
                 for n in noises]
        for name, (from_table, answered, beyond) in (
                ("y_and_z", _read_as_runtime(candidate["table"], lookup, y, z)),
                ("y_and_z_sample_noise", reads[0])):
            out[name] = {**tip_error_mm(from_table, tips),
                         "table_answered": float(answered.mean()) if len(y) else float("nan"),
                         "beyond_loads": int(beyond.sum())}
        out["y_and_z_held"] = {**tip_error_mm(_mean_of_answers([r[0] for r in reads]), tips),
                               "samples": HELD_SAMPLES}
    return out


def _read_as_runtime(table, lookup, y: np.ndarray, z: np.ndarray):
    """Tips (n, 2) mm read from the table, the lookup where it has no tip but none past every
    load it tabulated (``beyond_loads``: NaN); which the table answered; which lay beyond."""
    from_table = table(y, z)
    answered = np.isfinite(from_table[:, 0])
    beyond = ~answered & np.array([table.beyond_loads(a, b) != 0 for a, b in zip(y, z)], bool)
    fallback = ~answered & ~beyond
    from_table[fallback] = lookup_tips(lookup, y[fallback])
    return from_table, answered, beyond


def _mean_of_answers(reads: list[np.ndarray]) -> np.ndarray:
    """Each contact's mean tip (n, 2) over the samples that gave one (NaN where none did)."""
    stack = np.array(reads)
    answered = np.isfinite(stack[..., 0])
    total = np.where(answered[..., None], stack, 0.0).sum(axis=0)
    count = answered.sum(axis=0)[:, None]
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def lookup_tips(lookup, y: np.ndarray) -> np.ndarray:
    covered = (y >= lookup.z_min_uT) & (y <= lookup.z_max_uT)
    estimate = np.full((len(y), 2), np.nan)
    estimate[covered] = lookup(y[covered])
    return estimate



def noise_floor(sensor: SensorParams, table, lookup, contacts: dict, z_range) -> dict:
    """The realistic errors of the table a perfect calibration makes from the loads of
    ``table`` (a ``FieldTableFit`` that wrote a table): what the readings' noise costs,
    whatever the fit."""
    y_range = (float(table.tips.y_uT[0]), float(table.tips.y_uT[-1]))
    perfect = field_tip_table(perfect_fit(sensor, table.mechanics), y_range)
    measured = realistic_errors({"lookup": lookup, "table": perfect}, contacts, z_range)
    return {"one_sample": measured["y_and_z_sample_noise"], "held": measured["y_and_z_held"]}
