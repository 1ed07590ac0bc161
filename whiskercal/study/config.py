"""The study's configuration: documented TOML defaults, user overrides, and the plane geometry.

Defaults live in ``default_study.toml`` next to this module (every key commented). A user file
overrides any subset of keys; an unknown key or a bad value is refused with one clear sentence.

Geometry (docs/study.md): in the whisker frame the plane is pushed toward the root along
``push = -(cos tilt, sin tilt)`` and slides along ``slide = slide_sign * (sin tilt, -cos tilt)``.
The stage frame is the whisker frame rotated by ``whisker_angle_deg`` and shifted to
``whisker_origin_stage_mm``. The plane's line in the whisker frame at a stage position S passes
through ``R^T (S + fixture_offset - origin)``, where R is that rotation.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.session.frame import RigFrame
from whiskercal.tomlconfig import merge_overrides, read_toml

DEFAULTS_RESOURCE = "default_study.toml"


def default_config() -> dict[str, Any]:
    """The documented defaults as a nested dict."""
    text = resources.files("whiskercal.study").joinpath(DEFAULTS_RESOURCE).read_text("utf-8")
    return tomllib.loads(text)


# The default depths and slide were chosen for this tip reach (mm); other builds get them scaled.
DEFAULT_TIP_REACH_MM = 78.0


def follow_tip_reach(defaults: dict[str, Any], given: dict[str, Any]) -> dict[str, Any]:
    """The defaults for a build whose ``[geometry] tip_reach_mm`` the user's file gives.

    The nine depths (5..45 mm for 78 mm) and the slide (80 mm, centred on first contact) scale
    with the reach, depths rounded to 0.5 mm; a key the file gives is kept as given.
    """
    geometry = given.get("geometry")
    reach = geometry.get("tip_reach_mm") if isinstance(geometry, dict) else None
    if isinstance(reach, bool) or not isinstance(reach, (int, float)) \
            or not 0 < reach < math.inf or reach == DEFAULT_TIP_REACH_MM:
        return defaults
    factor = float(reach) / DEFAULT_TIP_REACH_MM
    trials = defaults["trials"]
    depths = sorted({max(0.5, round(2.0 * d * factor) / 2.0) for d in trials["depths_mm"]})
    travel = round(trials["travel_mm"] * factor, 1)
    scaled = dict(trials, depths_mm=depths, travel_mm=travel, slide_start_mm=-travel / 2.0)
    return {**defaults, "trials": scaled}


def load_config(path: str | Path | None = None) -> dict[str, Any]:
    """Defaults, overridden by the TOML file at ``path`` when given, validated.

    Raises
    ------
    UsageError
        When the file is missing, not TOML, has unknown keys or values out of range.
    """
    defaults = config = default_config()
    if path is not None:
        given = read_toml(path)
        config = merge_overrides(follow_tip_reach(config, given), given, str(path))
    where = "study config" if path is None else str(path)
    _check_types(config, defaults, where)
    _validate(config, where)
    return config


# lists of numbers that are points (x, y), mm; the other lists (depths) may have any length
_PAIRS = ("geometry.whisker_origin_stage_mm", "geometry.fixture_offset_mm")
# keys whose sign is fixed by what they measure (the rest are checked in _validate)
_POSITIVE = ("geometry.tip_reach_mm", "contact.search_max_mm", "contact.samples_per_step",
             "contact.baseline_samples", "sensor.rate_hz", "safety.move_timeout_s")
_NON_NEGATIVE = ("contact.search_start_mm", "safety.travel_margin_mm")


def _is_number(value: Any) -> bool:
    # TOML booleans are Python ints: not numbers here; NaN or inf would switch off a limit
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _type_problem(value: Any, default: Any, key: str) -> str | None:
    """What ``value`` must be, judged by the documented default's type, or None when it is."""
    if isinstance(default, bool):
        return None if isinstance(value, bool) else "true or false"
    if isinstance(default, int):
        return None if _is_number(value) and isinstance(value, int) else "a whole number"
    if isinstance(default, float):
        return None if _is_number(value) else "a finite number"
    if isinstance(default, list):
        good = (isinstance(value, list) and (len(value) == 2 if key in _PAIRS else len(value) > 0)
                and all(_is_number(v) for v in value))
        return None if good else ("a pair of finite numbers" if key in _PAIRS
                                  else "a non-empty list of finite numbers")
    return None


def _sign_problem(value: Any, key: str) -> str | None:
    if key in _POSITIVE and not value > 0:
        return "> 0"
    if key in _NON_NEGATIVE and not value >= 0:
        return ">= 0"
    return None


def _check_types(config: dict[str, Any], defaults: dict[str, Any], where: str) -> None:
    for section, table in defaults.items():
        for name, default in table.items():
            key, value = f"{section}.{name}", config[section][name]
            says = _type_problem(value, default, key) or _sign_problem(value, key)
            if says is not None:
                raise UsageError(f"{where}: {key} = {value!r} must be {says}")


