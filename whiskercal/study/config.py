"""The study's configuration: documented TOML defaults, user overrides, and the plane geometry.

Defaults live in ``default_study.toml`` next to this module (every key commented). A user file
overrides any subset of keys; `StudyConfig` types every table, so an unknown key or a bad value
is refused with one clear line.

Geometry (docs/study.md): in the whisker frame the plane is pushed toward the root along
``push = -(cos tilt, sin tilt)`` and slides along ``slide = slide_sign * (sin tilt, -cos tilt)``.
The stage frame is the whisker frame rotated by ``whisker_angle_deg`` and shifted to
``whisker_origin_stage_mm``. The plane's line in the whisker frame at a stage position S passes
through ``R^T (S + fixture_offset - origin)``, where R is that rotation.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import model_validator

from whiskercal.collect.config import MAX_REACH_MM, SensorSettings
from whiskercal.session.frame import RigFrame
from whiskercal.tomlconfig import merge_overrides, read_toml
from whiskercal.typedconfig import Flag, Table, integer, number, numbers, validate

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
            or not 0 < reach <= MAX_REACH_MM or reach == DEFAULT_TIP_REACH_MM:
        return defaults
    factor = float(reach) / DEFAULT_TIP_REACH_MM
    trials = defaults["trials"]
    depths = sorted({max(0.5, round(2.0 * d * factor) / 2.0) for d in trials["depths_mm"]})
    travel = round(trials["travel_mm"] * factor, 1)
    scaled = dict(trials, depths_mm=depths, travel_mm=travel, slide_start_mm=-travel / 2.0)
    return {**defaults, "trials": scaled}


def load_config(path: str | Path | None = None) -> dict[str, Any]:
    """Defaults, overridden by the TOML file at ``path`` when given, validated (`StudyConfig`).

    Returns
    -------
    dict
        The validated configuration as plain nested dicts (numbers of float keys as floats).

    Raises
    ------
    UsageError
        When the file is missing, not TOML, has unknown keys, values of the wrong type or out of
        range; one line naming the file, the table and the key.
    """
    config = default_config()
    if path is not None:
        given = read_toml(path)
        config = merge_overrides(follow_tip_reach(config, given), given)
    where = "study config" if path is None else str(path)
    return validate(StudyConfig, config, where).to_dict()


Number = number()
Positive = number(gt=0)
NonNegative = number(ge=0)
Pair = numbers(2)


class TrialsConfig(Table):
    """The nine depths (mm past first contact, increasing), the slide's speed (mm/s), length and
    start (mm from first contact) and sign, the retract (mm) and the approach and rapid speeds."""

    depths_mm: numbers(least=1, most=64, gt=0)
    speed_mm_s: Positive
    travel_mm: Positive
    slide_start_mm: Number
    slide_sign: integer(ge=-1, le=1)
    retract_mm: Positive
    approach_speed_mm_s: Positive
    rapid_speed_mm_s: Positive

    @model_validator(mode="after")
    def _depths_and_sign(self) -> "TrialsConfig":
        if any(later <= earlier for earlier, later in zip(self.depths_mm, self.depths_mm[1:])):
            raise ValueError("depths_mm must be increasing")
        if self.slide_sign == 0:
            raise ValueError("slide_sign must be 1 or -1")
        return self


class GeometryConfig(Table):
    """Whisker frame in stage coordinates (mm, deg), the tip's reach (mm), the plane's tilt (deg),
    the fixture's offset from the stage position (mm) and the plate's half length and thickness
    (mm)."""

    whisker_origin_stage_mm: Pair
    whisker_angle_deg: Number
    tip_reach_mm: number(gt=0, le=MAX_REACH_MM)
    plane_tilt_deg: Number
    fixture_offset_mm: Pair
    plate_half_length_mm: Positive
    plate_thickness_mm: Positive


class ContactConfig(Table):
    """First-contact search: threshold (µT), start, step (at most 1 mm) and end (mm), samples."""

    threshold_uT: Positive
    search_start_mm: NonNegative
    search_step_mm: number(gt=0, le=1.0)
    search_max_mm: Positive
    samples_per_step: integer(ge=1)
    baseline_samples: integer(ge=1)


class StudySafetyConfig(Table):
    """Overload |z| (µT), margin inside the travel (mm), homing, move timeout (s), and the
    fraction of sensor frames lost above which a run warns."""

    overload_uT: Positive
    travel_margin_mm: NonNegative
    home: Flag
    move_timeout_s: Positive
    max_frame_loss: number(ge=0, le=1, says="a fraction of the frames, in 0..1")


class StudyConfig(Table):
    """Every setting of the plane study, one table per TOML table (default_study.toml)."""

    trials: TrialsConfig
    geometry: GeometryConfig
    contact: ContactConfig
    sensor: SensorSettings
    safety: StudySafetyConfig

    @model_validator(mode="after")
    def _overload_above_contact(self) -> "StudyConfig":
        if self.safety.overload_uT <= self.contact.threshold_uT:
            raise ValueError("safety.overload_uT must exceed contact.threshold_uT")
        return self


WIRE_POINTS = 80  # points of the undeflected whisker a plate position is checked against
PATH_STEP_MM = 0.5  # the plate's positions along a move checked against the whisker


def _length_mm(path) -> float:
    """The length (mm) of straight moves through a path's points."""
    return float(sum(np.linalg.norm(b - a) for a, b in zip(path, path[1:])))


