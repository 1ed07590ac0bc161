"""Realistic contacts read as a stream: each plane pressed in from first touch, sample by sample.

``testing.fields.realistic_contacts`` gives each plane contact (tilt 0-40°, μ 0-0.4, both sliding
senses, six depths) as one reading. A runtime sees the whole press: the plane pushed in along its
normal while sliding, the twin solved every ``DEPTH_STEP`` of the whisker's length, the readings
between solved depths interpolated, ``SAMPLES_PER_STEP`` one-sample-noise readings a step (a
press of a 75 mm whisker at about 11 mm/s at 300 Hz), and at each of the six depths the contact
held ``HELD_SAMPLES`` samples. A press ends where the contact stops being a tip contact, or the
magnet would strike the chip.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from whiskercal.testing import fields as twin_data
from whiskercal.testing.twin_grid import tip_error_mm
from whiskercal.mechfit.table_error import HELD_SAMPLES

DEPTH_STEP = 0.005  # of the whisker's length, between solved depths
SAMPLES_PER_STEP = 3


@dataclass(frozen=True)
class Press:
    """One plane pressed in: noise-free (Y, Z) µT per solved depth (n, 2), true tips (n, 2) mm,
    and which solved depths are the realistic contacts' (held there)."""

    fields_uT: np.ndarray
    tips_mm: np.ndarray
    measured: np.ndarray


def presses(sensor) -> list[Press]:
    """Every plane of ``testing.fields``' realistic contacts, pressed in from first touch."""
    out = []
    depths = np.arange(DEPTH_STEP, max(twin_data.DEPTH_FRACTIONS) + 1e-9, DEPTH_STEP)
    measured = np.array([min(abs(d - f) for f in twin_data.DEPTH_FRACTIONS) < 1e-9
                         for d in depths])
    for tilt, mu, sign in twin_data.plane_conditions():
        states = _pressed_states(sensor, depths, tilt, mu, sign)
        if len(states) >= 2:
            out.append(Press(twin_data.pose_fields(sensor, states),
                             np.array([s.tip_mm for s in states]), measured[:len(states)]))
    return out


def _pressed_states(sensor, depths, tilt, mu, sign) -> list:
    """The tip contacts of one plane at each depth, up to the first that is not one."""
    states = []
    for fraction in depths:
        state = twin_data.plane_tip_contact(sensor, tilt, mu, sign, fraction)
        if state is None:
            break
        states.append(state)
    return states


def stream(press: Press, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The press's noisy readings (n, 2) µT, and for each the index of its solved depth where it
    is one of the held samples at a measured depth, else -1."""
    noise = np.array(twin_data.SAMPLE_NOISE_UT)
    points = np.vstack([np.zeros(2), press.fields_uT])
    readings, marks = [], []
    for k in range(len(press.fields_uT)):
        t = (np.arange(1, SAMPLES_PER_STEP + 1) / SAMPLES_PER_STEP)[:, None]
        readings.extend(points[k] + t * (points[k + 1] - points[k]))
        marks.extend([-1] * SAMPLES_PER_STEP)
        if press.measured[k]:
            readings.extend([points[k + 1]] * (HELD_SAMPLES - 1))
            marks[-1:] = [k]
            marks.extend([k] * (HELD_SAMPLES - 1))
    readings = np.array(readings) + rng.normal(0.0, 1.0, (len(readings), 2)) * noise
    return readings, np.array(marks)


def pressed_errors(read_stream: Callable[[np.ndarray], np.ndarray], pressed: list[Press],
                   z_range, seed: int = 0) -> dict:
    """Errors (mm) of ``read_stream`` (readings (n, 2) µT -> tips (n, 2) mm, NaN for none; it
    starts a new contact each call) at the measured depths whose Y lies in ``z_range``: the
    first held sample (one reading) and the mean of the held samples' tips."""
    rng = np.random.default_rng(seed)
    one, held, truth, fed = [], [], [], 0
    for press in pressed:
        readings, marks = stream(press, rng)
        fed += len(readings)
        tips = read_stream(readings)
        for k in np.flatnonzero(press.measured):
            if not z_range[0] <= press.fields_uT[k, 0] <= z_range[1]:
                continue
            rows = np.flatnonzero(marks == k)
            one.append(tips[rows[0]])
            held.append(np.nanmean(tips[rows], axis=0) if np.isfinite(tips[rows, 0]).any()
                        else np.full(2, np.nan))
            truth.append(press.tips_mm[k])
    truth = np.array(truth).reshape(-1, 2)
    return {"one_sample": tip_error_mm(np.array(one).reshape(-1, 2), truth),
            "held": {**tip_error_mm(np.array(held).reshape(-1, 2), truth),
                     "samples": HELD_SAMPLES},
            "presses": len(pressed), "n": len(truth), "readings": fed}
