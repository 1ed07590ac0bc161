"""The study's report: per-trial table, failing trials, the chosen target, figures, new artifact.

``build_report`` reads a study file and a calibration artifact, localizes every trial's slide
through the calibration's runtime, analyses it (whiskercal.study.analysis), chooses the target
(whiskercal.study.target) and, when asked, writes the figures and the artifact with the target.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from whiskercal.artifacts.plane_study import (PHASE_APPROACH, PHASE_SLIDE, Study, TrialRecord,
                                              read_study)
from whiskercal.errors import ArtifactError
from whiskercal.study.analysis import Criteria, TrialMetrics, TrialSeries, analyse_study
from whiskercal.study.config import PlaneGeometry
from whiskercal.study.localize import Countermeasures, Estimates, track
from whiskercal.rig.overload import SENSOR_AXIS_Y

SENSOR_AXIS_Z = 2
from whiskercal.study.recorder import measured_positions_mm, stage_position_per_sample
from whiskercal.study.target import TIE_MM, NoTargetError, TargetChoice, choose_target


class IncompleteStudyError(ArtifactError):
    """The study file lacks planned trials."""


@dataclass
class StudyReport:
    """Everything the report found; ``choice`` is None when no depth qualifies (``no_target`` says why)."""

    study: Study
    rows: list[TrialMetrics]
    series: list[TrialSeries]
    unmapped: dict[float, int]
    choice: TargetChoice | None = None
    no_target: str | None = None
    artifact_out: Path | None = None
    figures: list[Path] = field(default_factory=list)

    def as_dict(self) -> dict:
        """The per-trial table and the choice, JSON-able."""
        rows = []
        for row in self.rows:
            entry = row.as_dict()
            entry.pop("slip_indices")
            entry["unmapped_samples"] = self.unmapped.get(row.depth_mm, 0)
            rows.append(entry)
        passing = [r for r in self.rows if not r.failing]
        return {"study": str(self.study.path), "study_sha256": self.study.sha256,
                "trials": rows, "failing_depths_mm": [r.depth_mm for r in self.rows if r.failing],
                "passing_mean_filtered_mm": (float(np.mean([r.filtered_mean_mm for r in passing]))
                                             if passing else None),
                "choice": self.choice.as_dict() if self.choice else None,
                "no_target": self.no_target,
                "artifact": str(self.artifact_out) if self.artifact_out else None,
                "figures": [str(path) for path in self.figures]}


def check_complete(study: Study) -> None:
    """Refuse a study that lacks planned trials, naming them and how to finish it."""
    missing = study.missing_depths()
    if missing:
        listed = ", ".join(f"{d:g}" for d in missing)
        raise IncompleteStudyError(
            f"{study.path}: the study lacks the trials at {listed} mm "
            f"({len(study.trials)} of {len(study.trials) + len(missing)} done); finish it with "
            "`whiskercal optimal-depth run --resume` or pass --allow-missing")
    if not study.trials:
        raise IncompleteStudyError(f"{study.path}: the study holds no trials")


def slid_mm(trial: TrialRecord) -> float:
    """How far the stage moved during the slide (mm), from its status reports."""
    sliding = measured_positions_mm(trial.stage)[trial.stage["phase"] == PHASE_SLIDE]
    if sliding.shape[0] < 2:
        return 0.0
    return float(np.max(np.linalg.norm(sliding - sliding[0], axis=1)))


def trial_series(study: Study, trial: TrialRecord, calibration, threshold_uT: float,
                 settle_mm: float = Criteria.settle_mm,
                 countermeasures: Countermeasures = Countermeasures()) -> tuple[TrialSeries, int]:
    """The slide of one trial, localized through ``calibration``; and its unmapped sample count.

    The push-in's depth and z go along for the kink test; samples within ``settle_mm`` of
    the slide's start are marked unsteady. With ``countermeasures`` the tracker reads the
    trial's stream from its start, the stage at rest out of contact (a re-zeroed rest needs
    it), and the slide's estimates are kept; without, it reads the slide alone.
    """
    phase = trial.stream["phase"]
    slide = phase == PHASE_SLIDE
    static = np.asarray(trial.attrs.get("static_field_uT", study.header["baseline_field_uT"]),
                        float)
    z_all = trial.stream["field_uT"][:, SENSOR_AXIS_Y] - static[SENSOR_AXIS_Y]
    # the chip's Z axis, for an artifact that carries a (Y, Z) table (runtime.Tracker.update)
    axial_all = trial.stream["field_uT"][:, SENSOR_AXIS_Z] - static[SENSOR_AXIS_Z]
    stage_mm = stage_position_per_sample(trial.stage, phase.size)
    geometry = PlaneGeometry.from_config(study.config)
    approach = phase == PHASE_APPROACH
    approach_depth = geometry.depth_of_stage_mm(stage_mm[approach],
                                                study.header["first_contact_stage_mm"])
    estimates = _slide_estimates(calibration, z_all, axial_all, slide, countermeasures)
    along = np.linalg.norm(stage_mm[slide] - stage_mm[slide][:1], axis=1) if slide.any() else np.zeros(0)
    truth = trial.truth
    series = TrialSeries(
        depth_mm=trial.depth_mm, t_s=trial.stream["t_s"][slide], z_uT=z_all[slide],
        contact=np.abs(z_all[slide]) > threshold_uT,
        raw_tip_mm=estimates.raw_tip_mm, filtered_tip_mm=estimates.filtered_tip_mm,
        plane_point_mm=trial.plane["point_mm"][slide], plane_normal=trial.plane["normal"][slide],
        true_tip_mm=truth["tip_mm"][slide] if truth is not None else None,
        true_kind=truth["kind"][slide] if truth is not None else None,
        slid_mm=slid_mm(trial), planned_travel_mm=float(trial.attrs.get("travel_mm", np.nan)),
        steady=along >= settle_mm, approach_depth_mm=approach_depth, approach_z_uT=z_all[approach])
    return series, estimates.unmapped


def _slide_estimates(calibration, z_uT, axial_uT, slide, countermeasures) -> Estimates:
    """The tracker's estimates over the slide (see ``trial_series``)."""
    if not countermeasures.any or not slide.any():
        return track(calibration, z_uT[slide], axial_uT[slide])
    read = slice(0, int(np.flatnonzero(slide)[-1]) + 1)
    return track(calibration, z_uT[read], axial_uT[read], countermeasures).kept(slide[read])


