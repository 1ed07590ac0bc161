"""The shaft localizer judged on a shaft study: per-trial errors against the twin's true contact.

Each trial's stream goes through a fresh ``whiskercal.runtime_shaft`` tracker, sample by sample,
exactly as a robot would feed it (z and the rod's position from the stage's reports). Errors are
distances (mm) from the estimated contact point to the twin's true contact point at the same
sample; travel is the path length the rod moved since the tracker's contact began.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from whiskercal.artifacts.shaft_study import ShaftTrial, read_shaft_study
from whiskercal.errors import ArtifactError
from whiskercal.runtime_shaft import KIND_UNKNOWN, ONSET_UT, shaft_tracker

SETTLED_TRAVEL_MM = 5.0
"""Travel since contact (mm) after which ``median_error_mm`` is taken."""
GOOD_MM = 1.0
GROSS_MM = 2.0
"""An estimate this far (mm) from the true contact is a wrong one, not an inaccurate one."""


@dataclass
class TrialSeries:
    """Per-sample output of the tracker on one trial (mm; NaN where no estimate)."""

    name: str
    radial_mm: float
    estimate_mm: np.ndarray
    true_mm: np.ndarray
    error_mm: np.ndarray
    travel_mm: np.ndarray
    kind: np.ndarray
    true_kind: np.ndarray
    true_z_uT: np.ndarray
    seconds_per_sample: float


@dataclass
class TrialRow:
    """One trial's results (mm, s); NaN where there is nothing to measure."""

    name: str
    radial_mm: float
    approach_deg: float
    samples_in_contact: int
    median_error_mm: float
    final_error_mm: float
    travel_to_1mm: float
    localized_share_after_5mm: float
    gross_error_share: float
    kind_accuracy: float
    kind_accuracy_all: float
    kind_decided_share: float
    ms_per_sample: float


@dataclass
class ShaftReport:
    """Every trial's row, and the figures written."""

    study: str
    sensor_id: str
    rows: list[TrialRow]
    series: list[TrialSeries] = field(default_factory=list, repr=False)
    figures: list[str] = field(default_factory=list)

    def as_dict(self) -> dict:
        """The JSON form (``shaft-study report --json``)."""
        return {"study": self.study, "sensor_id": self.sensor_id,
                "trials": [asdict(row) for row in self.rows], "figures": self.figures}


def track_trial(calibration, trial: ShaftTrial, tracker=None) -> TrialSeries:
    """Run a fresh shaft tracker (of ``calibration``, unless one is given) over one trial's
    stream and line it up with the truth."""
    if trial.truth is None:
        raise ArtifactError(f"trial {trial.name} has no twin truth: the report needs a twin run")
    tracker = tracker if tracker is not None else shaft_tracker(calibration)
    z, position = trial.stream["z_uT"], trial.stream["position_mm"]
    n = len(z)
    estimate, travel = np.full((n, 2), np.nan), np.full(n, np.nan)
    kind = np.full(n, "free", dtype="U10")
    start = time.thread_time()  # this thread's CPU: what a sample costs, whatever shares the core
    for i in range(n):
        state = tracker.update(float(z[i]), position[i])
        if state.contact:
            kind[i] = state.kind
            travel[i] = state.localizer.travel_mm
            estimate[i] = state.localizer.contact_mm
    seconds = (time.thread_time() - start) / max(n, 1)
    true = np.asarray(trial.truth["contact_mm"], float)
    error = np.hypot(*(estimate - true).T)
    return TrialSeries(trial.name, trial.radial_mm, estimate, true, error, travel, kind,
                       np.asarray(trial.truth["kind"]).astype(str),
                       np.asarray(trial.truth["z_true_uT"], float), seconds)


def trial_row(series: TrialSeries, approach_deg: float) -> TrialRow:
    """The per-trial numbers of one tracked trial."""
    contact = np.isfinite(series.travel_mm)
    settled = contact & (series.travel_mm >= SETTLED_TRAVEL_MM)
    localized = np.isfinite(series.error_mm)
    settled_errors = series.error_mm[settled & localized]
    final = series.error_mm[contact & localized]
    return TrialRow(
        name=series.name, radial_mm=series.radial_mm, approach_deg=approach_deg,
        samples_in_contact=int(contact.sum()),
        median_error_mm=float(np.median(settled_errors)) if settled_errors.size else np.nan,
        final_error_mm=float(final[-1]) if final.size else np.nan,
        travel_to_1mm=_travel_to_good(series, contact),
        localized_share_after_5mm=float(localized[settled].mean()) if settled.any() else np.nan,
        gross_error_share=float(np.mean(series.error_mm[contact & localized] > GROSS_MM))
        if final.size else np.nan,
        kind_accuracy=_kind_accuracy(series, detectable=True),
        kind_accuracy_all=_kind_accuracy(series, detectable=False),
        kind_decided_share=float(np.mean(series.kind[contact] != KIND_UNKNOWN)) if contact.any() else np.nan,
        ms_per_sample=series.seconds_per_sample * 1e3)


def _travel_to_good(series: TrialSeries, contact: np.ndarray) -> float:
    """Travel (mm) from which every later sample in contact has an estimate within 1 mm."""
    index = np.flatnonzero(contact)
    if index.size == 0:
        return np.nan
    good = np.isfinite(series.error_mm[index]) & (series.error_mm[index] < GOOD_MM)
    bad = np.flatnonzero(~good)
    if bad.size == 0:
        return float(series.travel_mm[index[0]])
    if bad[-1] == index.size - 1:
        return np.nan
    return float(series.travel_mm[index[bad[-1] + 1]])


def _kind_accuracy(series: TrialSeries, detectable: bool) -> float:
    """Share of samples in true shaft or tip contact whose kind the tracker named rightly (an
    undecided or missed sample counts as wrong); with ``detectable``, only samples whose
    noise-free |z| passes the tracker's contact onset, which no detector sees below."""
    judged = np.isin(series.true_kind, ("shaft", "tip"))
    if detectable:
        judged &= np.abs(series.true_z_uT) > ONSET_UT
    if not judged.any():
        return np.nan
    return float(np.mean(series.kind[judged] == series.true_kind[judged]))


def build_report(study_path: str | Path, calibration) -> ShaftReport:
    """Track every trial of a shaft study with ``calibration`` and tabulate the results."""
    study = read_shaft_study(study_path)
    series = [track_trial(calibration, trial) for trial in study.trials]
    rows = [trial_row(s, float(t.attrs.get("approach_deg", np.nan)))
            for s, t in zip(series, study.trials)]
    order = np.argsort([(row.radial_mm, row.approach_deg) for row in rows], axis=0)[:, 0] \
        if rows else []
    return ShaftReport(str(study_path), study.sensor_id, [rows[i] for i in order],
                       [series[i] for i in order])
