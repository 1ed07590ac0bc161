"""The contour-following controller's constants, with units; a TOML file's ``[follow]`` table
overrides them key by key, every value typed and in range (`FollowConfig`)."""

from __future__ import annotations

from pathlib import Path

from pydantic import model_validator

from whiskercal.tomlconfig import read_toml
from whiskercal.typedconfig import Flag, Table, integer, number, validate

Positive = number(gt=0)
NonNegative = number(ge=0)


class FollowConfig(Table):
    """Constants of the loop (docs/contour.md).

    rate_hz: samples (and commands) per second. total_speed_mm_s: the speed the tangential and
    normal motions share (the paper's 8 mm/s). approach_speed_mm_s: toward the object before the
    first contact. tilt_deg: how far the whisker leans back from the surface's inward normal.
    kp_mm_s_per_uT, ki_mm_s2_per_uT, kd_mm_per_uT: the PID from the deflection error (z minus the
    target, µT) to the normal speed (mm/s), which is limited to normal_speed_max_mm_s; they are
    set for a build whose tip moves gains_tip_mm_per_uT (mm per µT) at the target (the default
    sensor's, 0.0065 at -3123 µT), and a follower told its build's figure there scales them by
    the ratio (a longer or softer whisker moves its tip farther per µT: the same gains in µT
    would leave its deflection barely held).
    heading_gain_per_s: turn rate per radian of heading error, at most turn_max_rad_s (the
    sensor turns about the contact, so the tip stays put while it turns). key_every: samples
    between key points; key_spacing_mm: their least spacing; key_points: how many the B-spline
    goes through.
    slip_drop: a slip is |z| falling below this share of the target's |z| within slip_window_s,
    or the raw tip jumping more than slip_jump_mm between samples; such a fall of |z| made of
    many small steps (none over gradual_step_share of it) with the wire still touching is a tip
    held in a concave corner and pushed along the wire: the sensor backs out of the corner and
    comes in on the next surface (as past a corner too narrow, ``corner_clearance_mm``).
    slip_resets_filter: a slip resets the tracker's filter, whose state is the tip before it.
    press_share: after the first contact the sensor only presses in, until |z| reaches this
    share of the target's.
    lost_after_s: a contact counts as lost only after this long without a tip (the sensor holds
    still meanwhile). backoff_s: after losing contact it backs off this long at the approach
    speed, then lines the whisker up
    with the last key point's inward normal (its tip ``search_standoff_mm`` short of it, turning at
    up to ``search_turn_rad_s``) and comes in again along it. key_noise_mm: the key points'
    scatter (rms) the B-spline smooths; key_turn_max_deg: the most the surface's direction may
    turn from one key point to the next (a noisy prediction is believed only that far).
    slow_heading_deg, stop_heading_deg: when the whisker's heading lags the one the surface asks
    for by more than the first, the tangential speed falls, reaching zero at the second (it then
    only turns, about the contact), so that the lag cannot grow in a bend.
    stall_travel_mm, stall_share: a surface ahead of the tip (a concave corner) holds the tip: when
    the contact has moved along the surface less than ``stall_share`` of the last
    ``stall_travel_mm`` the tangential command asked for, the surface's direction turns away from
    the object by ``corner_turn_deg`` (and again if it stays held); held with the deflection
    kept, or no key point for ``dwell_s`` while following at the target (an edge), it turns
    toward the object by ``edge_hold_turn_deg`` (and again if it stays held: one larger turn
    can lean a long whisker past a rounded edge's normal, and it slips off). search_turn_deg,
    search_turns: when a search passes the last key point without a contact (the surface bent
    toward the object there: an edge), the line it comes in along turns toward the object about
    that key point by ``search_turn_deg`` and it searches again, up to ``search_turns`` times
    before it gives up. edge_turn_deg: a step between key points that turns toward the object
    by more than this is an edge: the surface's direction takes it at once. edge_turn_max_rad_s:
    the turn rate allowed while the heading lags past ``stop_heading_deg`` (the sensor then
    stands still, turning about the contact: past an edge, or a concave corner).
    rise_share: following with the heading caught up, |z| above this share of the target's
    |z| is a tip held by a surface ahead (a concave corner) when the contact has also gone less
    than ``rise_progress_share`` of the last ``stall_travel_mm`` commanded (a tip that goes on,
    pressed harder by a direction not yet the surface's, is not held). corner_clearance_mm: the
    least distance (mm) from the sensor's base to the surface left at a concave corner: when
    turning about the corner would bring the base nearer, the sensor backs out of the corner
    and comes in on the next surface where its base, trailing the tip as far as it did at the
    corner, stays that far from the surface left.
    corner_out_mm: following, a contact this far (mm) outside the surface's line through the
    last key point, on the whisker's side, is a tip held in a concave corner (its axial push
    read as a bend toward the base; a convex surface only bends toward the object, and the key
    points scatter about a tenth of this).
    """

    rate_hz: Positive = 300.0
    total_speed_mm_s: Positive = 8.0
    approach_speed_mm_s: Positive = 5.0
    tilt_deg: NonNegative = 20.0
    kp_mm_s_per_uT: NonNegative = 3e-3
    ki_mm_s2_per_uT: NonNegative = 1e-4
    kd_mm_per_uT: NonNegative = 0.0
    gains_tip_mm_per_uT: Positive = 0.0065
    normal_speed_max_mm_s: Positive = 6.0
    heading_gain_per_s: Positive = 1.0
    turn_max_rad_s: Positive = 0.1
    key_every: integer(ge=1) = 10
    key_spacing_mm: Positive = 2.0
    key_points: integer(ge=4) = 6
    slip_drop: Positive = 0.5
    slip_window_s: Positive = 0.1
    slip_jump_mm: Positive = 3.0
    gradual_step_share: Positive = 0.25
    slip_resets_filter: Flag = True
    press_share: Positive = 0.9
    backoff_s: Positive = 6.0
    lost_after_s: NonNegative = 0.05
    search_standoff_mm: NonNegative = 10.0
    search_turn_rad_s: Positive = 0.3
    key_noise_mm: NonNegative = 0.1
    key_turn_max_deg: Positive = 10.0
    slow_heading_deg: Positive = 20.0
    stop_heading_deg: Positive = 45.0
    stall_travel_mm: Positive = 1.5
    stall_share: Positive = 0.3
    corner_turn_deg: Positive = 45.0
    edge_hold_turn_deg: Positive = 20.0
    search_turn_deg: Positive = 45.0
    edge_turn_deg: Positive = 20.0
    edge_turn_max_rad_s: Positive = 0.3
    dwell_s: Positive = 1.0
    search_turns: integer(ge=0) = 4
    rise_share: Positive = 1.1
    rise_progress_share: Positive = 0.7
    corner_clearance_mm: Positive = 10.0
    corner_out_mm: Positive = 1.0

    @model_validator(mode="after")
    def _stop_past_slow(self) -> "FollowConfig":
        if self.stop_heading_deg <= self.slow_heading_deg:
            raise ValueError("stop_heading_deg must exceed slow_heading_deg")
        return self


class FollowFile(Table):
    """A follow settings file: its one ``[follow]`` table (a key left out keeps its default)."""

    follow: FollowConfig = FollowConfig()


def load_follow_config(path: str | Path | None = None) -> FollowConfig:
    """The defaults, overridden by the ``[follow]`` table of a TOML file when given."""
    if path is None:
        return FollowConfig()
    return validate(FollowFile, read_toml(path), str(path)).follow
