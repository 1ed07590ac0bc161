"""The calibration artifact (schema ``whiskercal.calibration``, version 1.x): read, write, validate.

Layout (docs/formats.md, "Calibration artifact"), every dataset with a ``units`` attribute:

- ``/surface``: Legendre coefficients of z = f(x, y) (total degree), their exponents and the
  map of the basis' variables onto [-1, 1]; attributes ``degree``, ``basis``, ``coordinates``
  ("polar": r mm, θ rad about the origin; "cartesian": x, y mm).
- ``/domain``: hull vertices of the (rod-corrected) grid and the margin.
- ``/trace``: root position and its shift with z, trace length, entry radius, tip-side extension
  (the longest allowed, ``tip_extension_mm``, and the longest trusted, ``max_extension_mm``; 1.2).
- ``/lookup``: sample z values and their traced tips; attribute ``kind`` (the interpolant). Since
  1.2: ``extension_mm``, each sample's straight extension past the grid, and the attributes
  ``extrapolated`` (some of the range lies beyond ``max_extension_mm``) and ``trusted_z_uT`` (the
  part that does not, NaN when none; the runtime refuses the rest unless told otherwise).
- ``/filter``, ``/collision``: settings as attributes.
- ``/metrics``: fit and lookup evidence, and ``warnings`` (JSON list of sentences, 1.2);
  ``/metrics/truth`` when the raw grid came from the twin.
- ``/field_table`` (optional, 1.4; ``fit --field-table``): the (Y, Z) -> tip table of the
  mechanics with the magnet's map (docs/calibration.md): ``y_uT`` (ny,) and ``axial_uT`` (nz,),
  evenly spaced axes of the deflection (Y) and the chip-normal (Z) axis from their static
  readings, and ``tip_mm`` (ny, nz, 2), NaN outside what tip loads reach. A runtime given both
  axes reads the tip there and falls back to ``/lookup`` where the table has none.
- ``/load_branches`` (optional, 1.5): where the table is withheld because one (Y, Z) reading
  fits tip loads far apart, the model's tip loads on a (direction, size) grid that the runtime
  follows through each contact from rest (``whiskercal.model.load_branches``): ``fields_uT``
  (na, nm, 2) (Y, Z) from rest and ``tip_mm`` (na, nm, 2), NaN where no load, float32;
  ``noise_uT`` (2,) and ``y_range_uT`` (2,).
- ``/shaft_surface`` (optional, 1.4): the shaft localizer's own surface, radial patches
  (``whiskercal.artifacts.shaft_surface``); without it the localizer uses ``/surface``.
- ``/target`` (optional, added by the optimal-depth study in a minor version): ``z_uT``,
  ``depth_mm`` and why (:class:`Target`). It is never written into an artifact in place:
  :func:`write_with_target` makes the next version as a new file.

One writer, :func:`write_calibration` (and :func:`write_with_target` for the derived version);
one reader, :func:`read_calibration`. Reading never executes code: plain arrays and JSON text
only.
"""

from __future__ import annotations

import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from whiskercal.artifacts import shaft_surface as shaft_surface_group
from whiskercal.artifacts.h5io import (as_text, check_schema, now_iso, open_h5, read_array,
                                       read_json_attr, sha256_file, write_array, write_provenance,
                                       write_whole, malformed_is_an_error)
from whiskercal.atomic import refuse_input_as_output, write_bytes
from whiskercal.artifacts.shaft_surface import ShaftSurfaceData
from whiskercal.errors import ArtifactError, UsageError
from whiskercal.paths import ensure_dir

SCHEMA = "whiskercal.calibration"
# 1.1: /target (the study); 1.2: extrapolation marks; 1.3 is a 1.2 with a target; 1.4: the
# shaft localizer's own surface, /shaft_surface (whiskercal.artifacts.shaft_surface), and the
# (Y, Z) -> tip table, /field_table: both optional, found by their presence
# 1.5: the loads a runtime follows where the (Y, Z) readings fold, /load_branches (optional)
SCHEMA_VERSION = "1.5.0"
SUPPORTED_MAJOR = 1
BASIS = "legendre-total-degree"
TARGET_GROUP = "target"


