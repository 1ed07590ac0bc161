"""Choose DEFAULT_SENSOR's magnet placement so the twin resembles the paper's sensor.

Run: .venv/bin/python scripts/fit_default_magnet.py [--second]

The whisker (mechanics) is taken as it is; only the magnet is fitted: the NdFeB disc's size and
grade, how far below the centre of rotation it sits, the gap to the chip and a small lateral
mounting error of the chip, minimizing the RMS distance between the twin's tip for a
frictionless tip contact and the authors' characterized model (below) over its raw Y readings
-10000..0 µT, each compared at the twin's z = raw - 447 µT (the model's own rest), with the Z
axis kept inside the MLX90393's default range. The chip's mounting tilt follows in closed form
from the static Y reading the real sensor shows at rest (1160 µT).
The script prints the numbers that docs/twin.md records. params.py still holds the magnet an
earlier version fitted on another footing (the model's input read as the change from rest):
docs/twin.md says what applying this fit changes and what keeps it from being the default yet.

The authors' model is a target for choosing these defaults only: nothing in whiskercal computes
a result from it.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import differential_evolution

from whiskercal.twin.physics.magnet import MagnetParams, exact_field_uT
from whiskercal.twin.params import DEFAULT_SENSOR
from whiskercal.twin.truth import tip_contact_sweep

# raw Y (µT) -> tip (mm) of the model the authors ran (reference/README.md, from their public
# code). Its input is the raw reading, and its own undeflected point (tip y = 0) lies at raw
# +447 µT: the twin's z from rest is compared with the model at raw = z + 447 µT.
REFERENCE_RAW_Y_UT = np.array([0.0, -1000.0, -3000.0, -5000.0, -7000.0, -8760.0, -10000.0])
MODEL_REST_RAW_Y_UT = 447.0
REFERENCE_Z_UT = REFERENCE_RAW_Y_UT - MODEL_REST_RAW_Y_UT
REFERENCE_TIP_MM = np.array([
    [77.81, -3.39], [77.02, -10.64], [73.69, -23.44], [68.67, -34.36],
    [61.98, -43.97], [54.43, -50.82], [48.02, -53.57],
])
STATIC_Y_UT = 1160.5           # real sensor at rest (reference/README.md)
Z_AXIS_LIMIT_UT = 28000.0      # keep Z below the ±31.7 mT of RES 2 with margin
SWEEP_SAMPLES, SWEEP_MAX_SLOPE_RAD = 121, 1.6


# Search box: (diameter mm, height mm, polarization T, centre depth below the pivot mm, gap mm,
# chip offset in y mm). Sintered NdFeB grades N35..N52 span J = 1.17..1.45 T; the chip's offset
# is a mounting error, so it stays small.
BOUNDS = [(2.0, 8.0), (0.5, 5.0), (1.17, 1.45), (2.0, 12.0), (1.0, 10.0), (-0.5, 0.5)]
MAX_TILT_RAD = 0.1             # a mounting error too (5.7°)


def untilted_magnet(x) -> MagnetParams:
    """The candidate for parameters x (see BOUNDS) before the chip's tilt is set."""
    diameter, height, polarization, depth, gap, offset_y = x
    return MagnetParams(diameter_mm=diameter, height_mm=height, polarization_T=-polarization,
                        magnet_center_mm=-depth, gap_mm=gap, sensor_offset_mm=(0.0, offset_y, 0.0))


def tilt_for_static_y(magnet: MagnetParams, static_y_uT: float) -> float:
    """Smallest chip tilt (rad) that makes the Y reading at rest `static_y_uT` (untilted `magnet`)."""
    _, y0, z0 = exact_field_uT(magnet, 0.0, [0.0, 0.0])
    # Tilted by t, Y reads z0·sin t + y0·cos t = A·sin(t + psi) (MagnetParams.sensor_axes).
    amplitude, psi = np.hypot(y0, z0), np.arctan2(y0, z0)
    if abs(static_y_uT) > amplitude:
        return np.nan
    first = np.arcsin(static_y_uT / amplitude)
    candidates = np.angle(np.exp(1j * (np.array([first, np.pi - first]) - psi)))
    return float(candidates[np.argmin(np.abs(candidates))])


