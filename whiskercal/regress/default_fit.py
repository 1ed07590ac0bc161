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

from pathlib import Path
from typing import Any

import numpy as np

from whiskercal.regress.pipeline import fit_quantities, lookup_quantities, run_fit

# every TABLE_STRIDE-th row and column of the (Y, Z) table is checked (the 121 x 121 table
# gives an 11 x 11 subgrid)
TABLE_STRIDE = 12
# the default fit's metrics kept (decisions apart, which fit_quantities gives)
DEFAULT_FIT_METRICS = ("tip_model", "lookup_vs_truth_rmse_mm", "lookup_vs_truth_max_mm",
                       "lookup_vs_truth_points")


def default_fit_quantities(raw_grid: Path, workdir: Path, fit_args: list[str]) -> dict[str, Any]:
    """Fit ``raw_grid`` as `whiskercal fit RAW [fit_args]` does (the defaults, with the golden
    file's degree and samples) and name what it guarantees: ``default.fit.*`` (the decisions and
    the truth errors), ``default.lookup.*`` (the tip curve) and ``default.table.*`` (a subgrid
    of the (Y, Z) table's cells, NaN where the table has no tip, and the share of all its cells
    that hold one)."""
    from whiskercal.artifacts.calibration import read_calibration

    artifact = workdir / f"{raw_grid.parent.name}-default-calibration.h5"
    run_fit(raw_grid, artifact, fit_args)
    return default_quantities(read_calibration(artifact))


def default_quantities(data) -> dict[str, Any]:
    """The ``default.*`` quantities of a calibration artifact's content (``CalibrationData``)."""
    fitted = {key: value for key, value in fit_quantities(data).items()
              if key.split(".", 1)[1] in DEFAULT_FIT_METRICS + ("tip_error_warned",
                                                                "field_table_written")}
    fitted["fit.load_branches_written"] = data.load_branches is not None
    found = {**fitted, **lookup_quantities(data), **_table_quantities(data.field_table)}
    return {f"default.{name}": value for name, value in found.items()}


def _table_quantities(table: dict | None) -> dict[str, Any]:
    """The (Y, Z) table's axes and tips on every ``TABLE_STRIDE``-th row and column, and the
    share of its cells holding a tip."""
    if table is None:
        return {}
    rows = range(0, len(table["y_uT"]), TABLE_STRIDE)
    cols = range(0, len(table["axial_uT"]), TABLE_STRIDE)
    found: dict[str, Any] = {}
    for i in rows:
        found[f"table.y_uT[{i:03d}]"] = float(table["y_uT"][i])
    for j in cols:
        found[f"table.axial_uT[{j:03d}]"] = float(table["axial_uT"][j])
    tips = np.asarray(table["tip_mm"], float)
    found["table.answered_share"] = float(np.mean(np.all(np.isfinite(tips), axis=-1)))
    for i in rows:
        for j in cols:
            found[f"table.tip_x_mm[{i:03d},{j:03d}]"] = float(tips[i, j, 0])
            found[f"table.tip_y_mm[{i:03d},{j:03d}]"] = float(tips[i, j, 1])
    return found