@dataclass(frozen=True)
class Target:
    """The deflection target an optimal-depth study chose: z in µT at a contact depth in mm,
    the selection rule and the reason in words, and the SHA-256 of the study file."""

    z_uT: float
    depth_mm: float
    rule: str
    reason: str
    study_sha256: str


@dataclass
class CalibrationData:
    """Everything a calibration artifact holds, as plain numbers and arrays (mm, µT)."""

    sensor_id: str
    degree: int
    coordinates: str
    coefficients: np.ndarray
    exponents: np.ndarray
    scale_center: np.ndarray
    scale_half_width: np.ndarray
    hull_vertices_mm: np.ndarray
    domain_margin_mm: float
    trace_length_mm: float
    entry_radius_mm: float
    extension_radius_mm: float | None
    tip_extension_mm: float
    min_gradient_uT_per_mm: float
    root_mm: np.ndarray
    root_shift_mm_per_uT: np.ndarray
    rod_radius_mm: float
    tracer: str
    lookup_z_uT: np.ndarray
    lookup_tip_mm: np.ndarray
    lookup_kind: str
    filter: dict[str, Any]
    collision: dict[str, Any]
    metrics: dict[str, Any] = field(default_factory=dict)
    truth: dict[str, np.ndarray] | None = None
    inputs: dict[str, str] = field(default_factory=dict)
    config: dict[str, Any] = field(default_factory=dict)
    target: Target | None = None
    schema_version: str = SCHEMA_VERSION
    created: str = ""
    whiskercal_version: str = ""
    # 1.2: how far past the grid tips are extrapolated (None in older artifacts)
    max_extension_mm: float | None = None
    lookup_extension_mm: np.ndarray | None = None
    extrapolated: bool = False
    trusted_z_uT: tuple[float, float] | None = None  # with extrapolated: None means no part
    # 1.4: the (Y, Z) -> tip table: {"y_uT", "axial_uT", "tip_mm"} arrays (None: Y only)
    field_table: dict[str, np.ndarray] | None = None
    # 1.4: the shaft localizer's own surface (None in older artifacts)
    shaft_surface: ShaftSurfaceData | None = None
    # 1.5: tip loads followed through a contact: {"fields_uT", "tip_mm", "noise_uT",
    # "y_range_uT"} arrays (None: a table, or Y only)
    load_branches: dict[str, np.ndarray] | None = None

    @property
    def target_z_uT(self) -> float | None:
        """The study's deflection target, µT (None until a study chose one)."""
        return None if self.target is None else self.target.z_uT

    def trusted_range_uT(self) -> tuple[float, float] | None:
        """The z range (µT) whose tips lie within the extrapolation limit; None when none do."""
        if not self.extrapolated:
            return float(self.lookup_z_uT[0]), float(self.lookup_z_uT[-1])
        return self.trusted_z_uT


def _none_to_nan(value):
    return math.nan if value is None else value


def _nan_to_none(value):
    value = value.item() if isinstance(value, np.generic) else value
    return None if isinstance(value, float) and math.isnan(value) else value


def write_calibration(path: str | Path, data: CalibrationData) -> Path:
    """Write a calibration artifact (version 1.4.0); the file is replaced atomically.

    Raises
    ------
    ArtifactError
        When the file or its directory cannot be written (a read-only folder, a full disk: the
        old file is kept whole).
    """
    path = Path(path)

    def write(handle: h5py.File) -> None:
        write_provenance(handle, schema=SCHEMA, schema_version=SCHEMA_VERSION,
                         sensor_id=data.sensor_id, inputs=data.inputs, config=data.config)
        handle.attrs["rod_radius_mm"] = float(data.rod_radius_mm)
        _write_surface(handle.create_group("surface"), data)
        _write_trace(handle, data)
        _write_lookup(handle.create_group("lookup"), data)
        _write_settings(handle, data)
        _write_metrics(handle.create_group("metrics"), data)
        if data.field_table is not None:
            _write_field_table(handle.create_group("field_table"), data.field_table)
        if data.load_branches is not None:
            _write_load_branches(handle.create_group("load_branches"), data.load_branches)
        if data.shaft_surface is not None:
            shaft_surface_group.write(handle, data.shaft_surface)

    try:
        ensure_dir(path.parent)
        write_whole(path, write)
    except (OSError, UsageError) as error:
        raise ArtifactError(f"{path}: cannot write the calibration artifact ({error})") from None
    return path