def tip_distances_mm(magnet: MagnetParams, sweep) -> np.ndarray | None:
    """Distance from the twin's tip to the reference tip at each reference z (None: unusable)."""
    field = exact_field_uT(magnet, sweep.root_rotation_rad, sweep.root_shift_mm)
    z = field[:, 1] - field[0, 1]
    if np.any(np.diff(z) >= 0) or z[-1] > REFERENCE_Z_UT.min() or np.abs(field[:, 2]).max() > Z_AXIS_LIMIT_UT:
        return None
    tip = CubicSpline(z[::-1], sweep.tip_mm[::-1], axis=0)(REFERENCE_Z_UT)
    return np.linalg.norm(tip - REFERENCE_TIP_MM, axis=1)


def candidate(x) -> MagnetParams | None:
    """The magnet for parameters x (see BOUNDS), with the tilt that gives the static Y reading;
    None when no tilt within :data:`MAX_TILT_RAD` gives it."""
    magnet = untilted_magnet(x)
    tilt = tilt_for_static_y(magnet, STATIC_Y_UT)
    return replace(magnet, sensor_tilt_rad=tilt) if abs(tilt) <= MAX_TILT_RAD else None


def objective(x, sweep) -> float:
    """RMS tip distance (mm) over the reference points; 1e3 for unusable candidates."""
    magnet = candidate(x)
    if magnet is None:
        return 1e3
    distances = tip_distances_mm(magnet, sweep)
    return 1e3 if distances is None else float(np.sqrt(np.mean(distances**2)))


def fit(whisker, seed: int = 4) -> tuple[MagnetParams, np.ndarray]:
    """Differential evolution over BOUNDS, rounded to what a drawing would specify.

    The optimum is flat: seeds 1..4 end at RMS 2.16..2.24 mm with nearly the same magnet; seed 4
    needs the smallest mounting errors.
    """
    sweep = tip_contact_sweep(whisker, SWEEP_SAMPLES, SWEEP_MAX_SLOPE_RAD)
    result = differential_evolution(objective, BOUNDS, args=(sweep,), seed=seed, maxiter=80,
                                    popsize=20, tol=1e-7, polish=True)
    # The optimum leans on the Z-range limit: round finely (0.01 mm, 0.001 T), and one digit
    # finer where that rounding steps over the limit.
    print(f"optimizer: RMS {result.fun:.3f} mm at {np.round(result.x, 4)}")
    for extra in range(3):
        rounded = [round(value, digits + extra)
                   for value, digits in zip(result.x, (2, 2, 3, 2, 2, 2))]
        magnet = candidate(rounded)
        distances = None if magnet is None else tip_distances_mm(magnet, sweep)
        if distances is not None:
            return magnet, distances
    raise SystemExit("no rounding of the optimum keeps the field usable")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.parse_args()
    magnet, distances = fit(DEFAULT_SENSOR.whisker)
    rest = exact_field_uT(magnet, 0.0, [0.0, 0.0])
    print(f"magnet {magnet.diameter_mm} x {magnet.height_mm} mm, J {magnet.polarization_T} T")
    print(f"magnet centre {magnet.magnet_center_mm:.3f} mm, gap {magnet.gap_mm:.3f} mm, "
          f"chip offset {magnet.sensor_offset_mm[1]:.3f} mm, "
          f"tilt {magnet.sensor_tilt_rad:.5f} rad ({np.degrees(magnet.sensor_tilt_rad):.2f} deg)")
    print(f"field at rest (X, Y, Z) µT: {np.round(rest, 1)}")
    for z, d in zip(REFERENCE_Z_UT, distances):
        print(f"  z {z:8.0f} µT: {d:5.2f} mm from the reference tip")
    print(f"worst {distances.max():.2f} mm, RMS {np.sqrt(np.mean(distances**2)):.2f} mm")


if __name__ == "__main__":
    main()
