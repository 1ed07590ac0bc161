"""The twin's ground truth per recorded sample, kept apart from what the rig measures.

The simulated world records the truth of every sample its sensor board converts (time, true tip,
contact point, equilibrium kind, noise-free z). The board stamps each sample with its conversion
time, so a recorded sample is matched to the truth row of the same time. A sample without a
match within half a sample period gets NaN (and kind ``unknown``), never a neighbour's truth.
"""

from __future__ import annotations

import numpy as np

UNKNOWN_KIND = "unknown"


def truth_arrays(world) -> dict[str, np.ndarray]:
    """The world's whole truth record as named arrays (``t_s``, ``tip_mm``, ``kind``, ...)."""
    return world.truth.arrays()


def match_rows(truth_t_s: np.ndarray, sample_t_s: np.ndarray, tolerance_s: float) -> np.ndarray:
    """Index of the truth row at each sample's time, or -1 where none lies within tolerance (s)."""
    truth_t_s = np.asarray(truth_t_s, float)
    sample_t_s = np.asarray(sample_t_s, float)
    if truth_t_s.size == 0:
        return np.full(sample_t_s.size, -1)
    right = np.clip(np.searchsorted(truth_t_s, sample_t_s), 1, truth_t_s.size - 1) \
        if truth_t_s.size > 1 else np.zeros(sample_t_s.size, int)
    left = np.maximum(right - 1, 0)
    nearer_left = np.abs(truth_t_s[left] - sample_t_s) <= np.abs(truth_t_s[right] - sample_t_s)
    nearest = np.where(nearer_left, left, right)
    return np.where(np.abs(truth_t_s[nearest] - sample_t_s) <= tolerance_s, nearest, -1)


def per_sample(world, sample_t_s: np.ndarray, rate_hz: float = 300.0) -> dict[str, np.ndarray]:
    """Truth for each recorded sample: tip_mm, contact_mm (K, 2), kind (K,), z_uT (K,).

    Parameters
    ----------
    world
        The simulated world behind the sensor port (``port.world``).
    sample_t_s
        The board times of the recorded samples (s).
    rate_hz
        The sample rate; a match must lie within half a period.
    """
    record = truth_arrays(world)
    rows = match_rows(record["t_s"], sample_t_s, 0.5 / rate_hz)
    found = rows >= 0
    safe = np.where(found, rows, 0)

    def pick(name: str) -> np.ndarray:
        values = np.asarray(record[name], float)[safe] if len(record["t_s"]) else \
            np.zeros((rows.size,) + np.shape(record[name])[1:])
        values[~found] = np.nan
        return values

    kinds = np.asarray(record["kind"]).astype(str)[safe] if len(record["t_s"]) else \
        np.full(rows.size, UNKNOWN_KIND)
    return {"tip_mm": pick("tip_mm"), "contact_mm": pick("contact_mm"),
            "z_uT": pick("z_true_uT"),
            "kind": np.where(found, kinds, UNKNOWN_KIND).astype("U10")}


def check_world(world, geometry) -> None:
    """Refuse a simulated rig whose stage does not carry the plane the configuration describes.

    Raises
    ------
    UsageError
        When the world has no plane fixture, or its rig geometry or plane tilt differ from the
        configuration's (the errors would be compared with the wrong line).
    """
    from whiskercal.errors import UsageError

    fixture = world.config.fixture
    if fixture.name != "plane":
        raise UsageError(f"the simulated rig carries a {type(fixture).__name__}, not the plane: "
                         "open the stage as sim://NAME/stage?scene=plane")
    rig = world.config.geometry
    pushed = np.array([np.cos(fixture.normal_rad), np.sin(fixture.normal_rad)])
    if (np.max(np.abs(np.asarray(rig.origin_stage_mm) - geometry.origin_stage_mm)) > 1e-6
            or abs(rig.angle_rad - geometry.angle_rad) > 1e-9
            or np.max(np.abs(pushed - geometry.push_whisker)) > 1e-9
            or abs(fixture.half_length_mm - geometry.plate_half_length_mm) > 1e-9
            or abs(fixture.thickness_mm - geometry.plate_thickness_mm) > 1e-9):
        raise UsageError("the configuration's geometry (whisker origin, angle, plane tilt, plate "
                         "size) differs from the simulated rig's; set [geometry] to match "
                         "docs/twin.md")
