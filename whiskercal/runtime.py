"""What a robot loads: a calibration artifact -> tip position per sample, with contact and filter.

>>> from whiskercal import runtime
>>> calibration = runtime.load("CAL.h5")              # doctest: +SKIP
>>> calibration.tip(-3000.0)                           # (x, y) mm     # doctest: +SKIP
>>> tracker = calibration.tracker()                    # doctest: +SKIP
>>> state = tracker.update(z_uT)   # per sample: contact, raw and filtered tip   # doctest: +SKIP
>>> state = tracker.update(z_uT, axial_uT)   # with the chip's Z axis too   # doctest: +SKIP

Loading validates the schema (an unknown major version is refused with a clear message) and
never executes code. A calibration written with ``whiskercal fit --allow-extrapolation`` marks
the z whose tips lie farther past the grid than its limit: they are refused like z outside the
calibrated range, unless loaded with ``allow_extrapolated=True`` (then each such sample is
flagged in ``TrackerState.extrapolated``). Evaluation uses only the precomputed lookup: one
sample takes about a microsecond, a batch runs at tens of millions of samples a second
(docs/model.md).

Every expected failure raises a :class:`~whiskercal.errors.WhiskercalError` subclass, listed per
function below: a z that is not a real number (a string, None, a complex or ragged array) is a
:class:`~whiskercal.errors.UsageError`; NaN and ±inf are numbers, handled by the out-of-range
policy (and ignored by contact detection).

Two axes: an artifact written by ``whiskercal fit`` (unless ``--no-field-table``, or where the
fit withheld it) carries a (Y, Z) -> tip table (docs/calibration.md). Given the Z axis too (``axial_uT``, µT from its static reading),
the tracker reads the tip there (bilinear, a few microseconds), which tells a tip pushed with
friction or by a slanted surface from one pushed square at the same Y; where the table has no
tip (outside what tip loads reach) it falls back to the z lookup, whose out-of-range policy
then applies (a z the table answers is never out of range); except where Y lies within the
table's span and Z more than one cell beyond every tip the table answers at that Y (a load past
any the model tabulated, ``FieldTipTable.beyond_loads``): there the z lookup would place the tip
on the frictionless curve tens of millimetres off, so the sample is out of range under every
policy (raised under "raise"; no raw tip under "clip" and "nan", flagged -1 / +1 for Z below /
above). Without the table, or without
``axial_uT``, the tracker is the z lookup alone, as for every older artifact.

Where the fit withheld the table because one (Y, Z) reading fits tip loads far apart (a stiff
suspension), the artifact may carry the model's loads instead (``/load_branches``, 1.5): given
the Z axis, the tracker follows the load through every sample, from rest
(:class:`~whiskercal.model.load_branches.BranchFollower`, tens of microseconds a sample), so it
must be fed every sample, in contact or not, with the Z axis. A reading no load near the
followed one explains (the contact left the loads) gets no tip under every policy, as past the
table's loads.

Out-of-range z in contact (``out_of_range``, per tracker):

- ``"raise"`` (the default, strict): :class:`ZOutOfRangeError`, the tracker stays usable;
- ``"clip"`` (streaming): the tip at the nearest end of the calibrated range, the sample
  flagged in ``TrackerState.out_of_range`` (-1 below, +1 above); the filter is fed the edge tip;
- ``"nan"`` (streaming): no raw tip, the filter keeps its state, the sample flagged the same way.

Neither streaming policy raises on any float, NaN and inf included (a non-finite z keeps the
previous contact decision and gives no raw tip). ``whiskercal replay`` streams with ``"clip"``
(docs/replay.md says why).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from numbers import Real
from pathlib import Path

import numpy as np

from whiskercal.artifacts.calibration import (CalibrationData, collision_params_of,
                                              kalman_params_of, lookup_of, problem_of,
                                              read_calibration)
from whiskercal.artifacts.h5io import malformed_is_an_error
from whiskercal.errors import UsageError
from whiskercal.model.field_table import FieldTipTable
from whiskercal.model.load_branches import LoadBranches
from whiskercal.model.collision import CollisionDetector, CreepInverse, RestTracker, RezeroParams
from whiskercal.model.errors import ExtrapolationLimitError, ZOutOfRangeError
from whiskercal.model.kalman import FILTER_RATE_HZ, ConstantStateKalman, rate_scaled
from whiskercal.model.lookup import TipLookup, check_out_of_range
from whiskercal.model.trace import get_tracer


@dataclass(frozen=True)
class TrackerState:
    """One sample's result (mm).

    ``raw_tip_mm`` is None without contact (or with z outside the calibrated range under the
    "nan" policy); ``filtered_tip_mm`` is None until the filter has its first tip in a contact.
    ``extrapolated`` is True when the raw tip came from the part of the range marked as
    extrapolated past the grid (only when loaded with ``allow_extrapolated=True``).
    ``out_of_range`` is -1 (below) or +1 (above) when, in contact, z lay outside the range the
    lookup answers (``Calibration.z_range_uT``), or the Z axis beyond every load the (Y, Z)
    table answers at that z, and a streaming policy handled it; else 0. ``z_uT``: the
    deflection the tracker read, less its re-zeroed rest (a tracker made with ``rezero``;
    NaN otherwise: z as fed).
    """

    contact: bool
    raw_tip_mm: np.ndarray | None
    filtered_tip_mm: np.ndarray | None
    extrapolated: bool = False
    out_of_range: int = 0
    z_uT: float = float("nan")


class Tracker:
    """Streaming collision detection, lookup and constant-state Kalman filter, one z at a time;
    with ``rezero``, the rest re-zeroed out of contact (``model.collision.RestTracker``)."""

    def __init__(self, calibration: "Calibration", out_of_range: str = "raise",
                 rezero: RezeroParams | None = None, rate_hz: float | None = None,
                 creep: tuple[float, float] | None = None) -> None:
        """Raises ModelError for an ``out_of_range`` policy other than "raise", "nan", "clip",
        or a ``rate_hz`` that is not a positive number."""
        check_out_of_range(out_of_range)
        self._calibration = calibration
        self._out_of_range = out_of_range
        self._detector = CollisionDetector(calibration.collision_params)
        self._kalman = ConstantStateKalman(rate_scaled(calibration.kalman_params, rate_hz))
        branches = calibration.load_branches
        self._follower = None if branches is None else branches.follower()
        self._rest = None if rezero is None else RestTracker(rezero)
        self._creep = None if creep is None else CreepInverse(*creep, rate_hz or FILTER_RATE_HZ)

    @property
    def rest_uT(self) -> np.ndarray:
        """The rest (Y, Z) µT the tracker subtracts (zeros without ``rezero``)."""
        return np.zeros(2) if self._rest is None else self._rest.rest_uT.copy()

    def reset_filter(self) -> None:
        """Forget the filter's state (after a slip: the next raw tip starts it again)."""
        self._kalman.reset()

    def update(self, z_uT: float, axial_uT: float | None = None) -> TrackerState:
        """Feed one deflection sample (µT, relative to static), and optionally the chip's Z axis
        (µT, relative to its static reading) for the artifact's (Y, Z) table; with ``rezero``,
        relative to the re-zeroed rest instead (the stream must start out of contact).

        Raises
        ------
        ZOutOfRangeError
            In contact with z outside the calibrated range under the "raise" policy; the tracker
            stays usable and keeps its filter state. The "clip" and "nan" policies never raise:
            they flag the sample in ``TrackerState.out_of_range``.
        UsageError
            When z is not one real number; the tracker's state is unchanged.
        """
        if self._rest is None and self._creep is None:
            return self._update(z_uT, axial_uT)
        if type(z_uT) is not float:
            z_uT = _z_scalar(z_uT)
        reading = (z_uT, float("nan") if axial_uT is None else float(axial_uT))
        settling = self._rest is not None and not self._rest.settled
        if settling:  # the first readings are the rest, before anything is decided on them
            self._rest.observe(reading, False)
        rest = np.zeros(2) if self._rest is None else self._rest.rest_uT
        zeroed = np.array(reading) - rest
        if self._creep is not None:
            zeroed = self._creep.update(zeroed)
        z0, axial0 = float(zeroed[0]), None if axial_uT is None else float(zeroed[1])
        state = self._update(z0, axial0)
        if self._rest is not None and not settling:
            self._rest.observe(reading, state.contact)
        return replace(state, z_uT=z0)

    def _update(self, z_uT: float, axial_uT: float | None = None) -> TrackerState:
        """One sample relative to the rest: contact, lookup, filter (raises as ``update``)."""
        if type(z_uT) is not float:  # the per-sample path: plain floats skip the checks
            z_uT = _z_scalar(z_uT)
        was_in_contact = self._detector.contact
        contact = self._detector.update(z_uT)
        followed = self._follow(z_uT, axial_uT, contact)
        if not contact:
            if was_in_contact:
                self._kalman.reset()
            return TrackerState(False, None, None)
        lookup, table = self._calibration.lookup, self._calibration.field_table
        x = y = float("nan")
        if table is not None and axial_uT is not None:
            axial_uT = float(axial_uT)
            x, y = table.tip_scalar(z_uT, axial_uT)
            beyond = 0 if x == x else table.beyond_loads(z_uT, axial_uT)
            if beyond:
                return self._beyond_loads(z_uT, axial_uT, beyond)
        elif followed is not None:
            x, y = followed
            low, high = self._follower.branches.y_range_uT
            if x != x and low <= z_uT <= high:
                return self._beyond_loads(z_uT, float(axial_uT), 1)
        if x == x:  # the table answered: z lies inside its range
            side = 0
        else:
            x, y = lookup.tip_scalar(z_uT, self._out_of_range)
            side = -1 if z_uT < lookup.z_min_uT else 1 if z_uT > lookup.z_max_uT else 0
        if x != x:  # NaN: a non-finite z, or out of range under the "nan" policy
            return self._no_tip(side)
        raw = np.array([x, y])
        flagged = self._calibration._flagged(z_uT)
        return TrackerState(True, raw, self._kalman.update(raw), flagged, side)

    def _follow(self, z_uT: float, axial_uT, contact: bool):
        """The followed load's tip for this sample, or None without loads or the Z axis. Every
        sample is followed, in contact or not, so a contact is followed from rest; out of
        contact, a reading at rest starts the follower over."""
        if self._follower is None or axial_uT is None:
            return None
        axial_uT = float(axial_uT)
        if not contact and self._follower.branches.at_rest(z_uT, axial_uT):
            self._follower.reset()
        return self._follower.tip_scalar(z_uT, axial_uT)

    def _no_tip(self, side: int) -> TrackerState:
        """In contact with no raw tip: the filter keeps its state, the sample flagged ``side``."""
        filtered = self._kalman.state_mm
        return TrackerState(True, None, None if filtered is None else filtered.copy(), False,
                            side)

    def _beyond_loads(self, z_uT: float, axial_uT: float, side: int) -> TrackerState:
        """A (Y, Z) past every load the table (or the followed loads) was made from: no tip
        under any policy (there is no edge to clip to), raised under "raise"."""
        if self._out_of_range == "raise":
            raise ZOutOfRangeError(f"(Y, Z) = ({z_uT:.1f}, {axial_uT:.1f}) µT lies beyond every "
                                   "tip load the calibration's (Y, Z) model was made from")
        return self._no_tip(side)


