"""Regress every recorded dataset against its golden results, or rewrite them on purpose."""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from whiskercal.regress.compare import Change, compare
from whiskercal.regress.golden import (DEFAULT_PIPELINE, Dataset, check_inputs, find_datasets,
                                       read_golden, writable_golden_path, write_golden)
from whiskercal.regress.pipeline import recompute


@dataclass
class DatasetResult:
    """What one dataset's regression found.

    Attributes
    ----------
    name : str
        The dataset directory's name.
    quantities : int
        How many quantities were compared.
    changes : list of Change
        Quantities outside their tolerance (or added / removed).
    inputs_changed : list of str
        Recorded files whose SHA-256 differs from the one the golden results were computed from.
    updated : bool
        True when ``golden.json`` was (re)written.
    created : bool
        True when there was no ``golden.json`` before (``update`` only).
    elapsed_s : float
        Wall time of the recomputation, s.
    """

    name: str
    quantities: int
    changes: list[Change] = field(default_factory=list)
    inputs_changed: list[str] = field(default_factory=list)
    updated: bool = False
    created: bool = False
    elapsed_s: float = 0.0

    def as_dict(self) -> dict:
        """JSON-able form."""
        return {"dataset": self.name, "quantities": self.quantities,
                "changes": [c.as_dict() for c in self.changes],
                "inputs_changed": self.inputs_changed, "updated": self.updated,
                "created": self.created,
                "elapsed_s": round(self.elapsed_s, 3)}


def regress(data_dir: str | Path, update: bool = False,
            say: Callable[[str], None] | None = None) -> list[DatasetResult]:
    """Recompute every dataset in ``data_dir`` and compare with (or, with ``update``, rewrite)
    its golden results.

    Every dataset's files are checked before any work starts, so a missing or corrupt file ends
    the run at once with its name.
    """
    datasets = find_datasets(data_dir)
    if update:  # refuse a golden file that would be written out of place before any work starts
        for dataset in datasets:
            writable_golden_path(dataset)
    checked = [(dataset, check_inputs(dataset), read_golden(dataset, required=not update))
               for dataset in datasets]
    with tempfile.TemporaryDirectory(prefix="whiskercal-regress-") as scratch:
        return [_regress_one(dataset, inputs, golden, Path(scratch), update, say)
                for dataset, inputs, golden in checked]


def _regress_one(dataset: Dataset, inputs: dict[str, str], golden, workdir: Path, update: bool,
                 say) -> DatasetResult:
    started = time.perf_counter()
    pipeline = _pipeline(golden, update)
    quantities, sensor_id = recompute(dataset, pipeline, workdir, say)
    old_values = golden.quantities if golden is not None else {}
    old_classes = golden.classes if golden is not None else {}
    changes = compare(old_values, old_classes, quantities)
    old_inputs = golden.inputs if golden is not None else {}
    result = DatasetResult(dataset.name, len(quantities), changes,
                           sorted(n for n in inputs if old_inputs.get(n) not in (None, inputs[n])))
    if update and (golden is None or changes or inputs != old_inputs):
        write_golden(dataset, quantities, pipeline, inputs, sensor_id)
        result.updated, result.created = True, golden is None
    result.elapsed_s = time.perf_counter() - started
    return result


def _pipeline(golden, update: bool) -> dict:
    """What a dataset is recomputed with: its golden file's pipeline; on ``update`` with the
    steps it lacks taken from ``DEFAULT_PIPELINE`` (an older file gains the default fit's
    check) and the current description of why."""
    if golden is None:
        return dict(DEFAULT_PIPELINE)
    if not update:
        return golden.pipeline
    kept = {key: value for key, value in golden.pipeline.items() if key != "why"}
    return {**DEFAULT_PIPELINE, **kept}
