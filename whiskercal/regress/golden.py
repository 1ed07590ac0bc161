"""Recorded datasets and their golden results: finding, checking, reading and writing them.

A dataset is a directory holding ``raw_grid.h5`` (``whiskercal collect``), ``plane_study.h5``
(``whiskercal optimal-depth run``) and ``golden.json``: the results every stage gave on them,
each quantity with its tolerance class (whiskercal.regress.tolerances), and the options the
pipeline ran with (so a regression run repeats exactly the recorded pipeline).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from whiskercal import __version__, atomic
from whiskercal.artifacts.h5io import now_iso, sha256_file
from whiskercal.atomic import inside, refuse_input_as_output
from whiskercal.errors import ArtifactError, UsageError
from whiskercal.regress.tolerances import CLASSES, tolerance_for

RAW_GRID_FILE = "raw_grid.h5"
STUDY_FILE = "plane_study.h5"
SHAFT_STUDY_FILE = "shaft_study.h5"  # optional: a shaft study (docs/shaft.md)
GOLDEN_FILE = "golden.json"
GOLDEN_SCHEMA = "whiskercal.golden"
GOLDEN_VERSION = "1.0.0"
# The pipeline a dataset's golden results came from, unless its golden file says otherwise:
# `whiskercal fit` with these arguments, the study report with this margin weight, and fit's
# default path beside them.
# The level set's lookup without the (Y, Z) table carries the study: it reproduces to the
# nanometre classes on any machine; the default fit's iterative solves do not, and are checked
# to the mm bounds of what they guarantee (``regress.default_fit``, data/README.md).
DEFAULT_PIPELINE = {
    "fit_args": ["--degree", "5", "--samples", "20", "--tip-model", "level-set", "--no-field-table"],
    "margin_weight_mm": 0.1,
    "default_fit_args": ["--degree", "5", "--samples", "20"],
    "why": ("fit_args (--tip-model level-set --no-field-table) carry the study and the runtime: "
            "the level set's lookup reproduces to the nanometre classes on any machine. "
            "default_fit_args is fit's default path (the mechanics, the (Y, Z) joint fit and its "
            "table), whose iterative fits move with the arithmetic: its decisions are checked "
            "exactly and its tip curve, truth errors and table to the model_* and table_* "
            "classes (data/README.md)"),
}


@dataclass
class Dataset:
    """One recorded dataset directory."""

    path: Path

    @property
    def name(self) -> str:
        """The directory's name, used to label its results."""
        return self.path.name

    @property
    def raw_grid(self) -> Path:
        """The raw calibration grid."""
        return self.path / RAW_GRID_FILE

    @property
    def study(self) -> Path:
        """The flat-plane study."""
        return self.path / STUDY_FILE

    @property
    def shaft_study(self) -> Path | None:
        """The shaft study, when the dataset has one (None otherwise)."""
        path = self.path / SHAFT_STUDY_FILE
        return path if path.exists() else None

    @property
    def golden_path(self) -> Path:
        """The golden results file."""
        return self.path / GOLDEN_FILE


@dataclass
class Golden:
    """A dataset's golden results.

    Attributes
    ----------
    quantities : dict
        Quantity name -> golden value (float, int, bool, str, list or None for NaN).
    classes : dict
        Quantity name -> tolerance class name.
    pipeline : dict
        ``fit_args`` (list of `whiskercal fit` arguments) and ``margin_weight_mm``.
    inputs : dict
        Input file name -> SHA-256 the results were computed from.
    meta : dict
        Everything else in the file (schema, versions, time of the update).
    """

    quantities: dict[str, Any]
    classes: dict[str, str]
    pipeline: dict[str, Any] = field(default_factory=lambda: dict(DEFAULT_PIPELINE))
    inputs: dict[str, str] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)


def find_datasets(data_dir: str | Path) -> list[Dataset]:
    """The dataset directories in ``data_dir`` (or ``data_dir`` itself when it is one).

    Raises
    ------
    UsageError
        When ``data_dir`` is not a directory or holds no dataset.
    """
    root = Path(data_dir)
    if not root.is_dir():
        raise UsageError(f"{root}: no such directory")
    if _looks_like_dataset(root):
        return [Dataset(root)]
    found = [Dataset(p) for p in sorted(root.iterdir()) if p.is_dir() and _looks_like_dataset(p)]
    if not found:
        raise UsageError(f"{root}: no dataset directories (each needs {RAW_GRID_FILE}, "
                         f"{STUDY_FILE} and {GOLDEN_FILE})")
    return found


def _looks_like_dataset(path: Path) -> bool:
    return any((path / name).exists() for name in (RAW_GRID_FILE, STUDY_FILE, GOLDEN_FILE))


