"""Warnings about a calibration that succeeded but should not be trusted blindly.

Each check returns a sentence with its numbers, or None; ``whiskercal fit`` prints them and
stores them in the artifact's metrics (``warnings``). Failures that make a number wrong are
raised instead (``whiskercal/model/errors.py``); these are the ones a user must judge.
"""

from __future__ import annotations

import numpy as np

from whiskercal.model.surface import MAX_DEGREE, Surface

# The surface "under-fits" when its cross-validated error is more than this many times the
# noise expected at the grid points. A surface that fits to the noise has a CV RMSE of about
# the noise times sqrt(1 + terms / points), 1.05 to 1.15 for 21..45 terms on 180 points. At 5x
# the surface's own error is clearly the larger one (sqrt(5² - 1) = 4.9 times the noise), while
# ratios of 2..4 may still be error the standard error of the mean does not count (the stage's
# positioning, baseline drift). The twin's default grid, whose noise is small and white, lies far
# above it, so the level-set shift below decides whether it warns (docs/model.md).
UNDERFIT_FACTOR = 5.0
# ... and only when that error moves level sets by more than this (mm). Below it, a closer fit
# cannot move the tips by more than about a tenth of a millimetre, far inside the level-set
# method's own error against the true tip (``bench --only surface-degree`` shows both), so a
# residual above the noise that moves no tip is no under-fit that matters.
UNDERFIT_SHIFT_MM = 0.1


def expected_noise_uT(z_sem_uT: np.ndarray) -> float:
    """RMS standard error (µT) of the grid points' mean z: the error a perfect surface would show."""
    sem = np.asarray(z_sem_uT, float)
    sem = sem[np.isfinite(sem)]
    return float(np.sqrt(np.mean(sem ** 2))) if sem.size else float("nan")


def level_set_shift_mm(surface: Surface, points_mm: np.ndarray, error_uT: float) -> float:
    """How far (mm) a surface error of ``error_uT`` moves a level set, at the median |grad f|
    over ``points_mm``: the error's size in the units the tip is measured in."""
    gradient = np.linalg.norm(surface.gradient(np.asarray(points_mm, float)), axis=-1)
    return float(error_uT / np.median(gradient))


def underfit_warning(cv_rmse_uT: float, noise_uT: float, shift_mm: float, degree: int,
                     factor: float = UNDERFIT_FACTOR,
                     min_shift_mm: float = UNDERFIT_SHIFT_MM) -> str | None:
    """A sentence when the CV RMSE exceeds ``factor`` times the expected noise and moves level
    sets by more than ``min_shift_mm``, else None.

    Parameters
    ----------
    cv_rmse_uT : float
        The surface's k-fold cross-validated RMSE (µT).
    noise_uT : float
        RMS standard error of the grid points' mean z (µT), :func:`expected_noise_uT`.
    shift_mm : float
        The CV RMSE expressed as a level-set shift (mm), :func:`level_set_shift_mm`.
    degree : int
        The surface's degree (the advice differs at the highest one).
    """
    if not (np.isfinite(cv_rmse_uT) and np.isfinite(noise_uT) and noise_uT > 0):
        return None
    ratio = cv_rmse_uT / noise_uT
    if ratio <= factor or not shift_mm > min_shift_mm:
        return None
    advice = ("a higher degree fits closer" if degree < MAX_DEGREE
              else f"degree {MAX_DEGREE} is the highest: the polynomial cannot follow the data")
    return (f"the surface under-fits: its CV RMSE {cv_rmse_uT:.1f} µT is {ratio:.1f} times the "
            f"{noise_uT:.2f} µT noise expected at the grid points (more than {factor:g} times); "
            f"it moves level sets by about {shift_mm:.3f} mm ({advice})")