class Calibration:
    """A loaded calibration artifact.

    Attributes
    ----------
    data : CalibrationData
        Everything the file holds (metrics, provenance, settings).
    z_range_uT : (float, float)
        The range the lookup answers: the calibrated range, less the part marked as extrapolated
        unless ``allow_extrapolated``.
    trusted_z_range_uT : (float, float) or None
        The part whose tips lie within the extrapolation limit (None: no part).
    target_z_uT : float or None
        The optimal deflection target once the optimal-depth study has written one.
    field_table : FieldTipTable or None
        The (Y, Z) -> tip table when the artifact carries one (``fit``'s default).
    load_branches : LoadBranches or None
        The tip loads a tracker follows through each contact, where the fit withheld the table
        because the (Y, Z) readings fold (module docstring).

    Raises
    ------
    ExtrapolationLimitError
        When every tip of the calibration is marked as extrapolated and ``allow_extrapolated``
        is False.
    """

    def __init__(self, data: CalibrationData, allow_extrapolated: bool = False) -> None:
        self.data = data
        self.trusted_z_range_uT = data.trusted_range_uT()
        self.lookup = _lookup(data, allow_extrapolated)
        # only an allowed extrapolated part can answer a z that needs a flag
        self._flagging = bool(allow_extrapolated and data.extrapolated)
        self.kalman_params = kalman_params_of(data)
        self.collision_params = collision_params_of(data)
        self.z_range_uT = (self.lookup.z_min_uT, self.lookup.z_max_uT)
        self.target_z_uT = data.target_z_uT
        self.sensor_id = data.sensor_id
        self.field_table = _field_table(data)
        self.load_branches = _load_branches(data)
        self._problem = None

    def tip(self, z_uT, out_of_range: str = "raise") -> np.ndarray:
        """Tip (2,) or (..., 2) mm for z (scalar or array, µT).

        ``out_of_range``: "raise" (ZOutOfRangeError), "nan" (NaN tips) or "clip" (the nearest
        end of the calibrated range).

        Raises
        ------
        ZOutOfRangeError
            Some z (NaN and ±inf included) lies outside the range under the "raise" policy.
        ModelError
            ``out_of_range`` is not one of the three policies.
        UsageError
            z is not a real number or a (rectangular) array of them.
        """
        return self.lookup(_z_array(z_uT), out_of_range)

    def extrapolated(self, z_uT) -> np.ndarray:
        """True where z (µT) lies in the calibrated range's part marked as extrapolated.

        Raises UsageError when z is not a real number or a (rectangular) array of them.
        """
        z = _z_array(z_uT)
        if not self.data.extrapolated:
            return np.zeros(z.shape, bool)
        inside = (z >= self.data.lookup_z_uT[0]) & (z <= self.data.lookup_z_uT[-1])
        if self.trusted_z_range_uT is None:
            return inside
        low, high = self.trusted_z_range_uT
        return inside & ((z < low) | (z > high))

    def tip_motion_mm_per_uT(self, z_uT: float) -> float:
        """How far (mm) the lookup's tip moves per µT of deflection about ``z_uT`` (a central
        difference over 1 % of the calibrated range; a z outside the range is taken at its
        nearest end, one-sided there): what a controller that holds a deflection needs to scale
        its gains to the build.

        Raises UsageError when z is not one real number.
        """
        low, high = self.z_range_uT
        z_uT = min(max(_z_scalar(z_uT), low), high)
        step = 0.01 * (high - low)
        below, above = max(z_uT - step, low), min(z_uT + step, high)
        tips = self.tip(np.array([below, above]), out_of_range="clip")
        return float(np.linalg.norm(tips[1] - tips[0]) / (above - below))

    def _flagged(self, z_uT: float) -> bool:
        """The tracker's per-sample test, for a z the lookup has already answered."""
        if not self._flagging:
            return False
        trusted = self.trusted_z_range_uT
        return trusted is None or not trusted[0] <= z_uT <= trusted[1]

    def tracker(self, out_of_range: str = "raise", rezero: bool | RezeroParams = False,
                rate_hz: float | None = None,
                creep: tuple[float, float] | None = None) -> Tracker:
        """A fresh streaming tracker (collision detection + lookup + filter).

        ``out_of_range``: "raise" (strict), "clip" or "nan" (streaming, flagged; module docstring).
        ``rezero``: True (or ``RezeroParams``) re-zeroes the rest out of contact, so a drifting
        reading is tracked and the collision threshold follows it; the stream must then start
        out of contact (its first readings are the rest). Off by default.
        ``rate_hz``: the stream's sample rate; the filter's process noise, set per sample at
        ``model.kalman.FILTER_RATE_HZ``, is scaled to it (``model.kalman.rate_scaled``), so
        that the filter follows a moving tip as fast in time at 30 Hz as at 300 Hz. None: as
        the artifact has it. ``creep``: (share, time constant s) of the suspension's creep,
        measured on the rig: each reading is read less its crept part
        (``model.collision.CreepInverse``, at ``rate_hz`` or 300 Hz).
        Raises ModelError for any other policy.
        """
        params = RezeroParams() if rezero is True else rezero or None
        return Tracker(self, out_of_range, params, rate_hz, creep)

    def trace(self, z_uT: float, tracer: str = "fast") -> np.ndarray:
        """The tip (2,) mm traced at z (µT) on the stored surface (slow; for checks, not for the
        control loop).

        Raises
        ------
        TraceError
            The trace fails (a subclass says why: z out of range, the domain left, ...).
        ModelError
            ``tracer`` names no tracer.
        UsageError
            z is not one real number.
        """
        z_uT = _z_scalar(z_uT)
        trace = get_tracer(tracer)
        if self._problem is None:
            self._problem = problem_of(self.data)
        return trace(self._problem, z_uT).tip_mm


