"""How far a quantity may move when its dataset is recorded again through the twin, and why.

`whiskercal regress` recomputes from the recorded files, so its classes
(whiskercal.regress.tolerances) allow only reordered floating-point sums. Recording again runs the
twin itself, and the study's slides follow a stick-slip path: a stuck tip breaks loose in the step
whose friction ratio first exceeds mu_s, a comparison that a last-digit difference anywhere
upstream can tip to the neighbouring step (libm's sin, exp or atan2 rounding differently on
another CPU, numpy's SIMD loops, numba's code generation, a new release of any of them). From
there on the two paths' slips never line up again: the slide re-recorded differs sample by sample
by up to one slip of the tip (16-83 µm at the 5-30 mm depths of twin-short-60mm), while its
statistics over the slide's ~1800 samples move by a few µm and a median of z by an LSB.

Everything recorded without friction history stays in the last digits, and rounding the field to
whole counts hides those: the calibration grid (static contacts, each solved afresh), the
push-ins, the stage's moves. Those quantities keep the strict classes of ``tolerances``.

Measured on twin-short-60mm (data/README.md, "Recording again"): recorded again with glibc's
libm without its FMA and AVX2 variants, and 12 times with the twin whisker's Young's modulus
moved by -5 to 11 units in the last place (``scripts/rerecord_spread.py``), the slide statistics
moved by up to 3.6 µm, medians of z by 1 µT and, when the target's median moved, the runtime's
tip by 7.6 µm; numpy without its AVX2 loops, OpenBLAS's Nehalem kernels instead of Haswell, numba
compiling for a generic x86-64, one BLAS or numba thread instead of two moved nothing beyond the
last digits.
"""

from __future__ import annotations

import fnmatch
import math
import re
from typing import Any

from whiskercal.regress.compare import Change
from whiskercal.regress.tolerances import ToleranceClass, tolerance_for

# Twice the median's smallest possible move: a median of z can move by a whole count (or half of
# one, between the two middle samples of an even count) when the samples around it shift.
Z_STEPS = 2

SLIDE_STATISTIC = ToleranceClass(
    "slide_statistic", 0.01, 0.0,
    "Study error statistics and target scores (mm) of slides on the stick-slip path: once one "
    "slip falls a step earlier or later, the slides differ sample by sample by up to one slip of "
    "the tip (16-83 µm), and their means and spreads over ~1800 samples moved by up to 3.6 µm "
    "under last-digit changes of libm or of the twin's inputs. 10 µm is nearly three times "
    "that, and far below the 0.07 mm between the two best target scores and the 0.15 mm of the "
    "smallest error, so no verdict or choice can turn on it.")
WORDING = ToleranceClass(
    "wording", 0.0, 0.0,
    "A verdict's reasons: the same sentences, with their numbers masked. The numbers come from "
    "quantities checked on their own (a median of z moved by 1 µT turns 133.4 µT/mm into "
    "133.6, which the text rounds to 134).")


def median_z_class(z_step_uT: float) -> ToleranceClass:
    """The bound on a median of z (µT) recorded again: ``Z_STEPS`` counts of the z axis."""
    return ToleranceClass(
        "slide_median_z", Z_STEPS * z_step_uT, 0.0,
        f"A median of z (µT) over a slide, or the target taken from one: z comes in whole "
        f"counts of {z_step_uT:g} µT (the magnetometer's Y axis at the study's GAIN_SEL and "
        f"RES), and a re-recorded slide shifts the samples around the median, which moved by "
        f"one count; {Z_STEPS} counts allow for the other machines' paths.")


def runtime_tip_class(z_step_uT: float, tip_per_uT: float) -> ToleranceClass:
    """The bound on the runtime's tip at the target z: the target's bound times the lookup's
    steepest slope ``tip_per_uT`` (mm per µT)."""
    bound = Z_STEPS * z_step_uT * tip_per_uT
    return ToleranceClass(
        "runtime_tip_at_target", bound, 0.0,
        f"The runtime's tip (mm) at the target z, which may move by {Z_STEPS} counts of "
        f"{z_step_uT:g} µT: the lookup moves the tip at most {tip_per_uT:.4g} mm per µT, so "
        f"{bound:.3g} mm (a target moved by one count moved it 7.6 µm on twin-short-60mm).")


