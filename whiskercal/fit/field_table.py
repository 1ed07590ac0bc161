"""The (Y, Z) -> tip table for realistic tip contacts (``fit``'s default; ``--no-field-table``).

One scalar cannot tell a tip pushed square from one pushed with friction or by a slanted surface
at the same Y; the chip's Z axis can (docs/calibration.md). The mechanics and a multipole magnet
map are fitted to the grid's Y and Z together (``mechfit.magnetfit``), solved for tip loads of
every direction (``mechfit.tables.field_tip_table``), and the tips resampled on a regular
(Y, Z) grid that the artifact carries in ``/field_table`` and the runtime reads bilinearly.
The table's tip error is estimated without the truth (``mechfit.table_error``): warned above the
goal, and the table withheld (the runtime then reads the z lookup) where it cannot be trusted.
Where it is withheld because one reading fits tip loads far apart, with the model at the noise,
the model's loads are written instead for the runtime to follow through each contact from rest
(``followed_branches``; docs/calibration.md, "Where one reading folds").
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from whiskercal.artifacts.raw_grid import baseline_y_at
from whiskercal.errors import UsageError
from whiskercal.fit.timings import StageTimes
from whiskercal.fit.tip_model import WARN_TIP_ERROR_MM
from whiskercal.mechfit.branch_surface import followed_tip_error_mm, load_branches
from whiskercal.mechfit.fit import MechanicsFit
from whiskercal.mechfit.joint_lookup import JointLookup, joint_z_lookup
from whiskercal.mechfit.magnetfit import (MAX_STAGE_OFFSET_MM, fit_mechanics_magnet,
                                          offset_at_bound)
from whiskercal.mechfit.table_error import HELD_SAMPLES, estimated_tip_error_mm
from whiskercal.mechfit.tables import (DEFAULT_SAMPLES, read_back_mm, table_load_points,
                                       tabulate)
from whiskercal.model.calibrate import contact_mask
from whiskercal.model.field_table import FieldTipTable

SENSOR_AXIS_Z = 2
# the joint fit should explain both axes to about their noise; more says the model does not
MAX_RESIDUAL_RATIO = 2.0
# a stiffness ratio four times off that fits within this Δχ² is not excluded by the grid
MIN_DELTA_CHI2 = 9.0
# a held contact's estimate above this (mm RMS; the goal's bound on the largest error) or a
# residual above MAX_RESIDUAL_RATIO: no table is written and the runtime reads the z lookup, as
# for an artifact without one. The held estimate (``mechfit.table_error.HELD_SAMPLES``) decides:
# what averaging cannot remove is the table's own; one reading's noise the runtime's filter
# averages. The estimate runs low where the table is wrong, so the bound sits at twice the
# goal (the sensor-family benchmark shows the z lookup erring less past it).
REFUSE_ESTIMATE_MM = 0.5
# the most of the pressed directions the branch follower may lose for its loads to be written
MAX_LOST_FRACTION = 0.1


@dataclass
class FieldTableFit:
    """The table's arrays for the artifact (None when withheld), its evidence for /metrics,
    warnings, the table itself whether written or not (None when none was made), and the joint
    fit's z lookup."""

    table: dict[str, np.ndarray] | None
    metrics: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    tips: FieldTipTable | None = None
    # the joint fit's own z lookup and its estimate (``mechfit.joint_lookup``): the tip model's
    # candidate (``fit.tip_model.adopt_joint_lookup``)
    z_lookup: JointLookup | None = None
    # the loads the runtime follows through a contact where the table is withheld because one
    # reading fits loads far apart (``followed_branches``), for the artifact; None otherwise
    branches: dict[str, np.ndarray] | None = None
    # the joint fit the table came from (None when none was made): for checks against a truth
    mechanics: MechanicsFit | None = None
    # what reading Y alone is estimated to err on the table's loads (mm RMS), where the joint
    # model explains the grid to its noise and identifies the suspension; NaN otherwise
    # (``fit.tip_model``'s refusal)
    y_alone_mm: float = float("nan")

    @property
    def trusted(self) -> bool:
        """A table or loads to follow are written: a reader trusted on its own estimate."""
        return self.table is not None or self.branches is not None


@dataclass(frozen=True)
class TableContacts:
    """What the table is fitted to: rod centres (n, 2) mm, (Y, Z) from rest (n, 2) µT, which
    contacts are the tip sweep's (n,), the point means' standard errors (Y, Z µT), one sample's
    noise (Y, Z µT: what a runtime reading carries) and the rod's radius (mm)."""

    rod_center_mm: np.ndarray
    fields_uT: np.ndarray
    sweep: np.ndarray
    noise_uT: np.ndarray
    sample_noise_uT: np.ndarray
    rod_radius_mm: float


