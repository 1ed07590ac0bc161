"""From a raw grid to a calibration: rod-radius correction, surface, level-set problem, lookup.

Arrays in, arrays out; reading the raw file and writing the artifact happen elsewhere.

Steps (docs/model.md says why each is done the way it is):

1. Drop points without contact (z indistinguishable from the static reading).
2. Fit the surface to the rod centres once, and move every point by the rod radius along the
   local level-set normal, toward the side the whisker was pushed to: the shaft passes one rod
   radius from the rod's centre. Refit on the corrected points.
3. The level-set problem: domain = hull of the corrected points plus a margin; the trace enters
   the data at ``entry_radius_mm`` and may extend straight past the grid's far edge.
4. The lookup over the traceable z range, its interpolant chosen by hold-out.
5. The extrapolation check: where a tip lies more than ``max_extension_mm`` past the grid's far
   edge, the calibration is refused, or (``allow_extrapolation``) that part of the z range is
   marked as untrusted and the lookup refuses it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from whiskercal.model.diagnostics import expected_noise_uT, level_set_shift_mm, underfit_warning
from whiskercal.model.errors import ExtrapolationLimitError, FitError
from whiskercal.model.lookup import (LookupReport, TipLookup, bisect_end, build_lookup,
                                     traces_ok)
from whiskercal.model.surface import FitReport, Surface, fit_surface
from whiskercal.model.trace import Domain, LevelSetProblem, far_edge_radius
from whiskercal.model.uncertainty import scatter_warning, tip_spread_mm

# Level sets within about a third of the whisker from the root are shaped by the suspension's
# translation (the rod pushes hard that close) more than by the bending that the tip sees, on
# grids that reach that close; the tip error is flat around this entry on the recorded grids.
ENTRY_FRACTION_OF_TRACE = 1.0 / 3.0
# The fit keeps points from this far inside the entry circle (about one grid step), so the
# surface is interpolated, not extrapolated, on the entry circle.
FIT_MARGIN_INSIDE_ENTRY_MM = 3.0
# How far past the grid's far edge the trace may be extended straight (mm, beyond the gap
# between the farthest grid point and the trace length).
EXTENSION_ALLOWANCE_MM = 8.0
# How far past the grid's far edge a tip may be extrapolated and still be trusted (mm): on the
# twin's default sensor with the default grid cut shorter and on coarser lattices, the extension
# just short of where the lookup's RMS error against the true tips passes 0.5 mm.
MAX_EXTENSION_MM = 9.5


@dataclass(frozen=True)
class CalibrationOptions:
    """Choices of ``whiskercal fit`` (mm, µT)."""

    degree: int | str = 5
    coordinates: str = "polar"
    samples: int = 20
    tracer: str = "fast"
    lookup_kind: str = "auto"
    trace_length_mm: float = 78.0
    root_mm: tuple[float, float] = (0.0, 0.0)
    entry_radius_mm: float | None = None
    domain_margin_mm: float = 1.0
    correct_rod_radius: bool = True
    fit_traced_region_only: bool = True
    min_standard_errors: float = 5.0
    folds: int = 5
    seed: int = 0
    max_extension_mm: float = MAX_EXTENSION_MM
    allow_extrapolation: bool = False


@dataclass
class Calibration:
    """The fitted models and their evidence."""

    surface: Surface
    fit: FitReport
    problem: LevelSetProblem
    lookup: TipLookup | None              # None until ``trace_lookup``
    lookup_report: LookupReport | None
    contact_points_mm: np.ndarray
    z_uT: np.ndarray
    used: np.ndarray                      # mask of the raw points used
    rod_shift_mm: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    extension_limit_mm: float = MAX_EXTENSION_MM
    # the part of the lookup's range whose tips lie within the limit; None: no part does
    trusted_z_uT: tuple[float, float] | None = None
    extrapolated: bool = False            # some of the lookup's range lies beyond the limit
    warnings: list[str] = field(default_factory=list)  # sentences with their numbers
    expected_noise_uT: float = float("nan")  # RMS standard error of the used points' mean z
    cv_level_set_shift_mm: float = float("nan")  # the CV RMSE as a level-set shift
    tip_spread_mm: float = float("nan")  # RMS tip move when the grid's scatter is redrawn


def correct_for_rod(rod_center_mm: np.ndarray, z_uT: np.ndarray, rod_radius_mm: float,
                    surface: Surface) -> np.ndarray:
    """Contact points (n, 2) mm: rod centres moved by the radius along the level-set normal.

    The rod pushes the whisker toward larger |z|, so the shaft lies on that side of the rod:
    along sign(median z) * grad f / |grad f|.
    """
    gradient = surface.gradient(rod_center_mm)
    norm = np.linalg.norm(gradient, axis=1, keepdims=True)
    if np.any(norm == 0):
        raise FitError("the surface is flat at a grid point: cannot tell the rod's side")
    deeper = np.sign(np.median(z_uT)) or -1.0
    return rod_center_mm + rod_radius_mm * deeper * gradient / norm


def contact_mask(z_uT: np.ndarray, z_sem_uT: np.ndarray | None = None,
                 min_standard_errors: float = 5.0) -> np.ndarray:
    """Points that carry shape information: finite z, distinguishable from the static reading.

    A rod that misses the whisker (near the suspension, or past the tip) leaves z at the static
    reading; such a point says nothing about the level sets and would pin f to 0 where the
    whisker never was. It is dropped when |z| < ``min_standard_errors`` standard errors of its
    mean (``z_sem_uT``, µT).
    """
    mask = np.isfinite(z_uT)
    if z_sem_uT is not None:
        mask &= np.abs(z_uT) > min_standard_errors * np.asarray(z_sem_uT, float)
    return mask


def calibrate(rod_center_mm: np.ndarray, z_uT: np.ndarray, rod_radius_mm: float,
              options: CalibrationOptions = CalibrationOptions(),
              z_sem_uT: np.ndarray | None = None, progress=None) -> Calibration:
    """Fit the surface, build the level-set problem and the lookup from a raw grid.

    Parameters
    ----------
    rod_center_mm : ndarray (n, 2)
        Rod centres in the whisker frame, mm.
    z_uT : ndarray (n,)
        Deflection per point (Y field minus static), µT.
    rod_radius_mm : float
        Touch rod radius, mm.
    options : CalibrationOptions
    z_sem_uT : ndarray (n,), optional
        Standard error of each point's mean z (µT); points within ``min_standard_errors`` of
        zero are taken as no contact, and a CV RMSE far above it is warned of (``warnings``).
    progress : callable(str), optional
        Told the name of each stage as it starts.
    """
    calibration = calibrate_surface(rod_center_mm, z_uT, rod_radius_mm, options, z_sem_uT,
                                    progress)
    trace_lookup(calibration, options, progress)
    return calibration


def calibrate_surface(rod_center_mm: np.ndarray, z_uT: np.ndarray, rod_radius_mm: float,
                      options: CalibrationOptions = CalibrationOptions(),
                      z_sem_uT: np.ndarray | None = None, progress=None) -> Calibration:
    """``calibrate`` up to the level-set problem: the surface and its evidence, no lookup yet
    (``trace_lookup`` adds it; a tip model of another kind may stand in where it cannot)."""
    say = progress or (lambda _message: None)
    rod_center_mm, z_uT = np.asarray(rod_center_mm, float), np.asarray(z_uT, float)
    z_sem_uT = None if z_sem_uT is None else np.asarray(z_sem_uT, float)
    used = contact_mask(z_uT, z_sem_uT, options.min_standard_errors)
    _check_enough(used)  # before the traced region: an empty grid has no nearest point
    used &= _traced_region(rod_center_mm, options)
    _check_enough(used)
    points, z = rod_center_mm[used], z_uT[used]
    say("fitting the surface")
    if options.correct_rod_radius and rod_radius_mm > 0:
        first, _ = fit_surface(points, z, options.degree, options.coordinates, options.folds,
                               options.seed)
        points = correct_for_rod(points, z, rod_radius_mm, first)
    surface, report = fit_surface(points, z, options.degree, options.coordinates, options.folds,
                                  options.seed)
    problem = build_problem(surface, points, z, options)
    calibration = Calibration(surface, report, problem, None, None, points, z, used,
                              points - rod_center_mm[used], float(options.max_extension_mm))
    _check_fit(calibration, None if z_sem_uT is None else z_sem_uT[used])
    return calibration


def trace_lookup(calibration: Calibration, options: CalibrationOptions, progress=None) -> None:
    """Trace the lookup of a ``calibrate_surface`` result, check its extrapolation and scatter.

    Raises a ModelError (a TraceError or one of its kinds) when the level set cannot be traced
    soundly, ExtrapolationLimitError when the grid stops too far short of the tip.
    """
    say = progress or (lambda _message: None)
    say(f"tracing {options.samples} tips and the hold-out set")
    calibration.lookup, calibration.lookup_report = build_lookup(
        calibration.problem, options.samples, options.tracer, options.lookup_kind)
    _note_untraced(calibration)
    _check_extrapolation(calibration, options)
    say("redrawing the grid's scatter")
    _check_scatter(calibration, options.seed)


def _note_untraced(calibration: Calibration) -> None:
    """Warn of the levels inside the range the tracer could not follow (bridged in the lookup)."""
    report = calibration.lookup_report
    if report.untraced_z_uT.size == 0:
        return
    where = ", ".join(f"{z:.0f}" for z in report.untraced_z_uT)
    calibration.warnings.append(
        f"the level set at z = {where} µT could not be traced ({report.untraced_reason}); "
        "skipped: the lookup bridges it from the traced levels beside it")


def _check_enough(used: np.ndarray, least: int = 10) -> None:
    """Refuse a grid with fewer than ``least`` usable points (FitError)."""
    if used.sum() < least:
        raise FitError(f"only {int(used.sum())} grid points with contact: too few to calibrate")


def _check_extrapolation(calibration: Calibration, options: CalibrationOptions) -> None:
    """Refuse, or mark, the z whose tips lie beyond ``max_extension_mm`` past the grid."""
    lookup, report = calibration.lookup, calibration.lookup_report
    trusted = trusted_z_range(calibration.problem, lookup, report, options)
    calibration.trusted_z_uT = trusted
    calibration.extrapolated = trusted != (lookup.z_min_uT, lookup.z_max_uT)
    if not calibration.extrapolated:
        return
    message = extrapolation_message(lookup, report, trusted, options.max_extension_mm)
    if not options.allow_extrapolation:
        raise ExtrapolationLimitError(message)
    calibration.warnings.append(f"{message}; that range is marked and the runtime refuses it")
    if trusted is not None:
        calibration.lookup = TipLookup(lookup.z_knots_uT, lookup.tips_mm, lookup.kind, trusted)


def _check_fit(calibration: Calibration, z_sem_uT: np.ndarray | None) -> None:
    """Warn when the surface's CV RMSE lies far above the noise of the points it was fitted to."""
    noise = expected_noise_uT(z_sem_uT) if z_sem_uT is not None else float("nan")
    shift = level_set_shift_mm(calibration.surface, calibration.contact_points_mm,
                               calibration.fit.cv_rmse_uT)
    calibration.expected_noise_uT, calibration.cv_level_set_shift_mm = noise, shift
    underfit = underfit_warning(calibration.fit.cv_rmse_uT, noise, shift,
                                calibration.surface.degree)
    if underfit:
        calibration.warnings.insert(0, underfit)


