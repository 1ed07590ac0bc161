"""When the quasi-static whisker stops being enough: its bending modes' ring-down and lag.

For each build of the family (``bench.sensor_family.FAMILY``) the wire's two lowest bending
modes (``twin.physics.dynamics``, the default damping ratio) ride on the twin's statics, and the
reading is the magnet's field at the suspension's dynamic pose, sampled at the build's rate:

- **release**: a rod holding the wire near its tip (pushed sideways by a tenth of its reach) is
  taken away within one sample, as when it slides off the tip. The ring-down time is the time of
  the last sample whose noise-free z still differs from rest by more than one sample's noise
  (the Y axis' σ); beside it the first mode's envelope, ln(|z₀|·a₁/σ)/(ζω₁).
- **slide**: the rod slides along the pressed wire at a constant speed (2..50 mm/s) and stands
  still for a second after, once starting and stopping at once (as the mobile twin's robot
  takes a command) and once at the stage's acceleration (its default 200 mm/s², a trapezoid);
  the error is the largest difference between the quasi-static and the dynamic z over the run,
  beside the median over the middle half of the slide. The speed at which quasi-statics stop
  being enough is the lowest whose error passes one sample's noise, for each start.

Everything is noise-free and deterministic: the noise σ is only the yardstick.
"""

from __future__ import annotations

import math

import numpy as np

from whiskercal.plotting import pyplot, save_png
from whiskercal.twin.physics.dynamics import DEFAULT_DAMPING_RATIO, RingingRoot, modes

MODES = 2
SPEEDS_MM_S = (2.0, 5.0, 10.0, 20.0, 30.0, 50.0)
QUICK_SPEEDS_MM_S = (2.0, 10.0, 50.0)
ROD_RADIUS_MM = 1.5
PUSH_SHARE = 0.1  # the release's rod: this share of the reach sideways, 1 mm short of the tip
SLIDE_FROM, SLIDE_TO, SLIDE_PUSH = 0.45, 0.85, 0.08  # shares of the reach (x from, x to, y)
PATH_STEP_MM = 0.05  # the quasi-static path's resolution along the slide
RING_S = 10.0  # how long the release is followed
REST_AFTER_S = 1.0  # the slide's rest after it stops
STAGE_ACCEL_MM_S2 = 200.0  # the stage twin's $120/$121 (twin.devices.stage)
STARTS = {"abrupt": math.inf, "stage": STAGE_ACCEL_MM_S2}  # how a slide starts and stops (mm/s²)


def _noise_uT(sensor) -> float:
    return float(sensor.magnetometer.noise_uT_rms[1])


def _z_uT(sensor, rotations, shifts) -> np.ndarray:
    """Noise-free z (Y minus its rest) at suspension poses."""
    from whiskercal.twin.physics.magnet import field_uT

    rest = field_uT(sensor.magnet, 0.0, np.zeros(2))[1]
    return np.asarray(field_uT(sensor.magnet, np.asarray(rotations), np.asarray(shifts)))[..., 1] - rest


def release(sensor, found) -> dict:
    """The ring-down after the rod is taken away (see the module's docstring)."""
    from whiskercal.twin.physics.mechanics import solve_rod

    whisker = sensor.whisker
    reach = whisker.reach_mm
    held = solve_rod(whisker, (reach - 1.0, -PUSH_SHARE * reach - ROD_RADIUS_MM), ROD_RADIUS_MM)
    period = 1.0 / sensor.magnetometer.rate_hz
    ringing = RingingRoot(found, held.root_rotation_rad, held.root_shift_mm)
    ringing.at(0.0, held.root_rotation_rad, held.root_shift_mm)
    times = np.arange(1, int(RING_S / period) + 1) * period
    poses = [ringing.at(t, 0.0, (0.0, 0.0)) for t in times]
    z = _z_uT(sensor, [p[0] for p in poses], np.array([p[1] for p in poses]))
    sigma = _noise_uT(sensor)
    above = np.flatnonzero(np.abs(z) > sigma)
    held_z = float(_z_uT(sensor, held.root_rotation_rad, held.root_shift_mm))
    first = found[0]
    envelope = math.log(max(abs(held_z) * abs(first.rotation_share) / sigma, 1.0)) / first.decay_per_s
    return {"held_kind": held.kind, "held_z_uT": held_z, "noise_uT": sigma,
            "ring_down_s": float(times[above[-1]]) if len(above) else 0.0,
            "envelope_s": envelope, "first_swing_uT": float(z[np.argmax(np.abs(z))]),
            "followed_s": RING_S}


