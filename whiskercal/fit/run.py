"""``fit``: a raw calibration grid -> its calibration, metrics, warnings and provenance."""

from __future__ import annotations

import math
import platform
from contextlib import ExitStack
from dataclasses import asdict, replace
from typing import TYPE_CHECKING, Callable

import numpy as np
from threadpoolctl import threadpool_limits

from whiskercal.fit.contact_threshold import contact_threshold, threshold_warnings
from whiskercal.fit.metrics import (evidence_metrics, raw_metrics,
                                    surface_and_lookup_metrics)
from whiskercal.fit.options import FitOptions
from whiskercal.fit.result import FitResult
from whiskercal.fit.shaft_surface import shaft_surface_for
from whiskercal.fit.timings import StageTimes
from whiskercal.fit.tip_model import (adopt_joint_lookup, choose_tip_model,
                                      refuse_unless_resolved)
from whiskercal.fit.trace_length import resolve_trace_length
from whiskercal.fit.truth import (compare_with_twin_truth, refuse_z_against_truth,
                                  true_tip_curve, truth_sensor)
from whiskercal.mechfit.workers import InBackground
from whiskercal.model.calibrate import (Calibration, CalibrationOptions, calibrate,
                                        calibrate_surface, trace_lookup)
from whiskercal.model.errors import ExtrapolationLimitError, FitError, ModelError

if TYPE_CHECKING:
    from whiskercal.artifacts.raw_grid import RawGrid


def fit(raw: RawGrid, options: FitOptions = FitOptions(),
        progress: Callable[[str], None] | None = None) -> FitResult:
    """Calibrate a raw grid: what ``whiskercal fit`` does, short of reading and writing files.

    Resolves the trace length, fits the surface and the lookup (``model.calibrate``), records
    the metrics, and measures the lookup against the twin's true tips when the grid came from
    the twin. ``FitResult.write`` writes the artifact.

    Parameters
    ----------
    raw : RawGrid
        The raw grid (``artifacts.raw_grid.read_raw_grid``).
    options : FitOptions
    progress : callable(str), optional
        Told the name of each stage of the calibration as it starts; the stages' wall times
        come back in ``FitResult.timings_s``.

    Raises
    ------
    UsageError
        The trace length is unknown (give ``trace_length_mm``), or the model refuses the grid
        (``model.errors``: too few points, a degree out of range, a grid that stops short of
        the tip without ``allow_extrapolation``...).
    """
    # The fit's linear algebra is on matrices of a few hundred rows at most, and it is called
    # thousands of times: waking BLAS threads for each costs more than they save (most in the
    # table's interpolant, a small solve per triangle), the more so on a busy machine.
    with threadpool_limits(limits=1, user_api="blas"), ExitStack() as background:
        return _fit(raw, options, progress, background)


def _fit(raw: RawGrid, options: FitOptions, progress: Callable[[str], None] | None,
         background: ExitStack) -> FitResult:
    """``fit``'s stages, on one BLAS thread; the jobs it starts on other CPUs end with
    ``background``, whether it returns or raises."""
    refuse_z_against_truth(raw)
    times = StageTimes(progress)
    length_mm, length_warnings = resolve_trace_length(raw, options.trace_length_mm)
    model_options = options.calibration_options(length_mm)
    grid = level_set_points(raw)  # the shaft contacts; the tip sweep is the mechanics' alone
    # the twin's true tip curve depends on the sensor alone: made on another CPU meanwhile
    sensor = truth_sensor(grid)
    truth_curve = (None if sensor is None
                   else background.enter_context(InBackground(true_tip_curve, sensor)))
    with times.stage("level_set"):
        calibration, untraceable = calibrate_grid(raw, model_options, progress)
    with times.stage("mechanics", "mechanics-informed tip model and the error estimate"):
        calibration, tip_model = choose_tip_model(raw, calibration, options.tip_model,
                                                  length_mm, options.samples, untraceable)
    # the shaft localizer's surface needs the grid and the mechanics alone: fitted on another
    # CPU while the joint fit runs (its stage's time is then the wait for it)
    shaft_surface = background.enter_context(
        InBackground(shaft_surface_for, grid, length_mm, tip_model.mechanics))
    table = _field_table(raw, length_mm, options, times, tip_model.mechanics)
    if table is not None:
        calibration, tip_model = adopt_joint_lookup(calibration, tip_model, table.z_lookup,
                                                    options.tip_model)
    tip_model = refuse_unless_resolved(tip_model, options.tip_model,
                                       table is not None and table.trusted,
                                       math.nan if table is None else table.y_alone_mm)
    with times.stage("truth"):
        truth = compare_with_twin_truth(grid, calibration,
                                        None if truth_curve is None else truth_curve.result())
    with times.stage("shaft_surface"):
        shaft = shaft_surface.result()
    threshold = contact_threshold(options.threshold_uT, tip_model.mechanics,
                                  float(np.median(raw.z_std_uT)))
    metrics = {**surface_and_lookup_metrics(calibration), **evidence_metrics(calibration),
               **raw_metrics(raw), **tip_model.metrics, **threshold.metrics(),
               **(truth.metrics() if truth is not None else {}),
               **(table.metrics if table is not None else {}), **_shaft_metrics(shaft)}
    return FitResult(calibration, options, model_options, metrics,
                     length_warnings + _level_set_warnings(calibration, tip_model)
                     + tip_model.warnings
                     + (table.warnings if table is not None else [])
                     + threshold_warnings(threshold), truth,
                     raw.sensor_id,
                     raw.rod_radius_mm, inputs={"raw_grid": raw.sha256},
                     config=_provenance(model_options, raw.path),
                     field_table=None if table is None else table.table, shaft_surface=shaft,
                     load_branches=None if table is None else table.branches,
                     timings_s=times.seconds)


