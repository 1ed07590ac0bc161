"""Which tip model a calibration ships, and how wrong it may be: the level set or the mechanics.

The level set f = z is the whisker's shape under a shaft contact, not the locus of its tip
(docs/calibration.md). The mechanics-informed fit (``mechfit.identify``) models the suspension
and solves it for tip contact; where the grid pins the suspension down it is far closer, and its
profile says how firmly. So:

- ``level-set``: the paper's method ships; the mechanics is fitted for the estimate;
- ``mechanics``: always the mechanics' lookup (refused when it cannot be fitted);
- ``auto`` (default): the mechanics when its estimated error is finite and below the level
  set's, else the level set; and then the (Y, Z) joint fit's own z lookup (``mechanics-yz``)
  where its estimate is lower still (``adopt_joint_lookup``, once ``fit.field_table`` has made
  it).

A frictionless tip model is not the contact a robot makes (a contour followed with friction
reads either z lookup off by the friction's tilt of the force); the (Y, Z) table ``fit`` writes
by default (``fit.field_table``) is what places tips pushed with friction, and the z lookup
chosen here is the fallback where the table has no tip or the robot streams Y only
(docs/calibration.md).

The level set's error is estimated as its distance from an identified mechanics model (plus
that model's own estimate); without one, neither error can be estimated, and the fit says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.fit.options import TIP_MODELS
from whiskercal.mechfit.identify import (IGNORED_DELTA_CHI2, MAX_CHI2_PER_DOF,
                                         MechanicsCalibration, calibrate_mechanics,
                                         tip_change_mm)
from whiskercal.mechfit.joint_lookup import JointLookup
from whiskercal.model.calibrate import Calibration, contact_mask
from whiskercal.model.errors import ModelError
from whiskercal.model.lookup import LookupReport

# The tip-error goal (RMS, mm): a tip model's estimate, or the (Y, Z) table's, above it is warned
# as not meeting it.
WARN_TIP_ERROR_MM = 0.25
# the tip model's name when the (Y, Z) joint fit's z lookup ships (``adopt_joint_lookup``)
JOINT_TIP_MODEL = "mechanics-yz"
# an estimate above this (mm RMS, twice the goal: the estimate runs high) with no trusted table
# beside it is refused by ``auto`` (``refuse_unless_resolved``)
REFUSE_TIP_ERROR_MM = 2.0 * WARN_TIP_ERROR_MM
# what a calibration that cannot be estimated should change, in the refusal's words
WHAT_TO_CHANGE = ("Change the plan: the full plan (collect --plan full) where a shorter one was "
                  "taken, the tip sweep on (collect's [sweep] enabled = true), with "
                  "more angles or offsets nearer the tip ([sweep] angles, offsets_mm), or a reach "
                  "band closer to the tip ([grid] reach_max_mm); check the build's trace length "
                  "([rig] trace_length_mm); or ship a model knowingly with --tip-model level-set "
                  "or --tip-model mechanics")
# what a calibration whose only reading is Y alone, millimetres off on realistic contacts,
# should change, in the refusal's words
WHAT_TO_CHANGE_FOR_Z = ("Change the build so that its magnet moves further for a tip load (a "
                        "softer root, the magnet nearer the chip), or read it with less noise "
                        "(collect's [sensor] osr or filt), so that Y and Z tell its loads apart; "
                        "or ship the z lookup knowingly, for square tip contacts only, with "
                        "--tip-model mechanics or --tip-model level-set")
# how the warning that the mechanics stands in for an untraceable level set begins
UNTRACEABLE_WARNING = "the level set cannot be traced"


@dataclass
class TipModelChoice:
    """The tip model chosen, its estimated RMS tip error (mm; NaN: not estimable), the metrics
    the artifact records about it, and warnings."""

    name: str
    estimated_tip_error_mm: float
    metrics: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    # the mechanics fitted to the grid, whichever model ships (the shaft surface uses it)
    mechanics: MechanicsCalibration | None = None
    # neither the level set nor the Y fit can be trusted: raised by ``refuse_unless_resolved``
    # unless the (Y, Z) joint fit's lookup stands in (``adopt_joint_lookup``)
    refusal: ModelError | None = None


def _mechanics(raw, length_mm: float, samples: int):
    """The mechanics calibration of the grid's contacts, or the reason there is none.

    Every contact counts, the near-root ones the level set's surface leaves out included: the
    model has no trouble there, and they carry most of the root's compliance.
    """
    used = contact_mask(raw.z_uT, raw.z_sem_uT)
    noise = float(np.median(raw.z_sem_uT[used])) if used.any() else math.nan
    sweep = np.asarray(getattr(raw, "sweep", np.zeros(len(used), bool)), bool)
    try:
        return calibrate_mechanics(raw.rod_center_mm[used], raw.z_uT[used], raw.rod_radius_mm,
                                   length_mm, noise, samples, sweep=sweep[used]), ""
    except UsageError as error:
        return None, str(error).rstrip(".")


def _mechanics_metrics(mechanics: MechanicsCalibration) -> dict:
    suspension = mechanics.fit.suspension
    low, high = mechanics.plausible_ratios()
    return {"stiffness_ratio": mechanics.stiffness_ratio, "stub_mm": suspension.stub_mm,
            "translational_compliance": suspension.trans_compliance,
            "chi2_per_dof": mechanics.chi2_per_dof,
            "plausible_stiffness_ratio": [low, high],
            "estimated_tip_error_mm": _finite_or_nan(mechanics.estimated_tip_error_mm),
            "local_estimated_tip_error_mm": _finite_or_nan(mechanics.local_tip_error_mm),
            "pose_map_degree": int(mechanics.fit.pose_map.exponents.sum(axis=1).max()),
            "pose_map_shift_order": int(mechanics.fit.pose_map.exponents[:, 1:].sum(axis=1).max()),
            "tip_sweep_points": int(mechanics.sweep_points),
            "profile": [p.row() for p in mechanics.profile]}


def _finite_or_nan(value: float) -> float:
    return value if math.isfinite(value) else math.nan


def _level_set_estimate(calibration: Calibration, mechanics: MechanicsCalibration | None) -> float:
    if calibration.lookup is None or mechanics is None \
            or not math.isfinite(mechanics.estimated_tip_error_mm):
        return math.nan
    distance = tip_change_mm(calibration.lookup, mechanics.lookup)  # over the level set's range
    return _finite_or_nan(math.hypot(distance, mechanics.estimated_tip_error_mm))


def _use_mechanics(calibration: Calibration, mechanics: MechanicsCalibration) -> Calibration:
    """The calibration with the mechanics' lookup as its tip model (no level-set extrapolation)."""
    return _use_lookup(calibration, mechanics.lookup)