@dataclass(frozen=True)
class PlaneGeometry:
    """Where the plane is, in the whisker frame and in stage coordinates (mm, unit vectors)."""

    origin_stage_mm: np.ndarray
    angle_rad: float
    tilt_rad: float
    slide_sign: int
    tip_reach_mm: float
    fixture_offset_mm: np.ndarray
    plate_half_length_mm: float
    plate_thickness_mm: float

    @classmethod
    def from_config(cls, config: dict[str, Any]) -> "PlaneGeometry":
        """The geometry a configuration describes (a study file written before a key existed
        takes the key's default)."""
        geometry = {**default_config()["geometry"], **config["geometry"]}
        return cls(origin_stage_mm=np.asarray(geometry["whisker_origin_stage_mm"], float),
                   angle_rad=float(np.radians(geometry["whisker_angle_deg"])),
                   tilt_rad=float(np.radians(geometry["plane_tilt_deg"])),
                   slide_sign=int(config["trials"]["slide_sign"]),
                   tip_reach_mm=float(geometry["tip_reach_mm"]),
                   fixture_offset_mm=np.asarray(geometry["fixture_offset_mm"], float),
                   plate_half_length_mm=float(geometry["plate_half_length_mm"]),
                   plate_thickness_mm=float(geometry["plate_thickness_mm"]))

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

    def plate_touches_wire(self, stage_mm: np.ndarray) -> np.ndarray:
        """Whether the plate, at each stage position (n, 2), holds a point of the undeflected
        whisker (n,): a point behind the surface by at most the plate's thickness and within
        its half length along it."""
        stage = np.atleast_2d(np.asarray(stage_mm, float))
        tool = self.frame.to_whisker(stage + self.fixture_offset_mm)
        wire = np.column_stack([np.linspace(0.0, self.tip_reach_mm, WIRE_POINTS),
                                np.zeros(WIRE_POINTS)])
        offset = tool[:, None, :] - wire[None, :, :]
        depth = offset @ self.push_whisker
        along = offset @ self.slide_whisker
        inside = (depth >= 0) & (depth <= self.plate_thickness_mm) & \
            (np.abs(along) <= self.plate_half_length_mm)
        return inside.any(axis=1)

    def path_touches_wire(self, waypoints_stage_mm) -> bool:
        """Whether straight moves through ``waypoints_stage_mm`` carry the plate into the
        undeflected whisker anywhere (checked every ``PATH_STEP_MM``)."""
        points = [np.asarray(p, float) for p in waypoints_stage_mm]
        for start, end in zip(points, points[1:]):
            steps = max(2, int(np.ceil(np.linalg.norm(end - start) / PATH_STEP_MM)) + 1)
            if self.plate_touches_wire(np.linspace(start, end, steps)).any():
                return True
        return False

    def clear_paths_stage_mm(self, here_stage_mm: np.ndarray, target_stage_mm: np.ndarray):
        """Candidate paths from ``here`` to ``target`` (whose plane stands short of the tip),
        shortest first: straight, and through each point of the target's surface line (moves
        along it keep the plane short of the tip). Which of them keep the plate off the wire is
        ``path_touches_wire``'s to say."""
        here, target = np.asarray(here_stage_mm, float), np.asarray(target_stage_mm, float)
        along = self.to_stage_vector(self.slide_whisker)
        reach = (2.0 * (self.plate_half_length_mm + self.tip_reach_mm)
                 + np.linalg.norm(target - here))
        vias = [target + s * along for s in np.arange(-reach, reach, PATH_STEP_MM * 10)]
        paths = [[here, target]] + [[here, via, target] for via in vias]
        return sorted(paths, key=_length_mm)

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