def _check_scatter(calibration: Calibration, seed: int) -> None:
    """Warn when the grid's scatter about the surface moves the traced tips too far."""
    lookup = calibration.lookup  # its range is the trusted one when part was extrapolated
    z_range = (lookup.z_min_uT, lookup.z_max_uT)
    calibration.tip_spread_mm = tip_spread_mm(calibration.problem, calibration.contact_points_mm,
                                              calibration.fit.rmse_uT, z_range, seed)
    warning = scatter_warning(calibration.tip_spread_mm, calibration.fit.rmse_uT)
    if warning:
        calibration.warnings.append(warning)


def trusted_z_range(problem: LevelSetProblem, lookup: TipLookup, report: LookupReport,
                    options: CalibrationOptions) -> tuple[float, float] | None:
    """The part of the lookup's z range (µT) whose tips lie at most ``max_extension_mm`` past the
    grid's far edge: the whole range when no trace needed more, None when none manages with less.

    The traces are repeated with the extension capped at the limit, bisecting each end inward
    from the lookup sample that needed the least extension.
    """
    full = (lookup.z_min_uT, lookup.z_max_uT)
    if report.max_extension_mm <= options.max_extension_mm:
        return full
    capped = replace(problem, z_range_uT=full,
                     tip_extension_mm=min(problem.tip_extension_mm, options.max_extension_mm))
    bridged = np.isin(lookup.z_knots_uT, report.untraced_z_uT)  # no trace to start from there
    seed = float(lookup.z_knots_uT[int(np.argmin(np.where(bridged, np.inf,
                                                          report.knot_extension_mm)))])
    if not traces_ok(capped, options.tracer, seed):
        return None
    return (bisect_end(capped, options.tracer, seed, full[0], 12),
            bisect_end(capped, options.tracer, seed, full[1], 12))