def _field_table(data: CalibrationData) -> FieldTipTable | None:
    """The artifact's (Y, Z) -> tip table, or None (older artifacts, Y-only fits)."""
    table = data.field_table
    if table is None:
        return None
    return FieldTipTable(table["y_uT"], table["axial_uT"], table["tip_mm"])


def _load_branches(data: CalibrationData) -> LoadBranches | None:
    """The artifact's followed tip loads, or None (a table, Y only, older artifacts)."""
    return None if data.load_branches is None else LoadBranches.from_arrays(data.load_branches)


def _lookup(data: CalibrationData, allow_extrapolated: bool) -> TipLookup:
    """The artifact's lookup, narrowed to its trusted range unless extrapolation is allowed."""
    if allow_extrapolated or not data.extrapolated:
        return lookup_of(data)
    trusted = data.trusted_range_uT()
    if trusted is None:
        raise ExtrapolationLimitError(
            f"every tip of this calibration lies more than {data.max_extension_mm:g} mm past its "
            "grid (written with --allow-extrapolation): load it with allow_extrapolated=True to "
            "use it anyway")
    return lookup_of(data, trusted)


def load(path: str | Path, allow_extrapolated: bool = False) -> Calibration:
    """Load and validate a calibration artifact (schema ``whiskercal.calibration`` 1.x).

    ``allow_extrapolated``: answer z in the range marked as extrapolated past the grid too
    (flagged by :meth:`Calibration.extrapolated` and ``TrackerState.extrapolated``) instead of
    refusing it.

    Raises
    ------
    ArtifactError
        The file is missing, not a calibration artifact, torn, or of another major version.
    ExtrapolationLimitError
        Every tip is marked as extrapolated and ``allow_extrapolated`` is False.
    UsageError
        ``path`` is not a path or ``allow_extrapolated`` not a bool.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise UsageError(f"a calibration path must be a str or a path, not {type(path).__name__}")
    if not isinstance(allow_extrapolated, (bool, np.bool_)):
        raise UsageError("allow_extrapolated must be True or False, "
                         f"not {type(allow_extrapolated).__name__}")
    data = read_calibration(path)
    with malformed_is_an_error(path, "calibration artifact"):  # settings of the wrong type
        return Calibration(data, allow_extrapolated)


def _z_scalar(z_uT) -> float:
    """One z as a float; anything but a real number (bools, strings, arrays) is refused."""
    if isinstance(z_uT, np.ndarray) and z_uT.ndim == 0:
        z_uT = z_uT[()]
    if isinstance(z_uT, (bool, np.bool_)) or not isinstance(z_uT, Real):
        raise UsageError(f"z must be one real number of µT, not {_shown(z_uT)}")
    return float(z_uT)


def _z_array(z_uT) -> np.ndarray:
    """z (scalar or array) as a float array; non-numbers, complex or ragged arrays are refused."""
    try:
        z = np.asarray(z_uT)
    except ValueError:  # ragged nested sequences
        raise UsageError(f"z must be a real number or a rectangular array of them, "
                         f"not {_shown(z_uT)}") from None
    if z.dtype.kind not in "iuf":
        raise UsageError(f"z must be a real number or an array of them (µT), not {_shown(z_uT)}")
    return z.astype(float, copy=False)


def _shown(value) -> str:
    text = repr(value)
    return f"{type(value).__name__} {text[:40]}{'...' if len(text) > 40 else ''}"