def _write_surface(group: h5py.Group, data: CalibrationData) -> None:
    group.attrs["degree"] = int(data.degree)
    group.attrs["basis"] = BASIS
    group.attrs["coordinates"] = data.coordinates
    variable_units = "mm, rad" if data.coordinates == "polar" else "mm, mm"
    write_array(group, "coefficients", data.coefficients, "µT")
    write_array(group, "exponents", np.asarray(data.exponents, np.int32), "1")
    write_array(group, "scale_center", data.scale_center, variable_units)
    write_array(group, "scale_half_width", data.scale_half_width, variable_units)


def _write_trace(handle: h5py.File, data: CalibrationData) -> None:
    domain = handle.create_group("domain")
    write_array(domain, "hull_vertices_mm", data.hull_vertices_mm, "mm")
    domain.attrs["margin_mm"] = float(data.domain_margin_mm)
    trace = handle.create_group("trace")
    write_array(trace, "root_mm", data.root_mm, "mm")
    write_array(trace, "root_shift_mm_per_uT", data.root_shift_mm_per_uT, "mm/µT")
    for name in ("trace_length_mm", "entry_radius_mm", "extension_radius_mm", "tip_extension_mm",
                 "min_gradient_uT_per_mm", "max_extension_mm"):
        trace.attrs[name] = float(_none_to_nan(getattr(data, name)))
    trace.attrs["tracer"] = data.tracer


def _write_lookup(group: h5py.Group, data: CalibrationData) -> None:
    write_array(group, "z_uT", data.lookup_z_uT, "µT")
    write_array(group, "tip_mm", data.lookup_tip_mm, "mm")
    group.attrs["kind"] = data.lookup_kind
    if data.lookup_extension_mm is not None:
        write_array(group, "extension_mm", data.lookup_extension_mm, "mm")
    group.attrs["extrapolated"] = bool(data.extrapolated)
    trusted = data.trusted_z_uT if data.trusted_z_uT is not None else (math.nan, math.nan)
    group.attrs["trusted_z_uT"] = np.asarray(trusted, float)


def _write_field_table(group: h5py.Group, table: dict[str, np.ndarray]) -> None:
    write_array(group, "y_uT", np.asarray(table["y_uT"], float), "µT")
    write_array(group, "axial_uT", np.asarray(table["axial_uT"], float), "µT")
    write_array(group, "tip_mm", np.asarray(table["tip_mm"], float), "mm")


def _read_field_table(handle: h5py.File, path: Path) -> dict[str, np.ndarray] | None:
    if "field_table" not in handle:
        return None
    group = handle["field_table"]
    return {name: read_array(group, name, path) for name in ("y_uT", "axial_uT", "tip_mm")}


BRANCH_ARRAYS = {"fields_uT": "µT", "tip_mm": "mm", "noise_uT": "µT", "y_range_uT": "µT"}


def _write_load_branches(group: h5py.Group, branches: dict[str, np.ndarray]) -> None:
    for name, units in BRANCH_ARRAYS.items():
        large = name in ("fields_uT", "tip_mm")  # float32 halves them (0.3 MB each)
        write_array(group, name, np.asarray(branches[name], np.float32 if large else float),
                    units)


def _read_load_branches(handle: h5py.File, path: Path) -> dict[str, np.ndarray] | None:
    if "load_branches" not in handle:
        return None
    group = handle["load_branches"]
    return {name: np.asarray(read_array(group, name, path), float) for name in BRANCH_ARRAYS}


def _write_settings(handle: h5py.File, data: CalibrationData) -> None:
    for name, settings in (("filter", data.filter), ("collision", data.collision)):
        group = handle.create_group(name)
        for key, value in settings.items():
            group.attrs[key] = _none_to_nan(value)


