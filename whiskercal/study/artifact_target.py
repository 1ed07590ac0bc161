"""Writing the chosen target into a new version of the calibration artifact.

The artifact is never changed in place: it is copied, the copy gets a group ``/target``
(datasets ``z_uT`` and ``depth_mm``; attributes ``rule``, ``reason``, ``study_sha256``), its
schema's minor version is bumped (a reader of the same major version still loads it), its
``inputs_sha256`` gains the study file and the artifact it was derived from, and the copy is
renamed into place. ``whiskercal.runtime`` exposes the value as ``target_z_uT``.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import h5py

from whiskercal.artifacts import h5io
from whiskercal.errors import ArtifactError, UsageError
from whiskercal.paths import ensure_dir
from whiskercal.study.target import TargetChoice

TARGET_GROUP = "target"


def bump_minor(version: str) -> str:
    """``1.0.0`` -> ``1.1.0``: a new optional part that readers of the same major accept."""
    try:
        major, minor, *_ = (int(part) for part in version.split("."))
    except ValueError:
        raise ArtifactError(f"bad schema_version {version!r} in the calibration artifact") from None
    return f"{major}.{minor + 1}.0"


def target_artifact_path(calibration_path: str | Path, out_dir: str | Path) -> Path:
    """Default name of the new artifact: ``DIR/<name>-target.h5``."""
    calibration_path = Path(calibration_path)
    return Path(out_dir) / f"{calibration_path.stem}-target{calibration_path.suffix or '.h5'}"


def write_target(calibration_path: str | Path, out_path: str | Path, choice: TargetChoice,
                 study_sha256: str) -> Path:
    """Copy the calibration artifact to ``out_path`` with the target added.

    Raises
    ------
    UsageError
        When ``out_path`` is the input artifact itself (an artifact version is never rewritten).
    ArtifactError
        When the input cannot be read as HDF5.
    """
    calibration_path, out_path = Path(calibration_path), Path(out_path)
    if out_path.resolve() == calibration_path.resolve():
        raise UsageError("the artifact with the target must be a new file, not the input artifact")
    ensure_dir(out_path.parent)
    scratch = out_path.with_name(out_path.name + ".partial")
    shutil.copyfile(calibration_path, scratch)
    input_sha = h5io.sha256_file(calibration_path)
    try:
        with h5py.File(scratch, "r+") as handle:
            _add_target(handle, choice, study_sha256, input_sha)
    except OSError as error:
        scratch.unlink(missing_ok=True)
        raise ArtifactError(f"{calibration_path}: cannot write a copy with the target ({error})") from None
    os.replace(scratch, out_path)
    return out_path


def _add_target(handle: h5py.File, choice: TargetChoice, study_sha256: str, input_sha: str) -> None:
    if TARGET_GROUP in handle:
        del handle[TARGET_GROUP]  # a newer study supersedes the target of the copied version
    group = handle.create_group(TARGET_GROUP)
    h5io.write_array(group, "z_uT", float(choice.z_uT), "µT")
    h5io.write_array(group, "depth_mm", float(choice.depth_mm), "mm")
    group.attrs["rule"] = choice.rule
    group.attrs["reason"] = choice.reason
    group.attrs["study_sha256"] = study_sha256
    version = handle.attrs.get("schema_version", "1.0.0")
    version = version.decode() if isinstance(version, bytes) else str(version)
    handle.attrs["schema_version"] = bump_minor(version)
    inputs = h5io.read_json_attr(handle, "inputs_sha256", {}) or {}
    inputs["plane_study"] = study_sha256
    inputs["calibration"] = input_sha
    handle.attrs["inputs_sha256"] = json.dumps(inputs, sort_keys=True)
    handle.attrs["created"] = h5io.now_iso()


def read_target(path: str | Path) -> dict | None:
    """The target stored in an artifact (z_uT, depth_mm, rule, study_sha256), or None."""
    with h5io.open_h5(path) as handle:
        if TARGET_GROUP not in handle:
            return None
        group = handle[TARGET_GROUP]
        return {"z_uT": float(group["z_uT"][()]), "depth_mm": float(group["depth_mm"][()]),
                **{key: str(group.attrs[key]) for key in ("rule", "reason", "study_sha256")}}