def extrapolation_message(lookup: TipLookup, report: LookupReport,
                          trusted: tuple[float, float] | None, limit_mm: float) -> str:
    """One sentence: which z the grid does not reach far enough for, and by how much."""
    low, high = float(lookup.z_knots_uT[0]), float(lookup.z_knots_uT[-1])
    if trusted is None:
        where = f"every z in [{low:.0f}, {high:.0f}] µT"
    else:
        parts = [f"[{a:.0f}, {b:.0f}]" for a, b in ((low, trusted[0]), (trusted[1], high)) if b > a]
        where = f"z in {' and '.join(parts)} µT (trusted: [{trusted[0]:.0f}, {trusted[1]:.0f}] µT)"
    return (f"the grid stops short of the tip: for {where} the trace runs up to "
            f"{report.max_extension_mm:.1f} mm straight past the grid's far edge, more than the "
            f"{limit_mm:.1f} mm it may extrapolate")


def entry_radius(points_mm: np.ndarray, options: CalibrationOptions) -> float:
    """Where the trace enters the data (mm from the root): the option, else a third of the trace
    length, but never inside the grid's nearest point plus the domain margin."""
    if options.entry_radius_mm is not None:
        return float(options.entry_radius_mm)
    radius = np.linalg.norm(points_mm - np.asarray(options.root_mm, float), axis=1)
    return max(float(radius.min()) + options.domain_margin_mm,
               ENTRY_FRACTION_OF_TRACE * options.trace_length_mm)


