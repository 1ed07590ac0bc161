"""The shaft localizer over a flat-plane study's contacts on the shaft (tangential contact).

The plane study (``whiskercal optimal-depth``) labels the samples where the twin's whisker lies
along the plane (``tangential``: the shaft meets the plane before the tip) but localizes only
tips. Here every trial with such samples is fed, sample by sample from its start, through a
fresh shaft tracker (``runtime_shaft``) as a robot would: z (the Y axis minus the trial's static
reading) and the plane's position relative to the sensor. A flat plane that slides along itself
carries no contact point with it: only its motion along its own normal moves the contact, so the
position fed is the plane's recorded line point projected onto its normal. The estimate is
judged against the twin's true contact point on the samples truly on the shaft (tangential or
shaft contact whose noise-free |z| passes the tracker's onset).

A tangential contact is a line contact (the shaft lies on the plane from the contact point to
the tip), not the rod's point contact the calibrated surface describes; the numbers say how far
the point-contact model carries, docs/shaft.md.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from whiskercal.artifacts.plane_study import read_study
from whiskercal.errors import ArtifactError
from whiskercal.rig.overload import SENSOR_AXIS_Y
from whiskercal.runtime_shaft import KIND_SHAFT, KIND_TIP, ONSET_UT, shaft_tracker

SHAFT_KINDS = ("tangential", "shaft")


@dataclass
class PlanePhaseRow:
    """One plane-study trial's shaft contacts through the shaft tracker (mm; shares of the
    samples truly on the shaft; NaN where there is nothing to measure). ``rough_median_error_mm``
    is the error of the rough contact point the kind is decided from, given even while the
    estimate is withheld."""

    depth_mm: float
    samples_on_shaft: int
    called_shaft: float
    called_tip: float
    localized_share: float
    median_error_mm: float
    p90_error_mm: float
    rough_median_error_mm: float

    def as_dict(self) -> dict:
        """The JSON form."""
        return asdict(self)


def _fed(study, trial) -> tuple[np.ndarray, np.ndarray]:
    """z (µT) and the plane's position along its normal (mm, whisker frame) per sample."""
    static = np.asarray(trial.attrs.get("static_field_uT", study.header["baseline_field_uT"]))
    z = trial.stream["field_uT"][:, SENSOR_AXIS_Y] - float(static[SENSOR_AXIS_Y])
    point = np.asarray(trial.plane["point_mm"], float)
    normal = np.asarray(trial.plane["normal"], float)
    along = np.sum(point * normal, axis=1)
    return z, along[:, None] * normal


def track_plane_trial(study, trial, calibration) -> PlanePhaseRow:
    """Feed one plane-study trial through a fresh shaft tracker and judge its shaft samples."""
    z, position = _fed(study, trial)
    tracker = shaft_tracker(calibration)
    n = len(z)
    estimate, rough = np.full((n, 2), np.nan), np.full((n, 2), np.nan)
    kind = np.full(n, "free", dtype="U10")
    for i in range(n):
        state = tracker.update(float(z[i]), position[i])
        if state.contact:
            kind[i] = state.kind
            estimate[i] = state.localizer.contact_mm
            point = tracker.localizer.rough()
            rough[i] = point[0] if point is not None else np.nan
    truth = trial.truth
    judged = np.isin(np.asarray(truth["kind"]).astype(str), SHAFT_KINDS) \
        & (np.abs(np.asarray(truth["z_uT"], float)) > ONSET_UT)
    true_mm = np.asarray(truth["contact_mm"], float)
    error = np.hypot(*(estimate - true_mm).T)[judged]
    rough_error = np.hypot(*(rough - true_mm).T)[judged]
    localized = np.isfinite(error)
    count = int(judged.sum())
    share = (lambda mask: float(np.mean(mask)) if count else np.nan)
    return PlanePhaseRow(
        float(trial.depth_mm), count, share(kind[judged] == KIND_SHAFT),
        share(kind[judged] == KIND_TIP), share(localized),
        float(np.median(error[localized])) if localized.any() else np.nan,
        float(np.percentile(error[localized], 90)) if localized.any() else np.nan,
        float(np.nanmedian(rough_error)) if np.isfinite(rough_error).any() else np.nan)


def plane_phases(study_path, calibration) -> list[PlanePhaseRow]:
    """Every trial of a plane study with samples truly on the shaft, through the shaft tracker.

    Raises
    ------
    ArtifactError
        The study has no twin truth (a real rig's study cannot be judged).
    """
    study = read_study(study_path)
    if any(trial.truth is None for trial in study.trials):
        raise ArtifactError(f"{study_path}: no twin truth; the shaft phases cannot be judged")
    rows = []
    for trial in study.trials:
        kinds = np.asarray(trial.truth["kind"]).astype(str)
        if np.isin(kinds, SHAFT_KINDS).any():
            rows.append(track_plane_trial(study, trial, calibration))
    return rows
