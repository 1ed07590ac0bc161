"""Replay a recorded stream through a calibration's runtime tracker, one sample at a time.

z = sign · (Y reading − rest), µT; with a three-axis recording also the chip's Z axis,
axial = axial_sign · (Z reading − axial rest), which the tracker reads through the artifact's
(Y, Z) table or loads where it carries them, as a robot's runtime does. The rest (the static
reading, no contact) differs between sessions by hundreds of µT, so it is chosen per stream
and per axis (:class:`ReplayOptions.rest`, :class:`ReplayOptions.axial_rest`):

- a number: the static reading in µT, as measured at the start of that session;
- ``"recorded"``: the static reading a whiskercal HDF5 file recorded before its run;
- ``"auto"``: the median of the first ``rest_samples`` samples, which must be free of contact
  (refused when more than a tenth of them lie farther from that median than the collision
  threshold).

``sign`` = −1 replays a log whose sensor saw the deflection with the opposite sign to the
calibration's (the sensor or magnet mounted the other way round).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.model.errors import ZOutOfRangeError
from whiskercal.model.lookup import check_out_of_range
from whiskercal.recording import Recording

DEFAULT_POLICY = "clip"
"""Streaming default: the edge tip, flagged (docs/replay.md says why not NaN)."""
DEFAULT_REST_SAMPLES = 100
_REST_OUTLIERS = 0.1  # fraction of the first samples allowed beyond the threshold in "auto"


def _check_rest(rest, name: str) -> None:
    if isinstance(rest, str):
        if rest not in ("auto", "recorded"):
            raise UsageError(f"{name} must be a number (µT), 'auto' or 'recorded', not {rest!r}")
    elif rest is not None and not np.isfinite(rest):
        raise UsageError(f"the {name} reading must be a finite number of µT, not {rest!r}")


@dataclass(frozen=True)
class ReplayOptions:
    """How to turn readings into z (and the Z axis) and what to do with z outside the
    calibrated range."""

    rest: float | str | None = None
    """µT, "recorded", "auto", or None: "recorded" when the stream has one, else "auto"."""
    rest_samples: int = DEFAULT_REST_SAMPLES
    sign: int = 1
    out_of_range: str = DEFAULT_POLICY
    axial_rest: float | str | None = None
    """The Z axis's static reading, as ``rest`` (None: "recorded" when the stream has one,
    else "auto")."""
    axial_sign: int = 1

    def __post_init__(self) -> None:
        check_out_of_range(self.out_of_range)
        for name in ("sign", "axial_sign"):
            if getattr(self, name) not in (1, -1):
                raise UsageError(f"{name.replace('_', ' ')} must be 1 or -1, not "
                                 f"{getattr(self, name)!r}")
        if not isinstance(self.rest_samples, int) or self.rest_samples < 1:
            raise UsageError(f"rest samples must be a positive integer, not {self.rest_samples!r}")
        _check_rest(self.rest, "rest")
        _check_rest(self.axial_rest, "axial rest")


@dataclass
class ReplayResult:
    """Per sample (n,): time s, z µT, the Z axis from rest µT (NaN for a Y-only stream),
    contact, raw and filtered tips (n, 2) mm (NaN where none), out_of_range (-1 below, +1 above
    the calibrated range, 0 otherwise; contact samples only), extrapolated; the world frame's
    contact (n, 2) mm and the sensor base's pose (n, 3) (NaN without poses, or where the poses
    had a gap); and the settings and cost of the run."""

    t_s: np.ndarray
    z_uT: np.ndarray
    contact: np.ndarray
    raw_tip_mm: np.ndarray
    filtered_tip_mm: np.ndarray
    out_of_range: np.ndarray
    extrapolated: np.ndarray
    rest_uT: float
    rest_source: str
    policy: str
    z_range_uT: tuple[float, float]
    per_sample_us: float
    source: str = ""
    warnings: list[str] = field(default_factory=list)
    axial_uT: np.ndarray | None = None
    axial_rest_uT: float | None = None
    world_mm: np.ndarray | None = None
    base_pose: np.ndarray | None = None
    world: dict = field(default_factory=dict)
    """How the world frame was made (poses, mount, gaps); empty without poses."""

    def __len__(self) -> int:
        return len(self.t_s)

    def counts(self) -> dict[str, int]:
        """Samples, contact samples, and contact samples in and out of the calibrated range."""
        below = int(np.count_nonzero(self.out_of_range < 0))
        above = int(np.count_nonzero(self.out_of_range > 0))
        contact = int(np.count_nonzero(self.contact))
        return {"samples": len(self), "contact_samples": contact,
                "in_range": contact - below - above, "out_of_range": below + above,
                "out_of_range_below": below, "out_of_range_above": above}

    def summary(self) -> dict:
        """What the replay found, JSON-able: counts, the rest, the range, the cost, warnings."""
        finite = self.z_uT[np.isfinite(self.z_uT)]
        duration = float(self.t_s[-1] - self.t_s[0]) if len(self) else 0.0
        return {"source": self.source, **self.counts(), "duration_s": duration,
                "axes": 1 if self.axial_uT is None else 3,
                "rest_uT": self.rest_uT, "rest_source": self.rest_source,
                "axial_rest_uT": self.axial_rest_uT,
                "out_of_range_policy": self.policy,
                "calibrated_z_range_uT": list(self.z_range_uT),
                "z_min_uT": float(finite.min()) if len(finite) else None,
                "z_max_uT": float(finite.max()) if len(finite) else None,
                "extrapolated_samples": int(np.count_nonzero(self.extrapolated)),
                "per_sample_us": self.per_sample_us, "world": dict(self.world),
                "warnings": list(self.warnings)}


def resolve_rest(stream: Recording, options: ReplayOptions, threshold_uT: float,
                 axis: int = 1) -> tuple[float, str]:
    """The rest reading (µT) of the Y axis (``axis`` 1) or the Z axis (2), and a phrase saying
    where it came from."""
    rest = options.rest if axis == 1 else options.axial_rest
    values = stream.y_uT if axis == 1 else stream.axial_uT
    recorded = stream.recorded_rest_uT
    if recorded is not None and np.ndim(recorded) > 0:
        recorded = recorded[axis]
    elif axis == 2:
        recorded = None
    if axis == 2 and rest is None and isinstance(options.rest, str):
        rest = options.rest  # the Z axis follows --rest auto / recorded
    if rest is None:
        rest = "recorded" if recorded is not None else "auto"
    option = "--rest-uT" if axis == 1 else "--axial-rest-uT"
    if rest == "recorded":
        if recorded is None:
            raise UsageError(f"{stream.source}: the stream records no static reading; give the "
                             f"rest reading in µT ({option}) or use --rest auto")
        return float(recorded), "recorded in the stream's file"
    if rest == "auto":
        return _auto_rest(values, options.rest_samples, threshold_uT, option)
    return float(rest), "given"


def _auto_rest(values: np.ndarray, n: int, threshold_uT: float, option: str) -> tuple[float, str]:
    first = np.asarray(values, float)[:n]
    if len(first) < n:
        raise UsageError(f"--rest auto needs {n} samples before contact; the stream has "
                         f"{len(first)}")
    rest = float(np.median(first))
    moved = int(np.count_nonzero(np.abs(first - rest) > threshold_uT))
    if moved > _REST_OUTLIERS * n:
        raise UsageError(f"--rest auto: {moved} of the first {n} samples lie more than "
                         f"{threshold_uT:g} µT from their median {rest:.1f} µT, so the stream "
                         f"does not start at rest; give the rest reading with {option}")
    return rest, f"median of the first {n} samples"


def replay(stream: Recording, calibration, options: ReplayOptions = ReplayOptions(),
           world=None) -> ReplayResult:
    """Run every sample of ``stream`` through ``calibration.tracker(options.out_of_range)``.

    ``calibration`` is a :class:`whiskercal.runtime.Calibration`; ``world`` a
    :class:`whiskercal.replay.world.WorldFrame` (poses and mount) or None. Under the streaming
    policies ("clip", "nan") nothing raises mid-stream; under "raise" the first z outside the
    calibrated range in contact raises :class:`ZOutOfRangeError` naming the sample and its time.
    """
    threshold = calibration.collision_params.threshold_uT
    rest, rest_source = resolve_rest(stream, options, threshold)
    z = options.sign * (np.asarray(stream.y_uT, float) - rest)
    axial, axial_rest = None, None
    if stream.axial_uT is not None:
        axial_rest, axial_source = resolve_rest(stream, options, threshold, axis=2)
        axial = options.axial_sign * (np.asarray(stream.axial_uT, float) - axial_rest)
        rest_source = f"{rest_source}; Z: {axial_source}"
    tracker = calibration.tracker(options.out_of_range)
    started = time.perf_counter()
    states = _track(tracker, z, axial, stream.t_s)
    per_sample_us = (time.perf_counter() - started) / max(len(z), 1) * 1e6
    result = ReplayResult(np.asarray(stream.t_s, float), z, *_columns(states), rest, rest_source,
                          options.out_of_range, tuple(calibration.z_range_uT), per_sample_us,
                          stream.source, axial_uT=axial, axial_rest_uT=axial_rest)
    if world is not None:
        world.place(result)
    result.warnings = _warnings(result)
    return result


def _track(tracker, z: np.ndarray, axial: np.ndarray | None, t_s: np.ndarray) -> list:
    update, states = tracker.update, []
    append = states.append
    try:
        if axial is None:
            for value in z.tolist():
                append(update(value))
        else:
            for value, axis in zip(z.tolist(), axial.tolist()):
                append(update(value, axis))
    except ZOutOfRangeError as error:
        index = len(states)
        raise ZOutOfRangeError(f"sample {index} (t = {t_s[index]:.3f} s): {error}; replay with "
                               "--out-of-range clip or nan to go on past it") from None
    return states
def _columns(states: list) -> tuple[np.ndarray, ...]:
    n = len(states)
    contact = np.fromiter((s.contact for s in states), bool, n)
    raw = np.full((n, 2), np.nan)
    filtered = np.full((n, 2), np.nan)
    for i, state in enumerate(states):
        if state.raw_tip_mm is not None:
            raw[i] = state.raw_tip_mm
        if state.filtered_tip_mm is not None:
            filtered[i] = state.filtered_tip_mm
    side = np.fromiter((s.out_of_range for s in states), np.int8, n)
    extrapolated = np.fromiter((s.extrapolated for s in states), bool, n)
    return contact, raw, filtered, side, extrapolated


def _warnings(result: ReplayResult) -> list[str]:
    counts = result.counts()
    found = []
    if counts["contact_samples"] == 0:
        found.append("no sample was in contact: check the rest reading (--rest-uT) and the sign")
        return found
    low, high = result.z_range_uT
    z = result.z_uT[result.contact]
    if high <= 0 and np.mean(z > 0) > 0.5:
        found.append(f"most contact samples have z > 0 while the calibrated range is "
                     f"[{low:.0f}, {high:.0f}] µT: the sensor may be mounted the other way round "
                     "(--sign -1) or the rest reading is wrong")
    unplaced = result.world.get("contact_samples_without_pose", 0)
    if unplaced > 0.1 * counts["contact_samples"]:
        found.append(f"{unplaced} of {counts['contact_samples']} contact samples lay farther than "
                     f"{result.world['max_pose_gap_ms']:g} ms from every pose: no world point "
                     "(a gap in the poses, or clocks apart; --max-pose-gap-ms, --pose-latency-ms)")
    if counts["out_of_range"] > 0.1 * counts["contact_samples"]:
        found.append(f"{counts['out_of_range']} of {counts['contact_samples']} contact samples "
                     f"lay outside the calibrated range [{low:.0f}, {high:.0f}] µT "
                     f"({result.policy}: flagged)")
    return found