def _write_metrics(group: h5py.Group, data: CalibrationData) -> None:
    for key, value in data.metrics.items():
        if isinstance(value, np.ndarray):
            write_array(group, key, value, _metric_units(key))
        elif isinstance(value, (dict, list)):
            group.attrs[key] = json.dumps(value, sort_keys=True)
        else:
            group.attrs[key] = _none_to_nan(value)
    if data.truth is not None:
        truth = group.create_group("truth")
        for key, value in data.truth.items():
            write_array(truth, key, value, _metric_units(key))


def _metric_units(name: str) -> str:
    for suffix, units in (("_uT", "µT"), ("_mm", "mm"), ("_s", "s")):
        if name.endswith(suffix) or f"{suffix}_" in name:
            return units
    return "1"


def read_calibration(path: str | Path) -> CalibrationData:
    """Load and validate a calibration artifact of major version 1.

    Raises
    ------
    ArtifactError
        When the file is missing, not HDF5, not a calibration artifact, of another major version,
        or missing a part.
    """
    path = Path(path)
    with open_h5(path) as handle, malformed_is_an_error(path, "calibration artifact"):
        version = check_schema(handle, SCHEMA, SUPPORTED_MAJOR, path)
        try:
            data = _read(handle, path)
        except KeyError as error:
            raise ArtifactError(f"{path}: incomplete calibration artifact ({error})") from None
        data.schema_version = version
        validate(data, path)
    return data


def _read(handle: h5py.File, path: Path) -> CalibrationData:
    surface, trace, lookup = handle["surface"], handle["trace"], handle["lookup"]
    metrics = handle["metrics"] if "metrics" in handle else None
    return CalibrationData(
        sensor_id=as_text(handle.attrs["sensor_id"]),
        degree=int(surface.attrs["degree"]),
        coordinates=as_text(surface.attrs["coordinates"]),
        coefficients=read_array(surface, "coefficients", path),
        exponents=read_array(surface, "exponents", path),
        scale_center=read_array(surface, "scale_center", path),
        scale_half_width=read_array(surface, "scale_half_width", path),
        hull_vertices_mm=read_array(handle["domain"], "hull_vertices_mm", path),
        domain_margin_mm=float(handle["domain"].attrs["margin_mm"]),
        trace_length_mm=float(trace.attrs["trace_length_mm"]),
        entry_radius_mm=float(trace.attrs["entry_radius_mm"]),
        extension_radius_mm=_nan_to_none(float(trace.attrs["extension_radius_mm"])),
        tip_extension_mm=float(trace.attrs["tip_extension_mm"]),
        min_gradient_uT_per_mm=float(trace.attrs["min_gradient_uT_per_mm"]),
        root_mm=read_array(trace, "root_mm", path),
        root_shift_mm_per_uT=read_array(trace, "root_shift_mm_per_uT", path),
        rod_radius_mm=float(handle.attrs["rod_radius_mm"]),
        tracer=as_text(trace.attrs["tracer"]),
        lookup_z_uT=read_array(lookup, "z_uT", path),
        lookup_tip_mm=read_array(lookup, "tip_mm", path),
        lookup_kind=as_text(lookup.attrs["kind"]),
        filter=_settings(handle["filter"]),
        collision=_settings(handle["collision"]),
        metrics=_read_metrics(metrics) if metrics is not None else {},
        truth=_read_truth(metrics),
        inputs=read_json_attr(handle, "inputs_sha256", {}),
        config=read_json_attr(handle, "config", {}),
        target=_read_target(handle),
        shaft_surface=shaft_surface_group.read(handle, path),
        created=as_text(handle.attrs.get("created", "")),
        whiskercal_version=as_text(handle.attrs.get("whiskercal_version", "")),
        **_read_extrapolation(trace, lookup),
        field_table=_read_field_table(handle, path),
        load_branches=_read_load_branches(handle, path),
    )


def _read_target(handle: h5py.File) -> Target | None:
    if TARGET_GROUP not in handle:
        return None
    group = handle[TARGET_GROUP]
    depth_mm = float(group["depth_mm"][()]) if "depth_mm" in group else math.nan
    return Target(float(group["z_uT"][()]), depth_mm,
                  *(as_text(group.attrs.get(key, "")) for key in ("rule", "reason", "study_sha256")))