def _traced_region(points_mm: np.ndarray, options: CalibrationOptions) -> np.ndarray:
    """Points no nearer the root than one grid step inside the entry circle.

    The trace never evaluates f nearer the root than the entry circle, and rod contacts there
    (the suspension pushed hard, mostly translated) give the largest |z| and the roughest part of
    the surface; left in, they dominate the least squares and spoil the fit where the level sets
    are traced (measured on the twin: docs/model.md).
    """
    if not options.fit_traced_region_only:
        return np.ones(len(points_mm), bool)
    radius = np.linalg.norm(points_mm - np.asarray(options.root_mm, float), axis=1)
    return radius >= entry_radius(points_mm, options) - FIT_MARGIN_INSIDE_ENTRY_MM


def build_problem(surface: Surface, points_mm: np.ndarray, z_uT: np.ndarray,
                  options: CalibrationOptions) -> LevelSetProblem:
    """The level-set problem over the corrected grid (domain, entry, extension, z range)."""
    root = np.asarray(options.root_mm, float)
    reach = float(np.max(np.linalg.norm(points_mm - root, axis=1)))
    entry = entry_radius(points_mm, options)
    z_span = float(np.ptp(z_uT))
    domain = Domain.from_points(points_mm, options.domain_margin_mm)
    return LevelSetProblem(
        surface=surface,
        domain=domain,
        trace_length_mm=float(options.trace_length_mm),
        z_range_uT=(float(z_uT.min()), float(z_uT.max())),
        entry_radius_mm=float(entry),
        root_mm=root,
        min_gradient_uT_per_mm=1e-6 * z_span,  # a millionth of the range per mm: flat
        extension_radius_mm=far_edge_radius(points_mm, root),
        tip_extension_mm=max(0.0, options.trace_length_mm - reach) + EXTENSION_ALLOWANCE_MM,
    )