def _missing_row(depth_mm: float) -> TrialMetrics:
    """A placeholder row for a planned trial that is not in the file: failing, so that the
    target keeps its distance from depths nobody measured."""
    nan = float("nan")
    return TrialMetrics(depth_mm=depth_mm, n_samples=0, contact_fraction=nan, median_z_uT=nan,
                        raw_mean_mm=nan, raw_std_mm=nan, filtered_mean_mm=nan, filtered_std_mm=nan,
                        off_plane_fraction=nan, n_slips=0, failing=True,
                        reasons=["missing from the study file"])


def build_report(study_path: str | Path, calibration, criteria: Criteria = Criteria(),
                 margin_weight_mm: float = 0.1, allow_missing: bool = False,
                 tie_mm: float = TIE_MM,
                 countermeasures: Countermeasures = Countermeasures()) -> StudyReport:
    """Analyse a study file with a loaded calibration and choose the target.

    Parameters
    ----------
    study_path
        The study file (``whiskercal optimal-depth run``).
    calibration
        A loaded calibration (``whiskercal.runtime.load``).
    criteria
        Thresholds of slips, tangential contact and failure.
    margin_weight_mm
        The target rule's margin weight (see whiskercal.study.target).
    allow_missing
        Analyse a study that lacks planned trials instead of refusing it.
    tie_mm
        Scores within this of the lowest tie; the shallowest tied depth wins.
    countermeasures
        What the tracker does against drift and creep (``study.localize``; none by default).
    """
    study = read_study(study_path)
    if not allow_missing or not study.trials:
        check_complete(study)
    threshold = float(study.config.get("contact", {}).get("threshold_uT", 300.0))
    series, unmapped = [], {}
    for trial in study.trials:
        one, count = trial_series(study, trial, calibration, threshold, criteria.settle_mm,
                                  countermeasures)
        series.append(one)
        unmapped[trial.depth_mm] = count
    rows = analyse_study(series, criteria)
    if allow_missing:
        rows = sorted(rows + [_missing_row(depth) for depth in study.missing_depths()],
                      key=lambda row: row.depth_mm)
    report = StudyReport(study=study, rows=rows, series=sorted(series, key=lambda s: s.depth_mm),
                         unmapped=unmapped)
    try:
        report.choice = choose_target(rows, margin_weight_mm, tie_mm)
    except NoTargetError as error:
        report.no_target = str(error)
    return report
