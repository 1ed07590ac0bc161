"""whiskercal's own HDF5 files as recordings: a raw calibration grid's sample stream or a
flat-plane study's trials, each with the static Y reading it recorded before its run."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from whiskercal.errors import ArtifactError
from whiskercal.recording.types import Recording


def read_hdf5_stream(path: str | Path) -> Recording:
    """The Y stream of a whiskercal raw grid or plane study, with its recorded static reading."""
    from whiskercal.artifacts import h5io

    path = Path(path)
    with h5io.open_h5(path) as handle:
        schema = h5io.as_text(handle.attrs.get("schema", ""))
    if schema == "whiskercal.raw_grid":
        return _raw_grid_stream(path)
    if schema == "whiskercal.plane_study":
        return _study_stream(path)
    raise ArtifactError(f"{path}: an HDF5 file of schema {schema or 'none'!r} holds no stream to "
                        "replay (whiskercal.raw_grid or whiskercal.plane_study expected)")


def _raw_grid_stream(path: Path) -> Recording:
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.protocol.sensor_config import SensorConfig

    grid = read_raw_grid(path, stream=True)
    settings = grid.config.get("sensor", {})
    try:
        config = SensorConfig(**{k: int(settings[k]) for k in ("gain", "res") if k in settings})
        lsb_y = float(config.lsb_uT[1])
    except (TypeError, ValueError, IndexError, KeyError) as error:
        raise ArtifactError(f"{path}: bad sensor settings in the config ({error})") from None
    stream = grid.stream
    if stream is None or len(stream) == 0:
        raise ArtifactError(f"{path}: the raw grid holds no raw samples")
    return Recording(np.asarray(stream.t_s, float), stream.counts[:, 1].astype(float) * lsb_y,
                  f"{path} (raw grid stream, Y counts x {lsb_y:g} µT)",
                  float(grid.baseline_before_uT[1]))


def _study_stream(path: Path) -> Recording:
    from whiskercal.artifacts.plane_study import read_study

    study = read_study(path)
    trials = [t for t in study.trials if len(t.stream.get("t_s", ())) > 0]
    if not trials:
        raise ArtifactError(f"{path}: the study holds no trial with samples")
    try:
        t_s = np.concatenate([np.asarray(t.stream["t_s"], float) for t in trials])
        field = np.concatenate([np.asarray(t.stream["field_uT"], float)[:, 1] for t in trials])
        rest = float(np.asarray(study.header["baseline_field_uT"], float)[1])
    except (KeyError, IndexError, ValueError) as error:
        raise ArtifactError(f"{path}: a trial's stream or the baseline is malformed "
                            f"({error})") from None
    return Recording(t_s, field, f"{path} (plane study, {len(trials)} trials, field Y)", rest)