def _read_extrapolation(trace: h5py.Group, lookup: h5py.Group) -> dict[str, Any]:
    """The 1.2 extrapolation marks; artifacts before 1.2 have none (every z trusted)."""
    limit = _nan_to_none(float(trace.attrs["max_extension_mm"])) \
        if "max_extension_mm" in trace.attrs else None
    trusted = np.asarray(lookup.attrs.get("trusted_z_uT", [math.nan, math.nan]), float)
    return {"max_extension_mm": limit,
            "lookup_extension_mm": lookup["extension_mm"][()] if "extension_mm" in lookup else None,
            "extrapolated": bool(lookup.attrs.get("extrapolated", False)),
            "trusted_z_uT": None if np.any(np.isnan(trusted)) else (float(trusted[0]),
                                                                     float(trusted[1]))}


def _settings(group: h5py.Group) -> dict[str, Any]:
    return {key: _nan_to_none(_plain(value)) for key, value in group.attrs.items()}


def _plain(value: Any) -> Any:
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _read_metrics(group: h5py.Group) -> dict[str, Any]:
    metrics: dict[str, Any] = {}
    for key, value in group.attrs.items():
        value = _plain(value)
        if isinstance(value, str) and value.startswith(("{", "[")):
            value = json.loads(value)
        metrics[key] = _nan_to_none(value)
    for key, item in group.items():
        if isinstance(item, h5py.Dataset):
            metrics[key] = item[()]
    return metrics


def _read_truth(metrics: h5py.Group | None) -> dict[str, np.ndarray] | None:
    if metrics is None or "truth" not in metrics:
        return None
    return {key: dataset[()] for key, dataset in metrics["truth"].items()}


def _finite_collision(collision: dict) -> bool:
    values = [collision.get(key, 0.0) for key in ("threshold_uT", "static_uT")]
    values = [np.nan if value is None else float(value) for value in values]  # NaN is read as None
    return bool(np.all(np.isfinite(values)) and values[0] > 0)


def validate(data: CalibrationData, path: str | Path = "") -> None:
    """Check shapes and values that the runtime relies on; raise ArtifactError on the first fault."""
    where = f"{path}: " if path else ""
    n_terms = (data.degree + 1) * (data.degree + 2) // 2
    checks = [
        (np.shape(data.coefficients) == (n_terms,), f"{n_terms} surface coefficients"),
        (np.shape(data.exponents) == (n_terms, 2), "surface exponents of shape (terms, 2)"),
        (np.all(np.asarray(data.scale_half_width) > 0), "positive surface scaling"),
        (data.coordinates in ("polar", "cartesian"), "polar or cartesian surface coordinates"),
        (np.ndim(data.lookup_z_uT) == 1 and len(data.lookup_z_uT) >= 2, "at least two lookup samples"),
        (np.shape(data.lookup_tip_mm) == (len(data.lookup_z_uT), 2), "one lookup tip per sample"),
        (bool(np.all(np.diff(data.lookup_z_uT) > 0)), "increasing lookup z values"),
        (bool(np.all(np.isfinite(data.lookup_tip_mm))), "finite lookup tips"),
        (np.shape(data.root_mm) == (2,), "a root position (2,)"),
        (data.trace_length_mm > 0, "a positive trace length"),
        (data.lookup_extension_mm is None
         or np.shape(data.lookup_extension_mm) == np.shape(data.lookup_z_uT),
         "one extension per lookup sample"),
        (data.trusted_z_uT is None or bool(data.lookup_z_uT[0] <= data.trusted_z_uT[0]
                                           <= data.trusted_z_uT[1] <= data.lookup_z_uT[-1]),
         "a trusted z range inside the lookup's"),
        (_field_table_ok(data.field_table), "a field table of shape (ny, nz, 2) on increasing, "
         "evenly spaced axes"),
        (_load_branches_ok(data.load_branches), "load branches: fields and tips of one shape "
         "(na, nm, 2), a positive noise (2,) and an increasing Y range (2,)"),
        (_finite_collision(data.collision), "a finite collision threshold > 0 and static reading "
         "(the release may be NaN: the threshold's)"),
    ]
    for ok, expectation in checks:
        if not ok:
            raise ArtifactError(f"{where}corrupt calibration artifact: expected {expectation}")


