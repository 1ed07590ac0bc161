"""Shaft contact localizers compared: accuracy against travel since contact, cost per sample.

A short shaft study runs on the twin (``whiskercal.shaftstudy``, through the simulated serial
ports), and three measurement surfaces are fitted to the twin's default grid (seeded noise of the
averaged reading): the tip model's at degree 5 (the fit's default) and degree 7, and the shaft
surface ``fit`` stores for the localizer (``fit.shaft_surface``: a degree-8 middle and root and
tip patches from the grid plus the fitted mechanics). Each candidate localizer (batch
Gauss-Newton of ``model.shaft`` with two batch sizes, the particle filter of ``model.shaft_pf``)
tracks every trial sample by sample through ``runtime_shaft.ShaftTracker``; errors are against
the twin's true contact point. Rows pool the trials from 30 % to 95 % of the trace length (the
goal's range); ``root_error_mm`` is the trials at 20 %, the goal's 1 mm line.
"""

from __future__ import annotations

import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from whiskercal.testing.twin_grid import (AVERAGED_NOISE_UT, calibrate_grid, noisy_z, raw_like,
                                        simulate_grid)
from whiskercal.fit.shaft_surface import fit_shaft_surface
from whiskercal.mechfit.identify import calibrate_mechanics
from whiskercal.model.calibrate import contact_mask
from whiskercal.model.shaft import ShaftLocalizer, ShaftParams
from whiskercal.model.shaft_pf import ParticleLocalizer
from whiskercal.runtime_shaft import (SAMPLE_NOISE_UT, SHAFT_SURFACE_MISFIT_LENGTH_MM,
                                      ShaftTracker)
from whiskercal.shaftstudy.config import load_config
from whiskercal.shaftstudy.report import track_trial, trial_row
from whiskercal.shaftstudy.run import run_shaft_study
from whiskercal.artifacts.shaft_study import read_shaft_study

TRAVEL_BINS_MM = (1.0, 2.0, 3.0, 5.0, 8.0, 12.0)


def _study(quick: bool) -> list:
    config = load_config()
    if quick:
        config["trials"]["fractions"] = [0.2, 0.4, 0.7]
        config["trials"]["approach_deg"] = [0.0]
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "shaft.h5"
        run_shaft_study("sim://bench-shaft/stage", "sim://bench-shaft/sensor", path, config)
        return read_shaft_study(path).trials


SHAFT = "shaft"  # the surface column of the shaft surface's rows


def _candidates(quick: bool) -> list[tuple[str, int | str, callable]]:
    """(method, surface: a tip-model degree or ``SHAFT``, make localizer from surface, params)."""
    methods = [("batch-gn-96", lambda s, p: ShaftLocalizer(s, p)),
               ("batch-gn-48", lambda s, p: ShaftLocalizer(s, replace(p, max_points=48))),
               ("particles-1000", lambda s, p: ParticleLocalizer(s, p, particles=1000))]
    surfaces = (5, SHAFT) if quick else (5, 7, SHAFT)
    return [(name, surface, make) for surface in surfaces for name, make in methods]


def _surfaces(grid, quick: bool) -> dict:
    """Each candidate surface of one noisy grid: (surface, its misfit on the grid µT)."""
    z = noisy_z(grid)
    out = {}
    for degree in ((5,) if quick else (5, 7)):
        model = calibrate_grid(grid, z, degree=degree)
        out[degree] = (model.surface, float(model.fit.rmse_uT))
    length = grid.sensor.whisker.reach_mm
    raw = raw_like(grid.rod_center_mm, z, AVERAGED_NOISE_UT, grid.rod_radius_mm)
    used = contact_mask(z, raw.z_sem_uT)  # as fit's tip model does: contacts only
    mechanics = calibrate_mechanics(grid.rod_center_mm[used], z[used], grid.rod_radius_mm,
                                    length, AVERAGED_NOISE_UT)
    shaft = fit_shaft_surface(raw.rod_center_mm, z, raw.z_sem_uT, raw.rod_radius_mm, length,
                              mechanics)
    # the misfit the runtime uses (runtime_shaft.shaft_surface_of): on or between the columns
    out[SHAFT] = (shaft.surface, float(np.nanmax([shaft.rmse_uT, shaft.cv_rmse_uT])))
    return out


def _row(name: str, degree, make, surface_misfit, length: float, trials) -> dict:
    surface, misfit = surface_misfit
    params = ShaftParams(noise_uT=float(np.hypot(SAMPLE_NOISE_UT, misfit)), systematic_uT=misfit,
                         search_x_mm=(5.0, length))
    if degree == SHAFT:  # as the runtime sets it for the shaft surface
        params = replace(params, misfit_length_mm=SHAFT_SURFACE_MISFIT_LENGTH_MM)
    series = [track_trial(None, trial, ShaftTracker(surface, params, length,
                                                    localizer=make(surface, params)))
              for trial in trials]
    rows = [trial_row(s, 0.0) for s in series]
    goal = [r for r in rows if 0.3 * length <= r.radial_mm <= 0.95 * length + 1e-6]
    root = [r.median_error_mm for r in rows if r.radial_mm < 0.25 * length]
    binned = {}
    for bin_mm in TRAVEL_BINS_MM:
        errors = [s.error_mm[np.abs(s.travel_mm - bin_mm) < 0.25] for s in series
                  if 0.3 * length <= s.radial_mm]
        errors = np.concatenate(errors) if errors else np.zeros(0)
        binned[f"{bin_mm:g}"] = float(np.nanmedian(errors)) if np.any(np.isfinite(errors)) else None
    label = f"{name} shaft surface" if degree == SHAFT else f"{name} deg {degree}"
    return {"method": name, "degree": degree, "label": label,
            "median_error_mm": float(np.nanmedian([r.median_error_mm for r in goal])),
            "worst_median_error_mm": float(np.nanmax([r.median_error_mm for r in goal])),
            "root_error_mm": [float(e) for e in root],
            "ms_per_sample": float(np.mean([r.ms_per_sample for r in rows])),
            "s_per_sample": float(np.mean([r.ms_per_sample for r in rows])) / 1e3,
            "median_error_by_travel_mm": binned,
            "default": name == "batch-gn-96" and degree == SHAFT}


def run(quick: bool = False, progress=None) -> dict:
    """Every candidate on one shaft study; rows and a Pareto spec (time per sample vs error)."""
    trials = _study(quick)
    grid = simulate_grid()
    surfaces = _surfaces(grid, quick)
    length = grid.sensor.whisker.reach_mm
    rows = []
    for name, degree, make in _candidates(quick):
        rows.append(_row(name, degree, make, surfaces[degree], length, trials))
        if progress is not None:
            progress(rows[-1])
    return {"rows": rows, "trials": len(trials),
            "pareto": {"x": "s_per_sample", "y": "median_error_mm", "series": ["method"],
                       "label": "degree", "x_label": "time per sample (s)",
                       "y_label": "median contact error after 5 mm travel, 30-95 % (mm)"},
            "supports": {"localizer": "batch-gn-96", "surface": SHAFT,
                         "rule": "the batch Gauss-Newton localizer on the shaft surface: "
                                 "sub-millimetre from 20 % of the trace to 95 %, under 1 ms a "
                                 "sample; the surface bounds its accuracy"}}