def _level_set_warnings(calibration: Calibration, tip_model) -> list[str]:
    """The surface's and the level set's warnings, said of the level set where another tip
    model ships: a trace that scatters by millimetres does not make the mechanics' tips do so."""
    if tip_model.name == "level-set":
        return list(calibration.warnings)
    return [f"the level set (not shipped: {tip_model.name} ships): {w}"
            for w in calibration.warnings]


def _field_table(raw: RawGrid, length_mm: float, options: FitOptions, times: StageTimes,
                 mechanics):
    """The (Y, Z) -> tip table (``fit.field_table``; on unless ``--no-field-table``), else None;
    its joint fit starts from the z lookup's ``mechanics`` calibration when there is one, and
    its own z lookup may become the tip model (``fit.tip_model.adopt_joint_lookup``). Its
    stages are timed in ``times``."""
    if not options.field_table:
        return None
    from whiskercal.fit.field_table import fit_field_table

    return fit_field_table(raw, length_mm, None if mechanics is None else mechanics.fit,
                           options.samples, times)


def _shaft_metrics(shaft) -> dict:
    """The shaft localizer's surface as the artifact's metrics record it (µT)."""
    if shaft is None:
        return {"shaft_surface_source": "none"}
    return {"shaft_surface_rmse_uT": shaft.rmse_uT, "shaft_surface_source": shaft.source}


def z_sem_uT(raw: RawGrid) -> np.ndarray:
    """Standard error (n,) µT of each grid point's mean z."""
    return raw.z_sem_uT


def level_set_points(raw):
    """The points the level set is fitted to: the grid's, the tip sweep's left out (the level
    set f = z is a surface over shaft contacts; the sweep is the mechanics' alone)."""
    sweep = getattr(raw, "sweep", None)
    return raw if sweep is None or not np.any(sweep) else raw.without_sweep()


def calibrate_raw(raw: RawGrid, options: CalibrationOptions,
                  progress: Callable[[str], None] | None = None) -> Calibration:
    """``model.calibrate`` on a raw grid's points, with the standard errors of their means."""
    raw = level_set_points(raw)
    return calibrate(raw.rod_center_mm, raw.z_uT, raw.rod_radius_mm, options, z_sem_uT(raw),
                     progress)


def calibrate_grid(raw: RawGrid, options: CalibrationOptions,
                   progress) -> tuple[Calibration, ModelError | None]:
    """``calibrate_raw`` with the refusal of a short grid told how to proceed.

    When the level set cannot be traced at all, the surface alone and why: the tip model
    may still come from the mechanics (``fit.tip_model``), which decides whether to refuse.
    """
    raw = level_set_points(raw)
    calibration = calibrate_surface(raw.rod_center_mm, raw.z_uT, raw.rod_radius_mm, options,
                                    z_sem_uT(raw), progress)
    surface_warnings = list(calibration.warnings)
    try:
        trace_lookup(calibration, options, progress)
    except ExtrapolationLimitError as error:
        raise ExtrapolationLimitError(f"{error}; collect a grid that reaches farther, or pass "
                                      "--allow-extrapolation to mark that range") from None
    except FitError:
        raise
    except ModelError as error:
        return replace(calibration, lookup=None, lookup_report=None,
                       warnings=surface_warnings), error
    return calibration, None


def _provenance(options: CalibrationOptions, raw_path: str) -> dict:
    import scipy

    return {"options": asdict(options), "raw_grid": str(raw_path),
            "versions": {"python": platform.python_version(), "numpy": np.__version__,
                         "scipy": scipy.__version__}}