def axial_deflection_uT(raw) -> np.ndarray:
    """The chip-normal (Z) axis of each grid point's mean, less its static reading (µT), drift
    interpolated between the baselines as the Y axis' is."""
    after = raw.baseline_after
    static = baseline_y_at(raw.t_mid_s, (raw.baseline_before.t_s,
                                         raw.baseline_before.field_uT[SENSOR_AXIS_Z]),
                           None if after is None else (after.t_s, after.field_uT[SENSOR_AXIS_Z]))
    return raw.field_mean_uT[:, SENSOR_AXIS_Z] - static


def offset_warnings(offset_mm) -> list[str]:
    """A warning when the joint fit's stage offset (x, y mm) reached its bound: no belt's dead
    band is that wide, so the origin was set wrong or the fit made up for a wrong suspension."""
    if not offset_at_bound(offset_mm):
        return []
    x, y = offset_mm
    return [f"the (Y, Z) model put the stage's offset at its bound ({x:+.3f}, {y:+.3f} mm; at "
            f"most {MAX_STAGE_OFFSET_MM} mm an axis): check the stage's backlash and the "
            "whisker origin's position; the model may have found the wrong suspension and its "
            "estimates may be low"]


def loose_ratios(profile: list[dict]) -> tuple[float, ...]:
    """The k_θ·L/EI four times off the best's that fit the grid about as well (Δχ² below
    ``MIN_DELTA_CHI2``): where there is one, the grid's Y and Z do not identify the suspension."""
    return tuple(p["stiffness_ratio"] for p in profile if p["delta_chi2"] < MIN_DELTA_CHI2)


def trust_verdict(estimate_mm: float, held_estimate_mm: float, residual_ratio,
                  z_lookup_mm: float = float("nan"),
                  loose: tuple[float, ...] = ()) -> tuple[bool, list[str]]:
    """(write the table?, warnings) from the table's estimated tip error (mm RMS) for one
    reading and for a held contact (``HELD_SAMPLES`` averaged), the joint fit's residual in
    units of the noise (Y, Z) and the k_θ·L/EI that fit about as well as the best (``loose``,
    from ``loose_ratios``); ``z_lookup_mm``, what Y alone is estimated to err on the same loads,
    is named when the table is withheld (the runtime's fallback).

    A suspension the grid does not identify leaves the estimate no bound: every session whose
    joint fit was loose read realistic contacts several times further off than the table's
    estimate (docs/research/2026-12-03-quick-plan.md)."""
    ratio = float(np.max(residual_ratio))
    reasons = []
    if loose:
        reasons.append("the grid's Y and Z do not pin the suspension down (k_theta*L/EI "
                       f"{', '.join(f'{r:.3g}' for r in loose)} fits about as well as the best)")
    if not held_estimate_mm <= REFUSE_ESTIMATE_MM:
        reasons.append(f"its estimated tip error is {held_estimate_mm:.2f} mm RMS for a contact "
                       f"held {HELD_SAMPLES} samples ({estimate_mm:.2f} for one reading)")
    if not ratio <= MAX_RESIDUAL_RATIO:
        reasons.append(f"the (Y, Z) model leaves {ratio:.1f}x the noise unexplained")
    if reasons:
        fallback = (f" (Y alone errs {z_lookup_mm:.1f} mm RMS on the table's loads: expect "
                    "millimetres on contacts with friction or at a slant)"
                    if np.isfinite(z_lookup_mm) else "")
        return False, ["no (Y, Z) table written, it cannot be trusted: " + "; ".join(reasons)
                       + "; the runtime uses the z lookup" + fallback]
    if estimate_mm > WARN_TIP_ERROR_MM:
        return True, [f"the (Y, Z) table's estimated tip error is {estimate_mm:.2f} mm RMS for "
                      f"one reading, {held_estimate_mm:.2f} mm for a contact held "
                      f"{HELD_SAMPLES} samples (goal {WARN_TIP_ERROR_MM} mm)"]
    return True, []


# the fewest contacts the joint fit is tried on (it has 14 parameters: 3 mechanical, 7 geometric,
# 4 strengths, each contact giving two readings)
MIN_CONTACTS = 20


def _withheld(reason: str) -> FieldTableFit:
    """No table, and one warning saying why: the table is on by default, and a grid it cannot
    be fitted to may still calibrate the z lookup."""
    return FieldTableFit(None, {"field_table": {"field_table_written": False, "reason": reason},
                                "field_table_estimated_tip_error_mm": float("nan"),
                                "field_table_held_estimated_tip_error_mm": float("nan")},
                         [f"no (Y, Z) table written: {reason}; the runtime uses the z lookup"])