def slide_path(whisker) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The quasi-static slide: rod x (mm), root rotation (rad) and shift (mm, (n, 2))."""
    from whiskercal.twin.physics.mechanics import solve_rod

    reach = whisker.reach_mm
    xs = np.arange(SLIDE_FROM * reach, SLIDE_TO * reach + PATH_STEP_MM / 2, PATH_STEP_MM)
    y = -SLIDE_PUSH * reach
    rotations, shifts, previous = np.empty(len(xs)), np.empty((len(xs), 2)), None
    for index, x in enumerate(xs):
        previous = solve_rod(whisker, (x, y), ROD_RADIUS_MM, previous)
        rotations[index], shifts[index] = previous.root_rotation_rad, previous.root_shift_mm
    return xs, rotations, shifts


def travelled_mm(times: np.ndarray, distance: float, speed: float, accel: float) -> tuple[np.ndarray, float]:
    """How far a trapezoidal move (``accel`` mm/s², inf: at once) has gone at ``times``, and
    the time it ends (s)."""
    ramp = 0.0 if math.isinf(accel) else speed / accel
    if ramp * speed > distance:  # a triangle: never reaches the speed
        ramp = math.sqrt(distance / accel)
        speed = accel * ramp
    end = ramp + distance / speed
    t = np.clip(times, 0.0, end)
    up = 0.5 * speed / ramp * np.minimum(t, ramp) ** 2 if ramp else 0.0 * t
    cruise = speed * np.clip(t - ramp, 0.0, end - 2 * ramp)
    late = np.clip(t - (end - ramp), 0.0, ramp)
    down = speed * late - (0.5 * speed / ramp * late ** 2 if ramp else 0.0)
    return up + cruise + down, end


def slide(sensor, found, path, speed_mm_s: float, accel_mm_s2: float = math.inf) -> dict:
    """The quasi-static against the dynamic z while the rod slides at ``speed_mm_s``."""
    xs, rotations, shifts = path
    period = 1.0 / sensor.magnetometer.rate_hz
    _, duration = travelled_mm(np.zeros(1), xs[-1] - xs[0], speed_mm_s, accel_mm_s2)
    times = np.arange(1, int((duration + REST_AFTER_S) / period) + 1) * period
    x = xs[0] + travelled_mm(times, xs[-1] - xs[0], speed_mm_s, accel_mm_s2)[0]
    rotation = np.interp(x, xs, rotations)
    shift = np.column_stack([np.interp(x, xs, shifts[:, 0]), np.interp(x, xs, shifts[:, 1])])
    ringing = RingingRoot(found, rotations[0], shifts[0])
    poses = [ringing.at(t, r, s) for t, r, s in zip(times, rotation, shift)]
    error = _z_uT(sensor, [p[0] for p in poses], np.array([p[1] for p in poses])) \
        - _z_uT(sensor, rotation, shift)
    moving = np.flatnonzero(times <= duration)
    middle = moving[len(moving) // 4: 3 * len(moving) // 4]
    return {"speed_mm_s": speed_mm_s, "max_error_uT": float(np.max(np.abs(error))),
            "middle_error_uT": float(np.median(np.abs(error[middle]))) if len(middle) else math.nan,
            "z_span_uT": float(np.ptp(_z_uT(sensor, rotation, shift)))}


def build_rows(sensor, speeds, damping_ratio: float = DEFAULT_DAMPING_RATIO) -> dict:
    """One build's modes, release and slides, and the speed past which statics miss."""
    found = modes(sensor.whisker, MODES, damping_ratio)
    sigma = _noise_uT(sensor)
    path = slide_path(sensor.whisker)
    slides = [{"start": start, **slide(sensor, found, path, speed, accel)}
              for start, accel in STARTS.items() for speed in speeds]
    over = {start: [row["speed_mm_s"] for row in slides
                    if row["start"] == start and row["max_error_uT"] > sigma] for start in STARTS}
    return {"build": sensor.sensor_id, "rate_hz": sensor.magnetometer.rate_hz,
            "modes": [{"frequency_hz": m.frequency_hz, "damping_ratio": m.damping_ratio,
                       "rotation_share": m.rotation_share, "shift_share": m.shift_share}
                      for m in found],
            "first_mode_hz": found[0].frequency_hz, "second_mode_hz": found[1].frequency_hz,
            "release": release(sensor, found), "slides": slides,
            "statics_enough_below_mm_s": {start: min(speeds) if speeds else None
                                          for start, speeds in over.items()}}