def z_step_uT(study_path) -> float:
    """µT per count of z (the magnetometer's Y axis) at the settings a study was recorded with."""
    from whiskercal.protocol import mlx90393
    from whiskercal.rig.overload import SENSOR_AXIS_Y
    from whiskercal.artifacts.plane_study import read_study

    sensor = read_study(study_path).config["sensor"]
    return float(mlx90393.lsb_uT(int(sensor["gain"]), int(sensor["res"]))[SENSOR_AXIS_Y])


def lookup_slope_mm_per_uT(golden: dict[str, Any]) -> float:
    """Steepest tip movement per µT of z along the golden lookup table (mm/µT)."""
    count = int(golden["lookup.samples"])
    steepest = 0.0
    for i in range(count - 1):
        a, b = f"[{i:02d}]", f"[{i + 1:02d}]"
        dz = abs(golden["lookup.z_uT" + b] - golden["lookup.z_uT" + a])
        dx = golden["lookup.tip_x_mm" + b] - golden["lookup.tip_x_mm" + a]
        dy = golden["lookup.tip_y_mm" + b] - golden["lookup.tip_y_mm" + a]
        steepest = max(steepest, math.hypot(dx, dy) / dz)
    return steepest


def rerecorded_rules(z_step_uT: float, tip_per_uT: float
                     ) -> tuple[tuple[str, ToleranceClass], ...]:
    """Quantity name patterns (fnmatch) on the stick-slip path -> class; the first match wins."""
    median, tip = median_z_class(z_step_uT), runtime_tip_class(z_step_uT, tip_per_uT)
    slide = SLIDE_STATISTIC
    return (
        ("study.*.reasons", WORDING),
        ("study.passing_mean_filtered_mm", slide),
        ("study.*.raw_*_mm", slide),
        ("study.*.filtered_*_mm", slide),
        ("study.*.true_raw_mean_mm", slide),
        ("study.*.true_filtered_mean_mm", slide),
        ("study.target.score_mm", slide),
        ("study.target.scores_mm*", slide),
        ("study.*.median_z_uT", median),
        ("study.target.z_uT", median),
        ("runtime.target_z_uT", median),
        ("runtime.tip_*", tip),
    )


def rerecorded_tolerance(name: str, rules) -> ToleranceClass:
    """The class of a quantity recorded again: its rule's, else its class in ``tolerances``."""
    for pattern, tolerance in rules:
        if fnmatch.fnmatchcase(name, pattern):
            return tolerance
    return tolerance_for(name)


def compare_rerecorded(golden: dict[str, Any], new: dict[str, Any], z_step_uT: float
                       ) -> list[Change]:
    """Every quantity of a dataset recorded again that is not within its re-recording class.

    Parameters
    ----------
    golden, new
        Name -> value of the recorded dataset's golden results and of the re-recorded one's
        (None stands for NaN).
    z_step_uT
        µT per count of the z axis at the study's sensor settings.
    """
    rules = rerecorded_rules(z_step_uT, lookup_slope_mm_per_uT(golden))
    changes = []
    for name in list(golden) + [n for n in new if n not in golden]:
        tolerance = rerecorded_tolerance(name, rules)
        if name not in new or name not in golden:
            kind = "removed" if name not in new else "added"
            changes.append(Change(name, kind, golden.get(name), new.get(name), tolerance))
        elif not _agrees(golden[name], new[name], tolerance):
            changes.append(Change(name, "moved", golden[name], new[name], tolerance))
    return changes


def _agrees(golden: Any, new: Any, tolerance: ToleranceClass) -> bool:
    if tolerance is WORDING:
        return _masked(golden) == _masked(new)
    if _is_number(golden) and _is_number(new):
        return tolerance.allows(float(golden), float(new))
    return golden == new  # flags, labels, lists; None (NaN) matches only None


def _masked(value: Any) -> Any:
    """Reasons with every number replaced by '#'."""
    if isinstance(value, list):
        return [re.sub(r"\d+(\.\d+)?", "#", str(text)) for text in value]
    return value


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)