def _field_table_ok(table: dict[str, np.ndarray] | None) -> bool:
    if table is None:
        return True
    y, z, tips = (np.asarray(table[k], float) for k in ("y_uT", "axial_uT", "tip_mm"))
    even = all(a.ndim == 1 and len(a) >= 2 and np.all(np.diff(a) > 0)
               and np.allclose(np.diff(a), a[1] - a[0], rtol=1e-6) for a in (y, z))
    return bool(even and tips.shape == (len(y), len(z), 2))


def _load_branches_ok(branches: dict[str, np.ndarray] | None) -> bool:
    if branches is None:
        return True
    fields, tips, noise, span = (np.asarray(branches[k], float) for k in BRANCH_ARRAYS)
    return bool(fields.ndim == 3 and fields.shape[2] == 2 and tips.shape == fields.shape
                and noise.shape == (2,) and np.all(noise > 0) and span.shape == (2,)
                and span[0] < span[1])


# --- the target: a new version of an existing artifact ------------------------------------------

def bump_minor(version: str) -> str:
    """``1.0.0`` -> ``1.1.0``: a new optional part that readers of the same major accept."""
    try:
        major, minor, *_ = (int(part) for part in version.split("."))
    except ValueError:
        raise ArtifactError(f"bad schema_version {version!r} in the calibration artifact") from None
    return f"{major}.{minor + 1}.0"


def write_with_target(calibration_path: str | Path, out_path: str | Path, target: Target) -> Path:
    """Copy the calibration artifact to ``out_path`` with ``target`` added (docs/formats.md,
    "Calibration artifact with a target"): the copy's minor version is bumped, its ``created``
    renewed and its ``inputs_sha256`` extended by the study and the artifact it came from.

    Raises
    ------
    UsageError
        When ``out_path`` is the input artifact itself (an artifact version is never rewritten).
    ArtifactError
        When the input cannot be read as HDF5.
    """
    calibration_path, out_path = Path(calibration_path), Path(out_path)
    refuse_input_as_output(out_path, [calibration_path], "the artifact with the target")
    ensure_dir(out_path.parent)
    input_sha = sha256_file(calibration_path)
    try:
        buffer = io.BytesIO(calibration_path.read_bytes())
        with h5py.File(buffer, "r+") as handle:  # in memory: see h5io.write_whole
            _add_target(handle, target, input_sha)
        write_bytes(out_path, buffer.getvalue())
    except OSError as error:
        raise ArtifactError(f"{calibration_path}: cannot write a copy with the target "
                            f"({error})") from None
    return out_path


def _add_target(handle: h5py.File, target: Target, input_sha: str) -> None:
    if TARGET_GROUP in handle:
        del handle[TARGET_GROUP]  # a newer study supersedes the target of the copied version
    group = handle.create_group(TARGET_GROUP)
    write_array(group, "z_uT", float(target.z_uT), "µT")
    write_array(group, "depth_mm", float(target.depth_mm), "mm")
    group.attrs["rule"] = target.rule
    group.attrs["reason"] = target.reason
    group.attrs["study_sha256"] = target.study_sha256
    handle.attrs["schema_version"] = bump_minor(as_text(handle.attrs.get("schema_version", "1.0.0")))
    inputs = read_json_attr(handle, "inputs_sha256", {}) or {}
    inputs["plane_study"] = target.study_sha256
    inputs["calibration"] = input_sha
    handle.attrs["inputs_sha256"] = json.dumps(inputs, sort_keys=True)
    handle.attrs["created"] = now_iso()


# --- between the artifact and the models -------------------------------------------------------