def _use_lookup(calibration: Calibration, lookup) -> Calibration:
    """The calibration with a model's z lookup as its tip model."""
    report = calibration.lookup_report or LookupReport(
        lookup.kind, math.nan, np.full(2, math.nan), {}, np.zeros(0), np.zeros((0, 2)))
    report = replace(report, kind=lookup.kind, knot_extension_mm=None)
    return replace(calibration, lookup=lookup, lookup_report=report, extrapolated=False,
                   trusted_z_uT=(lookup.z_min_uT, lookup.z_max_uT))


def _pick(requested: str, mechanics, mechanics_error: float, level_set_error: float) -> str:
    if requested != "auto":
        return requested
    if mechanics is None or not math.isfinite(mechanics_error):
        return "level-set"
    return "mechanics" if not mechanics_error > level_set_error else "level-set"


def choose_tip_model(raw, calibration: Calibration, requested: str, length_mm: float,
                     samples: int, untraceable: ModelError | None = None
                     ) -> tuple[Calibration, TipModelChoice]:
    """The calibration with the tip model ``requested`` (or chosen by ``auto``), and the choice.

    ``untraceable``: why the level set could not be traced (``calibration`` then has no
    lookup); an identified mechanics model ships instead, whatever was requested.

    Raises
    ------
    UsageError
        ``mechanics`` was requested and the mechanics cannot be fitted to this grid, or the
        level set is untraceable and the mechanics is not identified.
    """
    if requested not in TIP_MODELS:
        raise UsageError(f"tip model must be one of {', '.join(TIP_MODELS)}, not {requested!r}")
    mechanics, why_not = _mechanics(raw, length_mm, samples)
    if mechanics is None and requested == "mechanics":
        raise UsageError(f"the mechanics-informed tip model cannot be fitted: {why_not}")
    mech_error = mechanics.estimated_tip_error_mm if mechanics is not None else math.inf
    if untraceable is not None and not math.isfinite(mech_error):
        return calibration, _refused(untraceable, why_not, mechanics)
    level_error = _level_set_estimate(calibration, mechanics)
    name = "mechanics" if untraceable is not None else \
        _pick(requested, mechanics, mech_error, level_error)
    estimate = _finite_or_nan(mech_error) if name == "mechanics" else level_error
    metrics = {"tip_model": name, "estimated_tip_error_mm": estimate,
               "level_set_estimated_tip_error_mm": level_error}
    if mechanics is not None:
        metrics["mechanics"] = _mechanics_metrics(mechanics)
        metrics["one_to_one_z_uT"] = list(mechanics.one_to_one_z_uT)
        calibration = _use_mechanics(calibration, mechanics) if name == "mechanics" else calibration
    choice = TipModelChoice(name, estimate, metrics, mechanics=mechanics)
    choice.warnings = _warnings(choice, mechanics, why_not)
    if untraceable is not None:
        choice.warnings.insert(0, f"{UNTRACEABLE_WARNING} ({untraceable}): the "
                                  "mechanics-informed tip model ships instead")
    return calibration, choice