def check_inputs(dataset: Dataset) -> dict[str, str]:
    """Refuse a dataset whose recorded files are missing or unreadable; return their SHA-256.

    Each file is opened with its own reader (schema and version checked), so a corrupt or
    foreign file is named with what is wrong with it.
    """
    from whiskercal.artifacts.plane_study import read_study
    from whiskercal.artifacts.raw_grid import read_raw_grid
    from whiskercal.artifacts.shaft_study import read_shaft_study

    files = [(dataset.raw_grid, read_raw_grid), (dataset.study, read_study)]
    if dataset.shaft_study is not None:
        files.append((dataset.shaft_study, read_shaft_study))
    for path, reader in files:
        if not path.is_file():
            raise ArtifactError(f"{dataset.name}: missing {path.name} in {dataset.path}")
        try:
            reader(path)
        except ArtifactError as error:
            raise ArtifactError(f"{dataset.name}: {path.name} is unreadable: {error}") from None
        except (OSError, KeyError, ValueError) as error:
            raise ArtifactError(f"{dataset.name}: {path.name} is corrupt ({error})") from None
    return {p.name: sha256_file(p) for p, _ in files}


def read_golden(dataset: Dataset, required: bool = True) -> Golden | None:
    """Read ``golden.json``; None when it is absent and not ``required``.

    Raises
    ------
    ArtifactError
        When it is absent (and required), not JSON, or not a golden file of version 1.
    """
    path = dataset.golden_path
    if not path.is_file():
        if required:
            raise ArtifactError(f"{dataset.name}: no {GOLDEN_FILE}; create it with "
                                "`whiskercal regress DATA_DIR --update`")
        return None
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
        _check_golden_schema(document, path)
        quantities = {name: entry["value"] for name, entry in document["quantities"].items()}
        classes = {name: entry["tolerance"] for name, entry in document["quantities"].items()}
    except (ValueError, KeyError, TypeError, AttributeError) as error:  # ValueError: not JSON or not UTF-8
        raise ArtifactError(f"{path}: not a valid golden results file ({error})") from None
    unknown = sorted(set(classes.values()) - set(CLASSES))
    if unknown:
        raise ArtifactError(f"{path}: unknown tolerance class(es) {', '.join(unknown)}")
    meta = {k: v for k, v in document.items() if k not in ("quantities", "pipeline", "inputs")}
    return Golden(quantities, classes, document.get("pipeline", dict(DEFAULT_PIPELINE)),
                  document.get("inputs", {}), meta)


def _check_golden_schema(document: dict, path: Path) -> None:
    if document.get("schema") != GOLDEN_SCHEMA:
        raise ArtifactError(f"{path}: not a {GOLDEN_SCHEMA} file")
    if str(document.get("schema_version", "")).split(".")[0] != GOLDEN_VERSION.split(".")[0]:
        raise ArtifactError(f"{path}: golden schema version {document.get('schema_version')} "
                            f"is not supported (this whiskercal reads {GOLDEN_VERSION[0]}.x)")


def write_golden(dataset: Dataset, quantities: dict[str, Any], pipeline: dict[str, Any],
                 inputs: dict[str, str], sensor_id: str) -> Path:
    """Write ``golden.json``: every quantity with its tolerance class, and why each class."""
    used = {name: tolerance_for(name) for name in quantities}
    document = {
        "schema": GOLDEN_SCHEMA, "schema_version": GOLDEN_VERSION, "dataset": dataset.name,
        "sensor_id": sensor_id, "whiskercal_version": __version__, "updated": now_iso(),
        "inputs": inputs, "pipeline": pipeline,
        "tolerance_classes": {c.name: {"abs": c.abs_tol, "rel": c.rel_tol, "why": c.why}
                              for c in sorted(set(used.values()), key=lambda c: c.name)},
        "quantities": {name: {"value": _json_value(value), "tolerance": used[name].name}
                       for name, value in quantities.items()},
    }
    return atomic.write_text(writable_golden_path(dataset), _dumps(document))


def writable_golden_path(dataset: Dataset) -> Path:
    """``golden.json``, checked before it is replaced: it must lie inside the dataset directory
    (not a link out of it) and must not be one of the recorded files (a hard or symbolic link).

    Raises
    ------
    UsageError
        When either check fails.
    """
    inside(dataset.path, GOLDEN_FILE, f"{dataset.name}: {GOLDEN_FILE}")
    refuse_input_as_output(dataset.golden_path, [dataset.raw_grid, dataset.study],
                           f"{dataset.name}: {GOLDEN_FILE}")
    return dataset.golden_path


def _dumps(document: dict) -> str:
    """JSON with one quantity per line, so that a diff of golden.json reads quantity by quantity."""
    head = {k: v for k, v in document.items() if k != "quantities"}
    text = json.dumps(head, indent=1, ensure_ascii=False)[:-2]
    lines = [f" {json.dumps(name, ensure_ascii=False)}: {json.dumps(entry, ensure_ascii=False)}"
             for name, entry in document["quantities"].items()]
    return text + ',\n "quantities": {\n ' + ",\n ".join(lines) + "\n }\n}\n"


def _json_value(value: Any) -> Any:
    """JSON keeps no NaN: it is written as null (and read back as NaN where a number is due)."""
    if isinstance(value, float) and math.isnan(value):
        return None
    return value
