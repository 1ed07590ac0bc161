"""``whiskercal inspect``: what a calibration artifact or a raw dataset holds."""

from __future__ import annotations

from pathlib import Path

import click
import h5py
import numpy as np

from whiskercal.artifacts import calibration, raw_grid
from whiskercal.artifacts.h5io import as_text, open_h5, read_json_attr
from whiskercal.cli.app import echo_json
from whiskercal.errors import ArtifactError

_PROVENANCE = ("schema", "schema_version", "created", "whiskercal_version", "sensor_id")


def _datasets(handle: h5py.File) -> dict[str, dict]:
    """Every dataset's shape and units, by path."""
    found: dict[str, dict] = {}

    def visit(name: str, item) -> None:
        if isinstance(item, h5py.Dataset):
            found["/" + name] = {"shape": list(item.shape),
                                 "units": as_text(item.attrs.get("units", "?"))}

    handle.visititems(visit)
    return found


def _scalar_metrics(metrics: dict) -> dict:
    """Metrics that print on one line (numbers, short strings, small dicts)."""
    out = {}
    for key, value in metrics.items():
        if isinstance(value, np.ndarray):
            out[key] = value.tolist() if value.size <= 16 else f"array{list(value.shape)}"
        else:
            out[key] = value
    return out


def _extension_summary(data) -> dict:
    """How far past the grid the lookup's tips were extrapolated (mm) and which z are trusted (µT);
    artifacts before schema 1.2 did not record it (None)."""
    extensions = data.lookup_extension_mm
    trusted = data.trusted_range_uT()
    return {"max_mm": None if extensions is None else float(np.max(extensions)),
            "limit_mm": data.max_extension_mm,
            "allowed_mm": data.tip_extension_mm,
            "extrapolated": data.extrapolated,
            "trusted_z_uT": None if trusted is None else [float(trusted[0]), float(trusted[1])]}


def _calibration_summary(path: Path) -> dict:
    data = calibration.read_calibration(path)
    return {
        "kind": "calibration",
        "surface": {"degree": data.degree, "coordinates": data.coordinates,
                    "terms": int(len(data.coefficients))},
        "lookup": {"samples": int(len(data.lookup_z_uT)), "interpolant": data.lookup_kind,
                   "z_range_uT": [float(data.lookup_z_uT[0]), float(data.lookup_z_uT[-1])]},
        "trace": {"length_mm": data.trace_length_mm, "root_mm": data.root_mm.tolist(),
                  "entry_radius_mm": data.entry_radius_mm, "tracer": data.tracer,
                  "rod_radius_mm": data.rod_radius_mm},
        "extension": _extension_summary(data),
        "filter": data.filter, "collision": data.collision,
        "target_z_uT": data.target_z_uT,
        "metrics": _scalar_metrics(data.metrics),
    }


def _raw_summary(path: Path) -> dict:
    grid = raw_grid.read_raw_grid(path, stream=True)
    return {"kind": "raw_grid", "points": len(grid), "complete": grid.complete,
            "encoders": grid.encoders, "frames": grid.frames.to_dict(),
            "planned_points": int(len(grid.plan_rod_center_mm)),
            "rod_radius_mm": grid.rod_radius_mm,
            "z_range_uT": [float(np.min(grid.z_uT)), float(np.max(grid.z_uT))] if len(grid) else None,
            "truth": sorted(grid.truth) if grid.truth else None}


def inspect_file(path: str | Path) -> dict:
    """A JSON-able description of a whiskercal HDF5 file (calibration artifact or raw grid)."""
    path = Path(path)
    try:
        handle = open_h5(path)
    except ArtifactError as error:
        hint = raw_grid.journal_hint(path) if "truncated" in str(error) else None
        raise ArtifactError(f"{error}; {hint}") if hint else error from None
    with handle:
        provenance = {key: as_text(handle.attrs[key]) for key in _PROVENANCE if key in handle.attrs}
        inputs = read_json_attr(handle, "inputs_sha256", {})
        datasets = _datasets(handle)
    schema = provenance.get("schema", "")
    readers = {calibration.SCHEMA: _calibration_summary, raw_grid.SCHEMA: _raw_summary}
    if schema not in readers:
        raise ArtifactError(f"{path}: not a whiskercal calibration artifact or raw grid "
                            f"(schema attribute is {schema or 'missing'!r})")
    return {"path": str(path), "size_bytes": path.stat().st_size, **provenance,
            "inputs_sha256": inputs, **readers[schema](path), "datasets": datasets}


def _print(summary: dict) -> None:
    skip = {"datasets", "metrics"}
    for key, value in summary.items():
        if key not in skip:
            click.echo(f"{key:20s} {value}")
    for key, value in summary.get("metrics", {}).items():
        click.echo(f"metric {key:13s} {value}")
    click.echo(f"datasets             {len(summary['datasets'])}")
    for name, info in summary["datasets"].items():
        click.echo(f"  {name:40s} {str(tuple(info['shape'])):14s} {info['units']}")


@click.command("inspect")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print the description as JSON.")
def command(file: str, as_json: bool) -> None:
    """Show what a calibration artifact or a raw grid holds.

    Schema, versions, provenance (creation time, inputs' SHA-256), the fit's metrics, the lookup
    and filter settings, and every dataset with its shape and units.
    """
    summary = inspect_file(file)
    if as_json:
        echo_json(summary)
    else:
        _print(summary)
