"""``whiskercal fit``'s default path on a recorded dataset, as ``regress`` checks it.

The main pipeline (``regress.pipeline``) fits the level set without the (Y, Z) table, whose
numbers reproduce to the nanometre on any machine. The default fit (the mechanics-informed tip
model, the joint (Y, Z) fit and its table, ``--tip-model auto``) runs iterative least squares
whose stopping points move with the arithmetic, so it is checked for what it guarantees instead:
the same decisions (which tip model ships, whether the table or the load branches are written,
whether the tip error is warned), and its tip curve, truth errors and table within the mm bounds
of the ``model_*`` and ``table_*`` tolerance classes (``regress.tolerances``). Its quantities
are named ``default.*``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from whiskercal.regress.pipeline import fit_quantities, lookup_quantities, run_fit

# the (Y, Z) table is checked at every TABLE_STRIDE-th Y of its axis (11 of the 121) by Z_SAMPLES
# Z across the grid's contacts
TABLE_STRIDE = 12
Z_SAMPLES = 11
# the default fit's metrics kept (decisions apart, which fit_quantities gives)
DEFAULT_FIT_METRICS = ("tip_model", "lookup_vs_truth_rmse_mm", "lookup_vs_truth_max_mm",
                       "lookup_vs_truth_points")


def default_fit_quantities(raw_grid: Path, workdir: Path, fit_args: list[str]) -> dict[str, Any]:
    """Fit ``raw_grid`` as `whiskercal fit RAW [fit_args]` does (the defaults, with the golden
    file's degree and samples) and name what it guarantees: ``default.fit.*`` (the decisions and
    the truth errors), ``default.lookup.*`` (the tip curve) and ``default.table.*`` (the (Y, Z)
    table's tips at fixed fields, NaN where the table has none, and the share of its cells that
    hold one)."""
    from whiskercal.artifacts.calibration import read_calibration
    from whiskercal.artifacts.raw_grid import read_raw_grid

    artifact = workdir / f"{raw_grid.parent.name}-default-calibration.h5"
    run_fit(raw_grid, artifact, fit_args)
    return default_quantities(read_calibration(artifact), axial_span_uT(read_raw_grid(raw_grid)))


def axial_span_uT(raw) -> tuple[float, float]:
    """The lowest and highest chip-normal (Z) deflection (µT) among the grid's contacts: the
    span the table's Z samples cover, fixed by the data whatever the fit makes of it."""
    from whiskercal.fit.field_table import axial_deflection_uT
    from whiskercal.model.calibrate import contact_mask

    axial = axial_deflection_uT(raw)[contact_mask(raw.z_uT, raw.z_sem_uT)]
    return float(axial.min()), float(axial.max())


def default_quantities(data, axial_span: tuple[float, float]) -> dict[str, Any]:
    """The ``default.*`` quantities of a calibration artifact's content (``CalibrationData``),
    its table sampled over ``axial_span`` (µT, ``axial_span_uT``)."""
    fitted = {key: value for key, value in fit_quantities(data).items()
              if key.split(".", 1)[1] in DEFAULT_FIT_METRICS + ("tip_error_warned",
                                                                "field_table_written")}
    fitted["fit.load_branches_written"] = data.load_branches is not None
    found = {**fitted, **lookup_quantities(data)}
    if data.field_table is not None:
        found["table.within_goal"] = table_within_goal(data.metrics)
        if found["table.within_goal"]:
            found.update(_table_quantities(data.field_table, axial_span))
    return {f"default.{name}": value for name, value in found.items()}


def table_within_goal(metrics: dict) -> bool:
    """Whether the fit estimates its (Y, Z) table to meet the tip goal (one reading's RMS within
    ``WARN_TIP_ERROR_MM``). A table over it is shipped with that warning and guarantees no
    more: its tips move by millimetres with the arithmetic (the long 110 mm build's, measured in
    ``tolerances.TABLE_TIP``), so regress checks its decision and not its tips."""
    from whiskercal.fit.tip_model import WARN_TIP_ERROR_MM

    return bool(metrics.get("field_table_estimated_tip_error_mm", math.inf) <= WARN_TIP_ERROR_MM)


def _table_quantities(table: dict, axial_span: tuple[float, float]) -> dict[str, Any]:
    """The (Y, Z) table's tips as the runtime reads them (``FieldTipTable``) at fixed fields:
    every ``TABLE_STRIDE``-th Y of its axis (the grid's range) by ``Z_SAMPLES`` Z across
    ``axial_span``; the ends of its Z axis; and the share of its cells holding a tip.

    Fixed fields, not cells: the Z axis spans what the joint fit's loads reach, so a cell's
    index names another field in another run, and a cell compared by index moves with the
    axis rather than with the tips. A field within a cell of the edge of the tabulated loads
    is left out (NaN): there the runtime renormalizes the answered corners' weights, and a
    corner answered in one run and not in another moves the tip by the cell's width; where
    the loads end is what ``table.answered_share`` checks."""
    from whiskercal.model.field_table import FieldTipTable

    lookup = FieldTipTable(table["y_uT"], table["axial_uT"], table["tip_mm"])
    y_samples = np.asarray(table["y_uT"], float)[::TABLE_STRIDE]
    z_samples = np.linspace(*axial_span, Z_SAMPLES)
    tips = lookup(y_samples[:, None], z_samples[None, :])
    tips[~_inside_loads(lookup, y_samples, z_samples)] = np.nan
    axis = np.asarray(table["axial_uT"], float)
    found: dict[str, Any] = {f"table.y_uT[{i * TABLE_STRIDE:03d}]": float(y)
                             for i, y in enumerate(y_samples)}
    found["table.axial_uT.first"], found["table.axial_uT.last"] = float(axis[0]), float(axis[-1])
    cells = np.asarray(table["tip_mm"], float)
    found["table.answered_share"] = float(np.mean(np.all(np.isfinite(cells), axis=-1)))
    for i in range(len(y_samples)):
        for j in range(Z_SAMPLES):
            found[f"table.tip_x_mm[{i * TABLE_STRIDE:03d},{j:02d}]"] = float(tips[i, j, 0])
            found[f"table.tip_y_mm[{i * TABLE_STRIDE:03d},{j:02d}]"] = float(tips[i, j, 1])
    return found


def _inside_loads(lookup, y_samples: np.ndarray, z_samples: np.ndarray) -> np.ndarray:
    """(len(y), len(z)) bool: the field's table cell and every cell around it have all their
    corners answered (a tip at each)."""
    answered = np.all(np.isfinite(lookup.tips_mm), axis=-1)
    fy = (y_samples - lookup.y_uT[0]) / (lookup.y_uT[1] - lookup.y_uT[0])
    fz = (z_samples - lookup.z_uT[0]) / (lookup.z_uT[1] - lookup.z_uT[0])
    inside = np.zeros((len(fy), len(fz)), bool)
    for a, i in enumerate(np.floor(fy).astype(int)):
        for b, j in enumerate(np.floor(fz).astype(int)):
            block = answered[max(i - 1, 0):i + 3, max(j - 1, 0):j + 3]
            inside[a, b] = 1 <= i and 1 <= j and block.shape == (4, 4) and bool(block.all())
    return inside
