"""Compact copies of recorded HDF5 files, small enough to keep in git.

The writers of raw grids and studies keep growable, lightly compressed tables (they append while
a run goes). A recorded dataset is final, so it is rewritten once: every array gzip-compressed
(level 9, byte shuffle), which is lossless and readable by any HDF5 tool; and the twin's
ground-truth positions and the plane's per-sample line point stored as float32 (their spacing is
under 1e-5 mm at 100 mm, a thousand times below the smallest error the study measures, and the
golden results are computed from the compact files themselves). Measurements (counts, fields,
times, stage positions) keep their exact values and types. Attributes are copied unchanged.
"""

from __future__ import annotations

import fnmatch
from pathlib import Path

import h5py
import numpy as np

from whiskercal.artifacts.h5io import open_h5, write_whole
from whiskercal.atomic import refuse_input_as_output

# Float64 datasets stored as float32 (twin ground truth and the plane's per-sample line point).
FLOAT32_PATTERNS = ("truth/*/tip_mm", "truth/*/contact_mm", "truth/*/z_uT",
                    "trials/*/plane/point_mm")
_MIN_COMPRESSED_ELEMENTS = 64  # tiny arrays cost more as chunks than they save


def compact_copy(source: str | Path, destination: str | Path) -> Path:
    """Rewrite an HDF5 file compactly (see the module's docstring) and return the new path.

    Parameters
    ----------
    source
        A raw grid or study file, as written by ``whiskercal collect`` / ``optimal-depth run``.
    destination
        The compact copy to write (replaced atomically if it exists); must not be ``source``
        (refused with UsageError).
    """
    source, destination = Path(source), Path(destination)
    refuse_input_as_output(destination, [source], "the compact copy")
    with open_h5(source) as src:
        def write(dst: h5py.File) -> None:
            _copy_attrs(src, dst)
            src.visititems(lambda name, item: _copy_item(name, item, dst))

        write_whole(destination, write)
    return destination


def _copy_attrs(src, dst) -> None:
    for key, value in src.attrs.items():
        dst.attrs[key] = value


def _copy_item(name: str, item, dst: h5py.File) -> None:
    if isinstance(item, h5py.Group):
        _copy_attrs(item, dst.require_group(name))
        return
    data = item[()]
    if data.dtype == np.float64 and any(fnmatch.fnmatchcase(name, p) for p in FLOAT32_PATTERNS):
        data = data.astype(np.float32)
    options = {}
    if np.ndim(data) and np.size(data) >= _MIN_COMPRESSED_ELEMENTS and data.dtype.kind != "O":
        options = {"compression": "gzip", "compression_opts": 9, "shuffle": True}
    dataset = dst.create_dataset(name, data=data, **options)
    _copy_attrs(item, dataset)