def _validate(config: dict[str, Any], where: str = "study config") -> None:
    trials = config["trials"]
    depths = np.asarray(trials["depths_mm"], float)
    if depths.size == 0 or np.any(depths <= 0) or np.any(np.diff(depths) <= 0):
        raise UsageError(f"{where}: trials.depths_mm must be positive and increasing")
    for key in ("speed_mm_s", "travel_mm", "approach_speed_mm_s", "rapid_speed_mm_s", "retract_mm"):
        if not float(trials[key]) > 0:
            raise UsageError(f"{where}: trials.{key} must be positive")
    if trials["slide_sign"] not in (1, -1):
        raise UsageError(f"{where}: trials.slide_sign must be 1 or -1")
    contact = config["contact"]
    if not 0 < float(contact["search_step_mm"]) <= 1.0:
        raise UsageError(f"{where}: contact.search_step_mm must be in (0, 1] mm")
    if not float(contact["threshold_uT"]) > 0:
        raise UsageError(f"{where}: contact.threshold_uT must be positive")
    if float(config["safety"]["overload_uT"]) <= float(contact["threshold_uT"]):
        raise UsageError(f"{where}: safety.overload_uT must exceed contact.threshold_uT")
    if not 0.0 <= float(config["safety"]["max_frame_loss"]) <= 1.0:
        raise UsageError(f"{where}: safety.max_frame_loss is a fraction of the frames, in [0, 1]")


@dataclass(frozen=True)
class PlaneGeometry:
    """Where the plane is, in the whisker frame and in stage coordinates (mm, unit vectors)."""

    origin_stage_mm: np.ndarray
    angle_rad: float
    tilt_rad: float
    slide_sign: int
    tip_reach_mm: float
    fixture_offset_mm: np.ndarray

    @classmethod
    def from_config(cls, config: dict[str, Any]) -> "PlaneGeometry":
        """The geometry a configuration describes."""
        geometry = config["geometry"]
        return cls(origin_stage_mm=np.asarray(geometry["whisker_origin_stage_mm"], float),
                   angle_rad=float(np.radians(geometry["whisker_angle_deg"])),
                   tilt_rad=float(np.radians(geometry["plane_tilt_deg"])),
                   slide_sign=int(config["trials"]["slide_sign"]),
                   tip_reach_mm=float(geometry["tip_reach_mm"]),
                   fixture_offset_mm=np.asarray(geometry["fixture_offset_mm"], float))

    @property
    def push_whisker(self) -> np.ndarray:
        """Unit direction (whisker frame) in which the plane is pushed in: toward the root."""
        return -np.array([np.cos(self.tilt_rad), np.sin(self.tilt_rad)])

    @property
    def slide_whisker(self) -> np.ndarray:
        """Unit direction (whisker frame) of the slide, along the plane."""
        return self.slide_sign * np.array([np.sin(self.tilt_rad), -np.cos(self.tilt_rad)])

    @property
    def frame(self) -> RigFrame:
        """The whisker frame in stage coordinates."""
        x_mm, y_mm = (float(v) for v in self.origin_stage_mm)
        return RigFrame((x_mm, y_mm), self.angle_rad)

    def to_stage_vector(self, vector_whisker: np.ndarray) -> np.ndarray:
        """A direction or displacement (whisker frame) in stage coordinates."""
        return self.frame.vector_to_stage(vector_whisker)

    def contact_guess_stage_mm(self) -> np.ndarray:
        """Stage position at which the plane would pass through the undeflected tip."""
        tip_stage = self.origin_stage_mm + self.to_stage_vector([self.tip_reach_mm, 0.0])
        return tip_stage - self.fixture_offset_mm

    def plane_line_whisker(self, stage_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plane's line in the whisker frame for stage positions (n, 2): points and normals."""
        stage_mm = np.atleast_2d(np.asarray(stage_mm, float))
        points = self.frame.to_whisker(stage_mm + self.fixture_offset_mm)
        normals = np.tile(self.push_whisker, (stage_mm.shape[0], 1))
        return points, normals

    def depth_of_stage_mm(self, stage_mm: np.ndarray, contact_stage_mm: np.ndarray) -> np.ndarray:
        """How far (mm) stage positions push the plane past the first-contact position."""
        push_stage = self.to_stage_vector(self.push_whisker)
        return (np.atleast_2d(stage_mm) - np.asarray(contact_stage_mm, float)) @ push_stage

    def trial_waypoints_stage_mm(self, contact_stage_mm: np.ndarray, depth_mm: float,
                                 config: dict[str, Any]) -> dict[str, np.ndarray]:
        """Stage positions of one trial: retracted start, slide start at depth, slide end, retracted end."""
        trials = config["trials"]
        push = self.to_stage_vector(self.push_whisker)
        slide = self.to_stage_vector(self.slide_whisker)
        start = np.asarray(contact_stage_mm, float) + float(trials["slide_start_mm"]) * slide
        end = start + float(trials["travel_mm"]) * slide
        back = -float(trials["retract_mm"]) * push
        return {"retracted_start": start + back, "slide_start": start + depth_mm * push,
                "slide_end": end + depth_mm * push, "retracted_end": end + back}