def table_contacts(raw) -> TableContacts:
    """The raw grid's contacts (the tip sweep's included) as the table's fit reads them."""
    used = contact_mask(raw.z_uT, raw.z_sem_uT)
    sweep = np.asarray(getattr(raw, "sweep", np.zeros(len(used), bool)), bool)
    n = np.sqrt(np.maximum(raw.n_samples[used], 1))
    axial_std = raw.field_std_uT[used, SENSOR_AXIS_Z]
    return TableContacts(raw.rod_center_mm[used],
                         np.column_stack([raw.z_uT[used], axial_deflection_uT(raw)[used]]),
                         sweep[used], np.array([np.median(raw.z_sem_uT[used]),
                                                np.median(axial_std / n)]),
                         np.array([np.median(raw.z_std_uT[used]), np.median(axial_std)]),
                         float(raw.rod_radius_mm))


def fit_field_table(raw, length_mm: float, start=None, samples: int = DEFAULT_SAMPLES,
                    times: StageTimes | None = None) -> FieldTableFit:
    """The (Y, Z) table of a raw grid (:func:`field_table_from_contacts`)."""
    used = contact_mask(raw.z_uT, raw.z_sem_uT)
    if used.sum() < MIN_CONTACTS:
        return _withheld(f"it needs at least {MIN_CONTACTS} contacts, the grid has {used.sum()}")
    return field_table_from_contacts(table_contacts(raw), length_mm, start, samples, times)


def field_table_from_contacts(contacts: TableContacts, length_mm: float, start=None,
                              samples: int = DEFAULT_SAMPLES,
                              times: StageTimes | None = None) -> FieldTableFit:
    """Fit the mechanics and the magnet map to the contacts, and tabulate the tips.

    The tip sweep's contacts are fitted too, solved along the rod's approach: they show the map
    and the suspension tip loads, which the shaft contacts never do; the table spans the grid's
    Y range. ``start``: the z lookup's mechanics (``MechanicsFit``) to start from (fitted on Y
    here when not given). Contacts the mechanics cannot be fitted to (a rigid root, rod
    positions the model refuses) get no table and one warning, as an untrusted table does.
    The joint fit's own z lookup (``samples`` knots) comes along, with its estimate.
    ``times`` (optional) gets the wall time of the joint fit, the table with its lookup and
    estimate, and the load branches.
    """
    started = time.perf_counter()
    c, times = contacts, times or StageTimes()
    try:
        with times.stage("joint_fit", "mechanics with the magnet's map on Y and Z, and the "
                                      "(Y, Z) -> tip table"):
            fit = fit_mechanics_magnet(c.rod_center_mm, c.fields_uT, c.rod_radius_mm,
                                       length_mm, c.noise_uT, start=start, sweep=c.sweep)
    except UsageError as error:  # as the z lookup's mechanics (fit.tip_model) reports it
        return _withheld(f"the (Y, Z) model cannot be fitted ({str(error).rstrip('.')})")
    on_grid = c.fields_uT[~c.sweep, 0]
    y_range = (float(on_grid.min()), float(on_grid.max()))
    with times.stage("table"):
        try:
            load_fields, load_tips = table_load_points(fit, y_range)
        except UsageError as error:  # a model with no tip loads to tabulate
            return _withheld(f"the (Y, Z) table cannot be made ({str(error).rstrip('.')})")
        table = tabulate(load_fields, load_tips, y_range)
        lookup = _joint_lookup(fit, c, length_mm, y_range, samples)
        error = estimated_tip_error_mm(load_fields, load_tips, table, c.sample_noise_uT,
                                       None if lookup is None else lookup.lookup)
    estimate = error["estimate_mm"]
    metrics = _fit_metrics(fit, c, table)
    metrics["table_read_back_mm"] = read_back_mm(table, load_fields, load_tips)
    if lookup is not None:
        metrics["z_lookup"] = lookup.metrics()
    residual_ratio = fit.rms_uT / c.noise_uT
    loose = loose_ratios(metrics["ratio_profile"])
    write, verdict = trust_verdict(estimate, error["held_estimate_mm"], residual_ratio,
                                   error.get("z_lookup_mm", float("nan")), loose)
    credible = _credible(residual_ratio, loose)
    branches = None
    if not write and credible:  # withheld: readings fold
        with times.stage("load_branches"):
            branches, verdict = followed_branches(fit, y_range, c.sample_noise_uT, verdict)
        metrics["load_branches"] = branches.pop("metrics")
    warnings = offset_warnings(metrics["stage_offset_mm"]) + verdict
    metrics.update(field_table_estimated_tip_error_mm=estimate, estimated_error_parts=error,
                   field_table_written=write, fit_s=time.perf_counter() - started)
    arrays = {"y_uT": table.y_uT, "axial_uT": table.z_uT, "tip_mm": table.tips_mm}
    top = {"field_table": metrics, "field_table_estimated_tip_error_mm": estimate,
           "field_table_held_estimated_tip_error_mm": error["held_estimate_mm"]}
    if branches is not None:
        top.update(_branch_summary(metrics["load_branches"]))
    return FieldTableFit(arrays if write else None, top, warnings, table, lookup,
                         branches.get("arrays") if branches else None, fit,
                         error.get("z_lookup_mm", float("nan")) if credible else float("nan"))


