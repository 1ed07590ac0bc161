"""What a fit gives back: the calibration with its metrics, warnings, truth and provenance."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from whiskercal.fit.options import FitOptions
from whiskercal.fit.shaft_surface import ShaftSurfaceFit
from whiskercal.fit.truth import TruthComparison
from whiskercal.model.calibrate import Calibration, CalibrationOptions


@dataclass
class FitResult:
    """A raw grid's calibration, ready to be written as the calibration artifact.

    Attributes
    ----------
    calibration : Calibration
        The fitted models (surface, level-set problem, lookup) and their evidence.
    options : FitOptions
        The options the fit was asked for.
    calibration_options : CalibrationOptions
        What the model ran with: ``options`` with the trace length resolved.
    metrics : dict
        The artifact's /metrics (µT, mm), warnings apart; ``collision_threshold_uT`` is the
        threshold the artifact stores (``fit.contact_threshold``).
    warnings : list of str
        Sentences with their numbers: a recorded trace length overridden, an under-fitting
        surface, a marked extrapolated range, a large tip spread.
    truth : TruthComparison or None
        The calibration against the twin's truth; None for a real rig's grid.
    sensor_id : str
    rod_radius_mm : float
    inputs : dict
        Input name -> SHA-256 (``raw_grid``).
    config : dict
        Provenance: the model's options, the raw grid's path, the numerical libraries' versions.
    shaft_surface : ShaftSurfaceFit or None
        The shaft localizer's own surface (``fit.shaft_surface``); None when it cannot be fitted.
    """

    calibration: Calibration
    options: FitOptions
    calibration_options: CalibrationOptions
    metrics: dict[str, Any]
    warnings: list[str]
    truth: TruthComparison | None
    sensor_id: str
    rod_radius_mm: float
    inputs: dict[str, str] = field(default_factory=dict)
    config: dict[str, Any] = field(default_factory=dict)
    field_table: dict[str, Any] | None = None
    """The (Y, Z) -> tip table's arrays (``fit.field_table``), None without ``--field-table``."""
    shaft_surface: ShaftSurfaceFit | None = None
    load_branches: dict[str, Any] | None = None
    """The loads the runtime follows where the table is withheld (``fit.field_table``)."""
    timings_s: dict[str, float] = field(default_factory=dict)
    """Wall time (s) per stage of the fit (``fit.timings.StageTimes``); not in the artifact."""

    def artifact_data(self):
        """The calibration artifact's content (a :class:`~whiskercal.artifacts.calibration.CalibrationData`)."""
        from dataclasses import replace

        from whiskercal.artifacts.calibration import data_from_calibration
        from whiskercal.model.collision import CollisionParams
        from whiskercal.model.kalman import KalmanParams

        data = data_from_calibration(
            self.calibration, sensor_id=self.sensor_id, rod_radius_mm=self.rod_radius_mm,
            tracer=self.calibration_options.tracer, kalman=KalmanParams(),
            collision=CollisionParams(threshold_uT=self.metrics["collision_threshold_uT"]),
            metrics={**self.metrics, "warnings": list(self.warnings)},
            truth=None if self.truth is None else self.truth.arrays(),
            inputs=self.inputs, config=self.config)
        if self.field_table is not None:
            data = replace(data, field_table=self.field_table)
        if self.load_branches is not None:
            data = replace(data, load_branches=self.load_branches)
        if self.shaft_surface is not None:
            from whiskercal.artifacts.shaft_surface import data_of

            shaft = self.shaft_surface
            data.shaft_surface = data_of(shaft.surface, shaft.rmse_uT, shaft.source,
                                         shaft.mechanics_points, shaft.cv_rmse_uT)
        return data

    def write(self, path: str | Path) -> Path:
        """Write the calibration artifact (HDF5, replaced whole) and return its path."""
        from whiskercal.artifacts.calibration import write_calibration

        return write_calibration(path, self.artifact_data())