def run(quick: bool = False, progress=None) -> dict:
    """Every build's rows (the first two in quick), the summary rows for the docs' table."""
    from whiskercal.bench.sensor_family import FAMILY

    builds = FAMILY[:2] if quick else FAMILY
    speeds = QUICK_SPEEDS_MM_S if quick else SPEEDS_MM_S
    per_build = []
    for sensor in builds:
        per_build.append(build_rows(sensor, speeds))
        if progress is not None:
            progress(sensor.sensor_id)
    rows = [{"build": b["build"], "first_mode_hz": b["first_mode_hz"],
             "second_mode_hz": b["second_mode_hz"], "damping_ratio": b["modes"][0]["damping_ratio"],
             "release_z_uT": b["release"]["held_z_uT"], "ring_down_s": b["release"]["ring_down_s"],
             "envelope_s": b["release"]["envelope_s"], "noise_uT": b["release"]["noise_uT"],
             "past_noise_from_mm_s": b["statics_enough_below_mm_s"],
             "error_uT": {start: {f"{row['speed_mm_s']:g}": row["max_error_uT"]
                                  for row in b["slides"] if row["start"] == start}
                          for start in STARTS}}
            for b in per_build]
    return {"rows": rows, "per_build": per_build, "speeds_mm_s": list(speeds), "modes": MODES,
            "damping_ratio": DEFAULT_DAMPING_RATIO, "quick": quick,
            "supports": {"dynamics": "off by default (quasi-static)",
                         "longest_ring_down_s": max(r["ring_down_s"] for r in rows),
                         "lowest_speed_past_noise_mm_s": {start: min(
                             (r["past_noise_from_mm_s"][start] for r in rows
                              if r["past_noise_from_mm_s"][start] is not None), default=None)
                             for start in STARTS},
                         "rule": "a scene needs the modes where its samples come within the "
                                 "ring-down of a release or slip, or it slides past the speed "
                                 "whose error passes one sample's noise"}}


def draw(result: dict, path) -> object:
    """The release's ring-down time per build, and the slide's error (in noise σ) by speed."""
    plt = pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(10.0, 4.2))
    builds = result["per_build"]
    names = [b["build"] for b in builds]
    left.barh(names, [b["release"]["ring_down_s"] for b in builds], color="C0")
    left.set_xlabel("ring-down to one sample's noise after a release (s)")
    for index, b in enumerate(builds):
        sigma = b["release"]["noise_uT"]
        for start, style in (("abrupt", "o-"), ("stage", "s--")):
            mine = [r for r in b["slides"] if r["start"] == start]
            right.plot([r["speed_mm_s"] for r in mine], [r["max_error_uT"] / sigma for r in mine],
                       style, color=f"C{index}", label=f"{b['build']} ({start})")
    right.axhline(1.0, color="grey", ls=":", lw=1, label="one sample's noise")
    right.set_xlabel("rod speed along the wire (mm/s)")
    right.set_ylabel("quasi-static error, largest (noise σ)")
    right.set_yscale("log")
    right.legend(fontsize=7)
    fig.suptitle(f"the wire's first {result['modes']} modes, ζ = {result['damping_ratio']:g}")
    fig.tight_layout()
    return save_png(fig, path)