def _refused(untraceable: ModelError, why_not: str, mechanics) -> TipModelChoice:
    """The choice when the level set cannot be traced and the Y fit is not identified."""
    why = why_not or "the grid does not identify the suspension"
    refusal = type(untraceable)(f"{untraceable}; nor can the mechanics-informed model stand "
                                f"in: {why}")
    choice = TipModelChoice("none", math.inf, {"tip_model": "none"}, mechanics=mechanics,
                            refusal=refusal)
    cause = f"the Y fit cannot be made ({why_not})" if why_not else \
        "the Y fit does not identify the suspension"
    choice.warnings = [f"{UNTRACEABLE_WARNING} ({untraceable}) and {cause}: the (Y, Z) joint "
                       "fit's tip model ships instead"]
    return choice


def refuse_unless_resolved(choice: TipModelChoice, requested: str = "auto",
                           trusted_table: bool = False,
                           y_alone_mm: float = math.nan) -> TipModelChoice:
    """``choice``, unless it is a refusal no joint fit stood in for, or (with ``auto``) with no
    trusted (Y, Z) table or loads beside it (``trusted_table``), a z lookup whose estimated tip
    error is unknown or above :data:`REFUSE_TIP_ERROR_MM`, or one that reading Y alone is
    estimated to put further off than that on the table's loads (``y_alone_mm``: contacts with
    friction or at a slant): then raise.

    Such an artifact may be off by millimetres with nothing to tell, and a lab would find out
    only at the robot; an explicit ``--tip-model`` ships it knowingly, with its warning. Where
    a trusted table ships, a robot streaming Z reads that, and the z lookup's estimate is
    warned for one streaming Y only.
    """
    if choice.refusal is not None:
        raise choice.refusal
    if requested != "auto" or trusted_table:
        return choice
    estimate = choice.estimated_tip_error_mm
    if not estimate <= REFUSE_TIP_ERROR_MM:
        raise ModelError(f"{_unvouched(choice)}. {WHAT_TO_CHANGE}")
    if y_alone_mm > REFUSE_TIP_ERROR_MM:
        raise ModelError(f"no (Y, Z) table or loads to follow could be trusted, and reading Y "
                         f"alone is estimated to err {y_alone_mm:.1f} mm RMS on the table's "
                         f"loads (contacts with friction or at a slant), over "
                         f"{REFUSE_TIP_ERROR_MM} mm. {WHAT_TO_CHANGE_FOR_Z}")
    return choice


def _unvouched(choice: TipModelChoice) -> str:
    """Why a z lookup with no estimate, or one over the refusal's bound, is not shipped."""
    estimate = choice.estimated_tip_error_mm
    if math.isfinite(estimate):
        return (f"the best tip model ({choice.name}) is estimated to err {estimate:.2f} mm RMS, "
                f"over {REFUSE_TIP_ERROR_MM} mm, and no (Y, Z) table could be trusted")
    return (f"no tip model's error can be estimated from this grid "
            f"({'; '.join(choice.warnings) or 'no estimate'})")