def data_from_calibration(calibration, *, sensor_id: str, rod_radius_mm: float, tracer: str,
                          kalman, collision, metrics: dict[str, Any],
                          truth: dict[str, np.ndarray] | None = None,
                          inputs: dict[str, str] | None = None,
                          config: dict[str, Any] | None = None) -> CalibrationData:
    """The artifact's content for a :class:`whiskercal.model.calibrate.Calibration`."""
    from dataclasses import asdict

    from whiskercal.model.surface import term_indices

    surface, problem, lookup = calibration.surface, calibration.problem, calibration.lookup
    return CalibrationData(
        sensor_id=sensor_id, degree=surface.degree, coordinates=surface.coordinates,
        coefficients=surface.coefficients, exponents=term_indices(surface.degree),
        scale_center=surface.scaling.center, scale_half_width=surface.scaling.half_width,
        hull_vertices_mm=problem.domain.vertices_mm, domain_margin_mm=problem.domain.margin_mm,
        trace_length_mm=problem.trace_length_mm, entry_radius_mm=problem.entry_radius_mm,
        extension_radius_mm=problem.extension_radius_mm, tip_extension_mm=problem.tip_extension_mm,
        min_gradient_uT_per_mm=problem.min_gradient_uT_per_mm,
        root_mm=np.asarray(problem.root_mm, float),
        root_shift_mm_per_uT=np.asarray(problem.root_shift_mm_per_uT, float),
        rod_radius_mm=rod_radius_mm, tracer=tracer,
        lookup_z_uT=lookup.z_knots_uT, lookup_tip_mm=lookup.tips_mm, lookup_kind=lookup.kind,
        filter=asdict(kalman), collision=asdict(collision), metrics=metrics, truth=truth,
        inputs=dict(inputs or {}), config=dict(config or {}),
        max_extension_mm=calibration.extension_limit_mm,
        lookup_extension_mm=calibration.lookup_report.knot_extension_mm,
        extrapolated=calibration.extrapolated,
        trusted_z_uT=calibration.trusted_z_uT if calibration.extrapolated else None)


def surface_of(data: CalibrationData):
    """The :class:`~whiskercal.model.surface.Surface` stored in an artifact."""
    from whiskercal.model.surface import Scaling, Surface, term_indices

    if not np.array_equal(np.asarray(data.exponents), term_indices(data.degree)):
        raise ArtifactError("the artifact's surface exponents are not in the expected order")
    return Surface(data.degree, data.coefficients,
                   Scaling(np.asarray(data.scale_center, float),
                           np.asarray(data.scale_half_width, float)), data.coordinates)


def problem_of(data: CalibrationData):
    """The :class:`~whiskercal.model.trace.LevelSetProblem` stored in an artifact."""
    from whiskercal.model.trace import Domain, LevelSetProblem

    return LevelSetProblem(
        surface=surface_of(data),
        domain=Domain.from_points(data.hull_vertices_mm, data.domain_margin_mm),
        trace_length_mm=data.trace_length_mm,
        z_range_uT=(float(data.lookup_z_uT[0]), float(data.lookup_z_uT[-1])),
        entry_radius_mm=data.entry_radius_mm, root_mm=np.asarray(data.root_mm, float),
        root_shift_mm_per_uT=np.asarray(data.root_shift_mm_per_uT, float),
        min_gradient_uT_per_mm=data.min_gradient_uT_per_mm,
        extension_radius_mm=data.extension_radius_mm, tip_extension_mm=data.tip_extension_mm)


def lookup_of(data: CalibrationData, trusted_z_uT: tuple[float, float] | None = None):
    """The :class:`~whiskercal.model.lookup.TipLookup` stored in an artifact, over its whole range
    (extrapolated part included: see :meth:`CalibrationData.trusted_range_uT`), or narrowed to
    ``trusted_z_uT`` (µT)."""
    from whiskercal.model.lookup import TipLookup

    return TipLookup(data.lookup_z_uT, data.lookup_tip_mm, data.lookup_kind, trusted_z_uT)


def kalman_params_of(data: CalibrationData):
    """The filter settings stored in an artifact."""
    from whiskercal.model.kalman import KalmanParams

    return KalmanParams(**{key: data.filter[key] for key in
                           ("q_mm2", "p0_mm2", "window", "r_floor_mm2", "r_prior_mm2")
                           if key in data.filter})


def collision_params_of(data: CalibrationData):
    """The collision settings stored in an artifact."""
    from whiskercal.model.collision import CollisionParams

    return CollisionParams(**{key: data.collision[key] for key in
                              ("threshold_uT", "release_uT", "static_uT") if key in data.collision})