def _credible(residual_ratio, loose: tuple[float, ...]) -> bool:
    """Are the model's loads worth following, and what Y alone errs on them worth a refusal?
    Only where the model explains the grid to its noise and the grid identifies it."""
    return bool(np.max(residual_ratio) <= MAX_RESIDUAL_RATIO) and not loose


def followed_branches(fit, y_range, sample_noise_uT, verdict: list[str]) -> tuple[dict, list]:
    """The model's loads for the branch follower (``model.load_branches``) where the table is
    withheld, its estimated error on the model's own presses, and the warnings that replace
    the table's: ``({"metrics": ..., "arrays": ... or absent}, warnings)``. The loads are
    written when the follower's held estimate passes ``REFUSE_ESTIMATE_MM`` and it kept to its
    branch on all but ``MAX_LOST_FRACTION`` of the directions pressed."""
    started = time.perf_counter()
    branches = load_branches(fit, y_range, sample_noise_uT)
    error = followed_tip_error_mm(branches, sample_noise_uT)
    lost = error["lost_directions_deg"]
    write = (error["held_estimate_mm"] <= REFUSE_ESTIMATE_MM
             and len(lost) <= MAX_LOST_FRACTION * error["presses"])
    metrics = {**error, "written": write, "shape": list(branches.shape),
               "fit_s": time.perf_counter() - started}
    if not write:
        return {"metrics": metrics}, verdict + [
            "no load branches written either: following a contact from rest is estimated to "
            f"err {error['held_estimate_mm']:.2f} mm RMS held, and loses its branch on "
            f"{len(lost)} of {error['presses']} directions"]
    arrays = {"fields_uT": branches.fields_uT, "tip_mm": branches.tips_mm,
              "noise_uT": branches.noise_uT, "y_range_uT": np.array(branches.y_range_uT)}
    return {"metrics": metrics, "arrays": arrays}, _branch_warnings(error)


def _branch_warnings(error: dict) -> list[str]:
    """What the fit says when the runtime will follow loads instead of reading a table."""
    lost = error["lost_directions_deg"]
    said = [f"no (Y, Z) table written: one reading fits tip loads far apart; the runtime "
            "follows each contact's load from rest instead (feed it every sample with the Z "
            f"axis), estimated tip error {error['estimate_mm']:.2f} mm RMS for one reading, "
            f"{error['held_estimate_mm']:.2f} mm held {HELD_SAMPLES} samples"]
    if lost:
        said.append("the load follower loses its branch on pushes at "
                    + ", ".join(f"{a:g}" for a in lost) + " degrees from the wire's normal, "
                    "where a press's readings retrace their path")
    return said


def _branch_summary(metrics: dict) -> dict:
    return {"load_branches_written": metrics["written"],
            "load_branches_estimated_tip_error_mm": metrics["estimate_mm"],
            "load_branches_held_estimated_tip_error_mm": metrics["held_estimate_mm"]}


def _joint_lookup(fit, contacts: TableContacts, length_mm, y_range, samples):
    """The joint fit's z lookup with its estimate (``mechfit.joint_lookup``); None where the
    fit has none over the grid's range."""
    c = contacts
    return joint_z_lookup(fit, c.rod_center_mm, c.fields_uT, c.noise_uT, c.rod_radius_mm,
                          length_mm, y_range, c.sweep, samples)


def _fit_metrics(fit, contacts: TableContacts, table: FieldTipTable) -> dict:
    """The joint fit's evidence, as /metrics records it under ``field_table``."""
    return {"stiffness_ratio": 1.0 / fit.suspension.rot_compliance,
            "stub_mm": fit.suspension.stub_mm,
            "trans_compliance": fit.suspension.trans_compliance,
            "residual_rms_uT": fit.rms_uT.tolist(), "noise_uT": contacts.noise_uT.tolist(),
            "magnet_map": fit.pose_map.as_dict(), "tip_sweep_points": int(contacts.sweep.sum()),
            "table_shape": list(table.tips_mm.shape[:2]),
            "table_answered_fraction": float(np.mean(np.isfinite(table.tips_mm[..., 0]))),
            "stage_offset_mm": fit.starts[-1]["stage_offset_mm"],
            "ratio_profile": fit.starts[-1].get("ratio_profile", [])}
