"""The shaft study's configuration: documented defaults, overridden key by key by a TOML file,
every table typed (`ShaftStudyConfig`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pydantic import model_validator

from whiskercal.tomlconfig import merge_overrides, read_toml
from whiskercal.typedconfig import Flag, Table, integer, number, numbers, validate

DEFAULTS: dict = {
    # the rig as `whiskercal collect` sets it up (whiskercal/collect/default_grid.toml)
    "rig": {"origin_stage_mm": [40.0, 100.0], "angle_deg": 0.0, "rod_radius_mm": 1.5,
            "trace_length_mm": 78.0},
    "trials": {
        # radial distances of the first contact, as fractions of the trace length
        "fractions": [0.2, 0.28, 0.36, 0.45, 0.53, 0.61, 0.7, 0.78, 0.86, 0.95],
        # approach directions, degrees from the whisker's -y (0: normal; the sign toward the slide)
        "approach_deg": [0.0, 30.0],
        # how far the contact is pushed across the whisker, as the contact's angle from the root
        "push_angle_deg": 10.0,
        # the slide along the whisker's axis after the push, toward its middle, mm
        "slide_mm": 10.0,
        # rod centre's y before and after a trial (clear of the whisker), mm
        "safe_y_mm": 6.0,
        "push_speed_mm_s": 10.0, "slide_speed_mm_s": 10.0, "travel_speed_mm_s": 25.0,
    },
    "sensor": {"rate_hz": 300, "gain": 5, "res": 2, "osr": 0, "filt": 2},
    "safety": {"home": True, "move_timeout_s": 60.0, "overload_uT": 15000.0,
               "baseline_samples": 150, "park_mm": [30.0, 20.0]},
}


Number = number()
Positive = number(gt=0)
Pair = numbers(2)


class ShaftRig(Table):
    """The whisker frame in stage coordinates (mm, deg), the rod's radius and the trace length (mm)."""

    origin_stage_mm: Pair
    angle_deg: Number
    rod_radius_mm: Positive
    trace_length_mm: Positive


class ShaftTrials(Table):
    """Where and how each trial presses (``DEFAULTS`` says what each key is)."""

    fractions: numbers(least=1, most=64, gt=0)
    approach_deg: numbers(least=1, most=16)
    push_angle_deg: number(ge=0, lt=90.0)
    slide_mm: number(ge=0)
    safe_y_mm: Positive
    push_speed_mm_s: Positive
    slide_speed_mm_s: Positive
    travel_speed_mm_s: Positive

    @model_validator(mode="after")
    def _inside_the_wire(self) -> "ShaftTrials":
        if max(self.fractions) > 1.0:
            raise ValueError("fractions are shares of the trace length, at most 1")
        if max(abs(angle) for angle in self.approach_deg) >= 90.0:
            raise ValueError("approach_deg must lie within ±90 deg of the whisker's -y")
        return self


class ShaftSensor(Table):
    """Sample rate (Hz) and the MLX90393 GAIN_SEL, RES, OSR, DIG_FILT codes."""

    rate_hz: integer(ge=1)
    gain: integer(ge=0, le=7)
    res: integer(ge=0, le=3)
    osr: integer(ge=0, le=3)
    filt: integer(ge=0, le=7)


class ShaftSafety(Table):
    """Homing, move timeout (s), overload |z| (µT), baseline samples and park position (mm)."""

    home: Flag
    move_timeout_s: Positive
    overload_uT: Positive
    baseline_samples: integer(ge=2)
    park_mm: Pair


class ShaftStudyConfig(Table):
    """Every setting of the shaft study, one table per TOML table."""

    rig: ShaftRig
    trials: ShaftTrials
    sensor: ShaftSensor
    safety: ShaftSafety

    @model_validator(mode="after")
    def _clear_of_the_wire(self) -> "ShaftStudyConfig":
        if self.trials.safe_y_mm <= self.rig.rod_radius_mm:
            raise ValueError("trials.safe_y_mm must exceed rig.rod_radius_mm to clear the whisker")
        return self


def load_config(path: str | Path | None = None) -> dict:
    """The defaults, overridden by ``path``'s keys, validated (`ShaftStudyConfig`: an unknown
    key, a value of the wrong type or out of range is one UsageError line naming the key).

    Returns the configuration as plain nested dicts (numbers of float keys as floats)."""
    if path is None:
        return validate(ShaftStudyConfig, DEFAULTS, "shaft study config").to_dict()
    values = merge_overrides(DEFAULTS, read_toml(path))
    return validate(ShaftStudyConfig, values, str(path)).to_dict()


def trial_plan(config: dict) -> list[dict]:
    """Every trial: name, radial_mm, approach_deg and its waypoints in the whisker frame (mm).

    The rod's centre arrives on the line that meets the undeflected whisker at ``radial_mm``,
    pushes until the contact lies ``push_angle_deg`` below the axis, slides along x toward the
    whisker's middle, then leaves straight up to ``safe_y_mm``.
    """
    rig, trials = config["rig"], config["trials"]
    length, radius = float(rig["trace_length_mm"]), float(rig["rod_radius_mm"])
    safe_y = float(trials["safe_y_mm"])
    plan = []
    for fraction in trials["fractions"]:
        radial = float(fraction) * length
        slide = float(trials["slide_mm"]) * (1.0 if radial < 0.5 * length else -1.0)
        touch = np.array([radial, radius])
        end_y = radius - radial * np.tan(np.radians(float(trials["push_angle_deg"])))
        for approach in trials["approach_deg"]:
            tilt = np.radians(float(approach)) * np.sign(slide)
            direction = np.array([np.sin(tilt), -np.cos(tilt)])
            start = touch - direction * (safe_y - radius) / np.cos(tilt)
            pushed = touch + direction * (radius - end_y) / np.cos(tilt)
            slid = pushed + np.array([slide, 0.0])
            plan.append({"name": f"r{radial:05.1f}mm_a{float(approach):02.0f}deg", "radial_mm": radial,
                         "approach_deg": float(approach), "start": start, "pushed": pushed,
                         "slid": slid, "leave": np.array([slid[0], safe_y])})
    return plan
