"""How far a recomputed quantity may move from its golden value, and why.

Every quantity that ``whiskercal regress`` checks belongs to one class below. A class's
tolerance covers what can legitimately differ between two runs of the same method on the same
data (another CPU, BLAS library or numpy release reordering floating-point sums), and nothing
that a change of method or data would cause. Recomputing on one machine gives bit-identical
numbers; the bounds say how much room a different machine gets.

A quantity passes when ``|new - golden| <= abs_tol + rel_tol * |golden|``; non-numbers (counts
stored as integers, flags, labels, lists) must be equal.

Measured: recomputing both datasets in data/ with OpenBLAS's Nehalem kernels instead of Haswell,
with one BLAS thread, with numpy's AVX2 loops off, or with glibc's libm without its FMA variants
moved no quantity by more than 1e-4 of its bound (the largest, a lookup-vs-truth error, by
8e-11 mm). Recording the data again through the twin moves far more: see
whiskercal.regress.rerecorded.
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass


@dataclass(frozen=True)
class ToleranceClass:
    """A tolerance shared by quantities of one kind.

    Attributes
    ----------
    name : str
        Short label, written next to each quantity in the golden file.
    abs_tol, rel_tol : float
        Allowed absolute difference (in the quantity's unit) and relative difference.
    why : str
        The reason for the bound, in one or two sentences.
    """

    name: str
    abs_tol: float
    rel_tol: float
    why: str
    # a NaN on one side only passes (a table cell on the edge of what the fit answers)
    nan_either: bool = False

    def allows(self, golden: float, new: float) -> bool:
        """True when ``new`` is within this tolerance of ``golden`` (NaN only matches NaN,
        unless ``nan_either``)."""
        if golden != golden or new != new:  # NaN: both must be NaN
            return self.nan_either or (golden != golden and new != new)
        return abs(new - golden) <= self.abs_tol + self.rel_tol * abs(golden)


EXACT = ToleranceClass(
    "exact", 0.0, 0.0,
    "A count, flag, label or decision (degree, interpolant, points used, failing trials, the "
    "chosen depth): rounding cannot change it, so any change is a change of method or data.")
MEASURED = ToleranceClass(
    "measured", 1e-9, 1e-12,
    "Computed from the recorded samples alone (medians and shares of z, distances slid, kink "
    "depths): only the order of a few additions can differ, far below 1e-9 of the unit.")
LEAST_SQUARES = ToleranceClass(
    "least_squares", 1e-9, 1e-7,
    "Surface fit statistics from LAPACK's least squares: another BLAS reorders its sums, and the "
    "column-scaled design's condition number (tens to thousands) magnifies 1e-16 to at most "
    "1e-12 relative; 1e-7 keeps a wide margin while a change of degree, basis or data moves "
    "them by 1e-3 or more.")
R_SQUARED = ToleranceClass(
    "r_squared", 1e-10, 0.0,
    "R² is 1 - SSres/SStot with SSres/SStot near 1e-5: a 1e-7 relative change of SSres (see "
    "least_squares) moves it by 1e-12; 1e-10 is that with margin.")
CONDITION = ToleranceClass(
    "condition", 0.0, 1e-6,
    "A condition number from an SVD: reordered sums change its trailing digits only.")
TRACE = ToleranceClass(
    "trace", 1e-6, 0.0,
    "Tips traced along the level set (mm) and what follows from them (lookup errors, runtime "
    "tips): the adaptive integrator (rtol 1e-7) reproduces them to about 1e-12 mm under reordered "
    "sums; 1 nm is far above that and far below the 1e-4 mm the lookup resolves.")
ESTIMATE = ToleranceClass(
    "estimate", 1e-6, 0.0,
    "Study errors (mm) from the lookup's tips through the Kalman filter: they inherit the trace "
    "tolerance, 1 nm, against errors of 0.01 mm and more.")
SCORE = ToleranceClass(
    "score", 1e-6, 0.0,
    "The target rule's scores (mm): sums of study errors, the estimate tolerance.")
LOOKUP_RANGE = ToleranceClass(
    "lookup_range", 1e-6, 1e-12,
    "Lookup sample deflections (µT): evenly spaced between ends found by bisection on whether a "
    "trace succeeds; rounding moves them only by the spacing's last digits, and a moved end means "
    "the traceable range itself changed.")

SHAFT_ERROR = ToleranceClass(
    "shaft_error", 1e-4, 0.0,
    "Shaft contact errors (mm) through the localizer's Gauss-Newton solves on a surface whose root "
    "and tip patches come from the mechanics' iterative least squares: measured, a 1e-13 relative "
    "change of the grid's z or the stream's z, or OpenBLAS's Nehalem kernels with one thread and "
    "numpy without AVX2/FMA, moved them by at most 8e-7 mm; 1e-4 mm keeps a hundredfold margin "
    "against errors of 0.03 mm and more, which a change of surface or solver moves by 0.01 mm.")
SHAFT_TRAVEL = ToleranceClass(
    "shaft_travel", 0.04, 0.0,
    "Travel (mm) at which a trial's error stays under 1 mm: the travel of the sample where a "
    "continuous error crosses a threshold; equal in every measured perturbation, it may move by "
    "one sample when an error sits on the threshold: 0.033 mm at the study's 10 mm/s and 300 Hz.")
SHAFT_SHARE = ToleranceClass(
    "shaft_share", 5e-3, 0.0,
    "Shares of a trial's samples (localized, grossly wrong, kind right or decided): counts of "
    "threshold decisions on continuous estimates; equal in every measured perturbation, a sample "
    "on a threshold may flip: 5e-3 is two samples of the shortest trial (about 450 in contact).")

# The default fit's classes were measured over four arithmetic variants of one machine on the
# three recorded datasets: OpenBLAS's SkylakeX, Haswell and Prescott kernels, and Haswell's with
# numpy's AVX-512 loops switched off (NPY_DISABLE_CPU_FEATURES), which reproduces a CPU without
# AVX-512 to the last digit. Each bound is about one and a half times the widest move measured.
ARITHMETIC_VARIANTS = ("OpenBLAS SkylakeX, Haswell and Prescott kernels, and Haswell's with "
                       "numpy's AVX-512 loops off")
MODEL_TIP = ToleranceClass(
    "model_tip", 0.06, 0.0,
    "The default fit's tip curve and its RMS truth error (mm): the joint (Y, Z) fit stops in a "
    "valley where chi2 changes by about 2 over k_theta*L/EI 71 to 74 (the long 110 mm build), "
    "at a place that moves with the arithmetic; over the " + ARITHMETIC_VARIANTS + ", the long "
    "build's lookup moved by up to 0.041 mm and its RMS truth error by 0.026 mm (the others' "
    "by under 0.006 mm), inside the fit's own estimate (0.056-0.063 mm). 0.06 mm keeps a fall "
    "to the level set (0.44 mm) or to another basin (millimetres) outside.")
MODEL_TIP_MAX = ToleranceClass(
    "model_tip_max", 0.15, 0.0,
    "The default fit's largest truth error (mm): the worst of its lookup's points, where the "
    "stopping point's move shows most; over the " + ARITHMETIC_VARIANTS + ", the long 110 mm "
    "build's moved by up to 0.097 mm (the others' by under 0.007 mm). 0.15 mm is under the "
    "0.25 mm goal.")
MODEL_Z = ToleranceClass(
    "model_z", 4.0, 1e-9,
    "The default fit's lookup deflections (µT): ends set by the grid's range and by where the "
    "fitted model's z stops being one-to-one, which follows the fit's stopping point; over the "
    + ARITHMETIC_VARIANTS + ", they moved by up to 2.5 µT (the long 110 mm build). 4 µT is "
    "under a thousandth of the lookups' spans.")
TABLE_AXIS = ToleranceClass(
    "table_axis", 200.0, 0.0,
    "The (Y, Z) table's axes (µT): Y's sampled rows span the grid's range; the Z axis's ends "
    "what the joint fit's tip loads reach, which follows where it stopped; over the "
    + ARITHMETIC_VARIANTS + ", an end moved by up to "
    "119 µT (the paper's 75 mm build), two thirds of its table's Z spacing. 200 µT is about "
    "one cell, against axes spanning thousands of µT.")
TABLE_TIP = ToleranceClass(
    "table_tip", 0.08, 0.0,
    "The (Y, Z) table's tips (mm) at fixed fields inside its loads, where the fit estimates the "
    "table within the goal (``default_fit.table_within_goal``): the joint fit's tip loads "
    "resampled on its axes; over the " + ARITHMETIC_VARIANTS + ", they moved by up to 0.042 mm. "
    "0.08 mm is under a third of the 0.25 mm goal. A field at the edge of the loads in one run "
    "may be left out in another: either side's NaN passes, and the table's coverage is checked "
    "as table_share.", nan_either=True)
TABLE_SHARE = ToleranceClass(
    "table_share", 0.01, 0.0,
    "The share of the (Y, Z) table's cells that hold a tip: its edge follows the joint fit's "
    "loads; over the " + ARITHMETIC_VARIANTS + ", it moved by up to 0.0035 (about fifty of the "
    "121 x 121 cells). 0.01 is over a hundred cells, while a table that loses a region of its "
    "loads loses far more.")

CLASSES = {c.name: c for c in (EXACT, MEASURED, LEAST_SQUARES, R_SQUARED, CONDITION, TRACE,
                               ESTIMATE, SCORE, LOOKUP_RANGE, SHAFT_ERROR, SHAFT_TRAVEL,
                               SHAFT_SHARE, MODEL_TIP, MODEL_TIP_MAX, MODEL_Z, TABLE_AXIS,
                               TABLE_TIP, TABLE_SHARE)}

# Quantity name patterns (fnmatch) -> class; the first match wins, so specific names go first.
RULES: tuple[tuple[str, ToleranceClass], ...] = (
    ("default.fit.lookup_vs_truth_points", EXACT),
    ("default.fit.lookup_vs_truth_max_mm", MODEL_TIP_MAX),
    ("default.fit.lookup_vs_truth_*_mm", MODEL_TIP),
    ("default.lookup.z_uT*", MODEL_Z),
    ("default.lookup.tip_*", MODEL_TIP),
    ("default.table.answered_share", TABLE_SHARE),
    ("default.table.within_goal", EXACT),
    ("default.table.*_uT*", TABLE_AXIS),
    ("default.table.tip_*", TABLE_TIP),
    ("fit.r2", R_SQUARED),
    ("fit.rmse_uT", LEAST_SQUARES),
    ("fit.cv_rmse_uT", LEAST_SQUARES),
    ("fit.cv_rmse_by_degree_uT*", LEAST_SQUARES),
    ("fit.condition_number", CONDITION),
    ("fit.lookup_*_mm", TRACE),
    ("fit.contact_error_*_mm", TRACE),
    ("lookup.z_uT*", LOOKUP_RANGE),
    ("lookup.tip_*", TRACE),
    ("runtime.tip_*", TRACE),
    ("runtime.target_z_uT", MEASURED),
    ("study.target.score_mm", SCORE),
    ("study.target.scores_mm*", SCORE),
    ("study.target.z_uT", MEASURED),
    ("study.passing_mean_filtered_mm", ESTIMATE),
    ("study.*.raw_*_mm", ESTIMATE),
    ("study.*.filtered_*_mm", ESTIMATE),
    ("study.*.true_raw_mean_mm", ESTIMATE),
    ("study.*.true_filtered_mean_mm", ESTIMATE),
    ("study.*.median_z_uT", MEASURED),
    ("study.*.contact_fraction", MEASURED),
    ("study.*.true_tangential_fraction", MEASURED),
    ("study.*.slid_mm", MEASURED),
    ("study.*.kink_depth_mm", MEASURED),
    ("shaft.*.median_error_mm", SHAFT_ERROR),
    ("shaft.*.final_error_mm", SHAFT_ERROR),
    ("shaft.*.travel_to_1mm", SHAFT_TRAVEL),
    ("shaft.*_share*", SHAFT_SHARE),
    ("shaft.*.kind_accuracy*", SHAFT_SHARE),
)


def tolerance_for(name: str) -> ToleranceClass:
    """The tolerance class of a quantity name; names that match no rule are exact."""
    for pattern, tolerance in RULES:
        if fnmatch.fnmatchcase(name, pattern):
            return tolerance
    return EXACT
