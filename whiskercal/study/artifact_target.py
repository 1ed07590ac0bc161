"""Writing the chosen target into a new version of the calibration artifact.

The artifact is never changed in place: ``whiskercal.artifacts.calibration.write_with_target``
copies it, adds the group ``/target`` and bumps the schema's minor version (docs/formats.md,
"Calibration artifact with a target"). ``whiskercal.runtime`` exposes the value as
``target_z_uT``.
"""

from __future__ import annotations

from pathlib import Path

from whiskercal.artifacts.calibration import Target, write_with_target
from whiskercal.study.target import TargetChoice


def target_artifact_path(calibration_path: str | Path, out_dir: str | Path) -> Path:
    """Default name of the new artifact: ``DIR/<name>-target.h5``."""
    calibration_path = Path(calibration_path)
    return Path(out_dir) / f"{calibration_path.stem}-target{calibration_path.suffix or '.h5'}"


def write_target(calibration_path: str | Path, out_path: str | Path, choice: TargetChoice,
                 study_sha256: str) -> Path:
    """Copy the calibration artifact to ``out_path`` with the study's choice as its target.

    Raises
    ------
    UsageError
        When ``out_path`` is the input artifact itself (an artifact version is never rewritten).
    ArtifactError
        When the input cannot be read as HDF5.
    """
    target = Target(z_uT=float(choice.z_uT), depth_mm=float(choice.depth_mm), rule=choice.rule,
                    reason=choice.reason, study_sha256=study_sha256)
    return write_with_target(calibration_path, out_path, target)
