"""Whether the files a command combines belong together: one sensor, one plan, the recorded inputs.

A report that puts a raw grid or a study beside a calibration, or a study report that writes a
target into an artifact, is only true of one sensor when the files were made together. Three
things say so, each recorded when the file was written:

- the **sensor id** every whiskercal file carries (``sensor_id``);
- the **plan**: the whisker's reach a study was planned for (``[geometry] tip_reach_mm``) and
  the trace length a raw grid was collected for (``[rig] trace_length_mm``) are the arc length
  the calibration traces (``trace_length_mm``);
- the **fingerprints**: a calibration records the SHA-256 of the raw grid it was fitted from
  (``inputs_sha256.raw_grid``) and, with a target, of the study that chose it
  (``target.study_sha256``); any other file in their place is another file.

A mismatch is refused with one line, or with ``allow`` returned as a warning for the caller to
show (``--allow-other-sensor``). A fingerprint a file does not record (an older artifact, or the
all-zero placeholder of a target written by hand) is not compared.
"""

from __future__ import annotations

import math
from pathlib import Path

from whiskercal.artifacts import plane_study, raw_grid
from whiskercal.artifacts.h5io import (as_text, check_schema, open_h5, other_sensor,
                                       read_json_attr, sha256_file)
from whiskercal.errors import UsageError

# the trace length and a study's reach are one measured arc length, written to a tenth of a mm or
# so; another build's differs by millimetres
PLAN_TOLERANCE_MM = 0.5
NO_FINGERPRINT = ("", "0" * 64)


def _calibration_facts(cal_path) -> dict:
    """What a calibration records of the files it came from."""
    with open_h5(cal_path) as handle:
        inputs = read_json_attr(handle, "inputs_sha256", {}) or {}
        trace = handle.get("trace")
        target = handle.get("target")
        return {"sensor_id": as_text(handle.attrs.get("sensor_id", "")),
                "raw_sha256": str(inputs.get("raw_grid", "")),
                "study_sha256": as_text(target.attrs.get("study_sha256", "")) if target else "",
                "trace_length_mm": _number(trace.attrs.get("trace_length_mm")) if trace else None}


def _number(value) -> float | None:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


SCHEMAS = {"rig": (raw_grid.SCHEMA, raw_grid.SUPPORTED_MAJOR),
           "geometry": (plane_study.SCHEMA, plane_study.SUPPORTED_MAJOR)}


def _planned_reach_mm(path, table: str, key: str) -> float | None:
    """The reach a raw grid (``table`` "rig") or a study ("geometry") was planned for; a file of
    another kind is refused here, before it is compared."""
    with open_h5(path) as handle:
        check_schema(handle, *SCHEMAS[table], path)
        config = read_json_attr(handle, "config", {}) or {}
    section = config.get(table) if isinstance(config, dict) else None
    return _number(section.get(key)) if isinstance(section, dict) else None


def _plan_mismatch(path, what: str, reach_mm: float | None, facts: dict) -> str | None:
    traced = facts["trace_length_mm"]
    if reach_mm is None or traced is None or abs(reach_mm - traced) <= PLAN_TOLERANCE_MM:
        return None
    return (f"{what} {path} was planned for a whisker of {reach_mm:g} mm to its tip, the "
            f"calibration traces {traced:g} mm")


def _fingerprint_mismatch(path, what: str, recorded: str, fitted: str) -> str | None:
    if recorded in NO_FINGERPRINT or sha256_file(path) == recorded:
        return None
    return f"{what} {path} is not the one the calibration was {fitted} (its SHA-256 differs)"


def raw_grid_mismatches(cal_path, raw_path, facts: dict | None = None) -> list[str]:
    """Why ``raw_path`` is not the raw grid of the calibration ``cal_path`` (empty: it is)."""
    facts = facts or _calibration_facts(cal_path)
    reach_mm = _planned_reach_mm(raw_path, "rig", "trace_length_mm")
    found = [_fingerprint_mismatch(raw_path, "the raw grid", facts["raw_sha256"], "fitted from"),
             _plan_mismatch(raw_path, "the raw grid", reach_mm, facts)]
    return [reason for reason in found if reason]


def study_mismatches(cal_path, study_path, facts: dict | None = None,
                     target_from_it: bool = True) -> list[str]:
    """Why ``study_path`` is not a study of the calibration ``cal_path``'s build: its plan, and
    with ``target_from_it`` the study the artifact's target was chosen by."""
    facts = facts or _calibration_facts(cal_path)
    found = [_plan_mismatch(study_path, "the study",
                            _planned_reach_mm(study_path, "geometry", "tip_reach_mm"), facts)]
    if target_from_it:
        found.append(_fingerprint_mismatch(study_path, "the study", facts["study_sha256"],
                                           "given its target by"))
    return [reason for reason in found if reason]


def _refused_or_warned(reasons: list[str], allow: bool) -> list[str]:
    if reasons and not allow:
        raise UsageError(f"{reasons[0]}: its results would not be this sensor's (pass "
                         "--allow-other-sensor to use it anyway)")
    return reasons


def check_report_inputs(cal_path, raw_path=None, study_path=None, allow: bool = False) -> list[str]:
    """Refuse a raw grid or a study that does not belong with the calibration (another sensor,
    plan or file, see the module); with ``allow``, return the warnings instead."""
    facts = _calibration_facts(cal_path)
    reasons = []
    for path, what, more in ((raw_path, "the raw grid", raw_grid_mismatches),
                             (study_path, "the study", study_mismatches)):
        if path is None:
            continue
        plan_and_file = more(cal_path, path, facts)  # checks its schema first
        sensor = other_sensor(facts["sensor_id"], path, what, allow=True)
        reasons += ([sensor] if sensor else []) + plan_and_file
    return _refused_or_warned(reasons, allow)


def check_study_for_target(cal_path, study_path, allow: bool = False) -> list[str]:
    """Refuse a study of another sensor or plan than the calibration it is to write a target
    into (the artifact's earlier target may come from any study); with ``allow``, the warnings."""
    facts = _calibration_facts(cal_path)
    plan = study_mismatches(cal_path, study_path, facts, target_from_it=False)
    sensor = other_sensor(facts["sensor_id"], study_path, "the study", allow=True)
    reasons = ([sensor] if sensor else []) + plan
    return _refused_or_warned(reasons, allow)