def adopt_joint_lookup(calibration: Calibration, choice: TipModelChoice,
                       joint: JointLookup | None, requested: str
                       ) -> tuple[Calibration, TipModelChoice]:
    """With ``auto``, the (Y, Z) joint fit's z lookup (from ``fit.field_table``) as the tip
    model when its estimated error is below the chosen model's (or that one has none); else
    both unchanged. Whatever was requested, it stands in for a refused choice (``refusal``)
    when it has an estimate.

    Z pins the suspension down where Y alone leaves it loose: on the family with the tip sweep
    its lookups lie far closer to the true tips (docs/research/2026-11-29-calibration.md).
    """
    current = choice.estimated_tip_error_mm
    stands_in = choice.refusal is not None or requested == "auto"
    if not stands_in or joint is None or not math.isfinite(joint.estimated_tip_error_mm) \
            or joint.estimated_tip_error_mm >= current:
        return calibration, choice
    estimate = joint.estimated_tip_error_mm
    metrics = {**choice.metrics, "tip_model": JOINT_TIP_MODEL, "estimated_tip_error_mm": estimate,
               "replaced_tip_model": choice.name, "replaced_estimated_tip_error_mm": current}
    adopted = TipModelChoice(JOINT_TIP_MODEL, estimate, metrics, mechanics=choice.mechanics)
    kept = [w for w in choice.warnings if w.startswith(UNTRACEABLE_WARNING)]
    adopted.warnings = kept + _estimate_warning(adopted)
    return _use_lookup(calibration, joint.lookup), adopted


def _estimate_warning(choice: TipModelChoice) -> list[str]:
    estimate = choice.estimated_tip_error_mm
    if estimate > WARN_TIP_ERROR_MM:
        return [f"estimated tip error {estimate:.2f} mm RMS ({choice.name}, frictionless tip "
                f"contact) exceeds {WARN_TIP_ERROR_MM} mm: treat tips as this uncertain"]
    return []


def _warnings(choice: TipModelChoice, mechanics, why_not: str) -> list[str]:
    estimate = choice.estimated_tip_error_mm
    if math.isfinite(estimate):
        return _estimate_warning(choice)
    if mechanics is None:
        return [f"the tip error cannot be estimated: the mechanics-informed model was {why_not}"]
    if mechanics.chi2_per_dof > MAX_CHI2_PER_DOF:
        return [f"the tip error cannot be estimated: the suspension model leaves "
                f"{math.sqrt(mechanics.chi2_per_dof):.1f}x the noise unexplained (a suspension "
                "outside the model, a root shifting further than the pose map follows without "
                "a tip sweep, or a wrong trace length?); tips may be off by millimetres"]
    if not math.isfinite(mechanics.local_tip_error_mm):
        return ["the tip error cannot be estimated: the fitted tip curve does not hold its z "
                "range under the fit's own uncertainty (z folds near its end); tips may be off "
                "by millimetres"]
    low, high = mechanics.plausible_ratios()
    if high > low:
        return [f"the tip error cannot be estimated: the grid does not pin the suspension down "
                f"(k_theta*L/EI from {low:.3g} to {high:.3g} fits it equally well); tips may be "
                "off by millimetres"]
    lost = lost_tip_curves(mechanics)
    return [f"the tip error cannot be estimated: a suspension with k_theta*L/EI {lost} fits the "
            f"grid nearly as well as the best ({low:.3g}) and its tip curve does not reach the "
            "grid's z range; tips may be off by millimetres"]


def lost_tip_curves(mechanics: MechanicsCalibration) -> str:
    """The profiled k_θ·L/EI whose tip curve does not cover the grid's z range, within the
    misfit the estimate weighs (``identify.IGNORED_DELTA_CHI2``), with their Δχ²."""
    lost = [p for p in mechanics.profile
            if not math.isfinite(p.tip_change_mm) and p.delta_chi2 <= IGNORED_DELTA_CHI2]
    return ", ".join(f"{p.stiffness_ratio:.3g} (delta chi2 {p.delta_chi2:.0f})" for p in lost) \
        or "none profiled"
