"""What a calibration shipped, in words and units: the part of the report a person reads first.

A calibration artifact holds many numbers; a robot's user needs five answers before any of
them: which tip model the lookup comes from and how far off its tips are estimated to be,
whether the (Y, Z) table (or the loads followed in its place) was written and with what
estimate, the collision threshold and who reads it, and the warnings ``fit`` gave. The evidence
(surface fit, hold-out errors, the twin's truth) follows under names a reader knows.
"""

from __future__ import annotations

import math

from whiskercal.artifacts.calibration import CalibrationData
from whiskercal.fit.contact_threshold import NOISE_FLOOR_SIGMAS, TIP_MOTION_MM

# how each tip model the lookup can come from is said in the report
TIP_MODEL_WORDS = {
    "level-set": "the paper's level set traced on the fitted surface z = f(x, y)",
    "mechanics": "the mechanics-informed model (suspension and elastica fitted to the Y axis)",
    "mechanics-yz": "the mechanics-informed model fitted to the Y and Z axes together",
}
# why the stored collision threshold has its value (``fit.contact_threshold`` sources)
THRESHOLD_SOURCE_WORDS = {
    "paper": "the paper's value",
    "tip motion": f"the build's own: the fitted model reads it where a tip has moved "
                  f"{TIP_MOTION_MM:g} mm",
    "noise floor": f"the build's noise floor ({NOISE_FLOOR_SIGMAS:g} times one sample's Y noise)",
    "given": "given with fit --threshold-uT",
    "paper (no fitted model)": "the paper's value (no fitted model to choose another)",
}
# the evidence rows: metric key, what it is called in the report, its unit
EVIDENCE = (
    ("rmse_uT", "surface fit residual, RMS", "µT"),
    ("cv_rmse_uT", "surface fit residual, cross-validated RMS", "µT"),
    ("r2", "surface fit R²", ""),
    ("condition_number", "surface fit condition number", ""),
    ("lookup_holdout_rmse_mm", "lookup against its own traced tips, hold-out RMS", "mm"),
    ("lookup_vs_truth_rmse_mm", "lookup against the twin's true tips, RMS", "mm"),
    ("lookup_vs_truth_max_mm", "lookup against the twin's true tips, largest", "mm"),
    ("points_used", "grid points fitted", ""),
    ("points_total", "grid points recorded", ""),
)


def _mm(value) -> str:
    value = float(value)
    return f"{value:.3f} mm RMS" if math.isfinite(value) else "not estimated"


def tip_model_line(data: CalibrationData) -> str:
    """Which tip model the z -> tip lookup was made from, and its estimated tip error."""
    name = data.metrics.get("tip_model", "level-set")
    words = TIP_MODEL_WORDS.get(name, name)
    estimate = data.metrics.get("estimated_tip_error_mm", math.nan)
    return f"{name}: {words}; estimated tip error {_mm(estimate)}"


def table_line(data: CalibrationData) -> str:
    """Whether the (Y, Z) -> tip table, or the loads followed in its place, was written."""
    m = data.metrics
    if "field_table_estimated_tip_error_mm" not in m:
        return "not fitted (fit --no-field-table): the runtime reads the z lookup alone"
    estimate = (f"estimated tip error {_mm(m['field_table_estimated_tip_error_mm'])} for one "
                f"reading, {_mm(m.get('field_table_held_estimated_tip_error_mm', math.nan))} "
                "for a held contact")
    if data.field_table is not None:
        return f"written; {estimate}"
    line = f"withheld ({estimate}): the runtime reads the z lookup"
    if data.load_branches is not None:
        line += ("; instead the loads are followed through each contact from rest, estimated "
                 f"tip error {_mm(m.get('load_branches_estimated_tip_error_mm', math.nan))}")
    return line


def threshold_line(data: CalibrationData) -> str:
    """The collision threshold, why it has its value, and who reads it."""
    m = data.metrics
    source = m.get("collision_threshold_source", "given")
    motion = float(m.get("collision_tip_motion_mm", math.nan))
    line = (f"{float(data.collision['threshold_uT']):.0f} µT from the static reading, "
            f"{THRESHOLD_SOURCE_WORDS.get(source, source)}")
    if math.isfinite(motion):
        line += f"; a frictionless tip has moved {motion:.1f} mm when z passes it"
    return (line + ". Stored in the artifact (/collision); the runtime's tracker "
            "(whiskercal.runtime.load(...).tracker()) starts a contact where |z| passes it")


def warnings_lines(data: CalibrationData) -> list[str]:
    """The warnings ``fit`` gave, as it gave them (none: one line saying so)."""
    warnings = [str(w) for w in data.metrics.get("warnings", [])]
    return warnings or ["none"]


def shipped(data: CalibrationData) -> dict[str, str]:
    """The answers the report leads with, by the question they answer."""
    return {"sensor": data.sensor_id, "tip model": tip_model_line(data),
            "(Y, Z) table": table_line(data), "collision threshold": threshold_line(data),
            "deflection target": ("not chosen yet (optimal-depth report sets it)"
                                  if data.target_z_uT is None
                                  else f"{data.target_z_uT:.0f} µT, chosen by the study")}


def evidence(data: CalibrationData) -> dict[str, object]:
    """The fit's evidence under the report's names (with units), in the order above."""
    rows = {}
    for key, name, unit in EVIDENCE:
        if key in data.metrics:
            value = data.metrics[key]
            # R² sits near 1 on any usable fit: six decimals show what a few digits round away
            rows[f"{name} ({unit})" if unit else name] = f"{value:.6f}" if key == "r2" else value
    return rows
