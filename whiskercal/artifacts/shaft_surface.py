"""The calibration artifact's optional ``/shaft_surface`` group (since 1.4): the shaft localizer's
own measurement surface (``whiskercal.fit.shaft_surface``), radial patches of polynomials.

Layout: attributes ``edges_mm`` (radial distances where neighbouring patches meet), ``blend_mm``,
``rmse_uT`` (misfit on the grid's contacts), ``cv_rmse_uT`` (misfit on each inner grid column
left out of the fit in turn: between the columns; optional, absent from older artifacts), ``source`` (``grid+mechanics`` or ``grid``) and
``mechanics_points``; one subgroup per patch, ``patch0``, ``patch1``, ..., ordered by radial
distance, each laid out like ``/surface``. Artifacts without the group load too; the shaft
localizer then uses ``/surface``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from whiskercal.artifacts.h5io import as_text, read_array, write_array
from whiskercal.errors import ArtifactError

GROUP = "shaft_surface"


@dataclass
class ShaftSurfaceData:
    """The shaft surface as plain arrays: per patch ``degree``, ``coordinates``, Legendre
    ``coefficients``, ``scale_center`` and ``scale_half_width``; the edges (mm), blend (mm),
    misfit (µT) and what it was fitted to."""

    patches: list[dict]
    edges_mm: np.ndarray
    blend_mm: float
    rmse_uT: float
    source: str
    mechanics_points: int = 0
    cv_rmse_uT: float = float("nan")


def data_of(surface, rmse_uT: float, source: str, mechanics_points: int,
            cv_rmse_uT: float = float("nan")) -> ShaftSurfaceData:
    """The plain form of a :class:`~whiskercal.model.patched_surface.PatchedSurface`."""
    patches = [{"degree": p.degree, "coordinates": p.coordinates,
                "coefficients": np.asarray(p.coefficients, float),
                "scale_center": np.asarray(p.scaling.center, float),
                "scale_half_width": np.asarray(p.scaling.half_width, float)}
               for p in surface.patches]
    return ShaftSurfaceData(patches, np.asarray(surface.edges_mm, float), float(surface.blend_mm),
                            float(rmse_uT), source, int(mechanics_points), float(cv_rmse_uT))


def surface_of(data: ShaftSurfaceData):
    """The :class:`~whiskercal.model.patched_surface.PatchedSurface` the data describe."""
    from whiskercal.model.patched_surface import PatchedSurface
    from whiskercal.model.surface import Scaling, Surface

    patches = [Surface(int(p["degree"]), p["coefficients"],
                       Scaling(np.asarray(p["scale_center"], float),
                               np.asarray(p["scale_half_width"], float)), p["coordinates"])
               for p in data.patches]
    try:
        return PatchedSurface(patches, data.edges_mm, data.blend_mm)
    except ValueError as error:
        raise ArtifactError(f"the artifact's shaft surface is malformed: {error}") from None


def write(handle: h5py.File, data: ShaftSurfaceData) -> None:
    """Add ``/shaft_surface`` to an artifact being written."""
    group = handle.create_group(GROUP)
    write_array(group, "edges_mm", np.asarray(data.edges_mm, float), "mm")
    group.attrs["blend_mm"] = float(data.blend_mm)
    group.attrs["rmse_uT"] = float(data.rmse_uT)
    if np.isfinite(data.cv_rmse_uT):
        group.attrs["cv_rmse_uT"] = float(data.cv_rmse_uT)
    group.attrs["source"] = data.source
    group.attrs["mechanics_points"] = int(data.mechanics_points)
    for k, patch in enumerate(data.patches):
        sub = group.create_group(f"patch{k}")
        sub.attrs["degree"] = int(patch["degree"])
        sub.attrs["coordinates"] = patch["coordinates"]
        units = "mm, rad" if patch["coordinates"] == "polar" else "mm, mm"
        write_array(sub, "coefficients", patch["coefficients"], "µT")
        write_array(sub, "scale_center", patch["scale_center"], units)
        write_array(sub, "scale_half_width", patch["scale_half_width"], units)


def read(handle: h5py.File, path: Path) -> ShaftSurfaceData | None:
    """``/shaft_surface`` of an open artifact, or None when it has none (before 1.4)."""
    if GROUP not in handle:
        return None
    group = handle[GROUP]
    count = len([name for name in group if name.startswith("patch")])
    patches = []
    for k in range(count):
        sub = group[f"patch{k}"]
        patches.append({"degree": int(sub.attrs["degree"]),
                        "coordinates": as_text(sub.attrs["coordinates"]),
                        "coefficients": read_array(sub, "coefficients", path),
                        "scale_center": read_array(sub, "scale_center", path),
                        "scale_half_width": read_array(sub, "scale_half_width", path)})
    return ShaftSurfaceData(patches, np.atleast_1d(read_array(group, "edges_mm", path)),
                            float(group.attrs["blend_mm"]), float(group.attrs["rmse_uT"]),
                            as_text(group.attrs["source"]),
                            int(group.attrs.get("mechanics_points", 0)),
                            float(group.attrs.get("cv_rmse_uT", np.nan)))
