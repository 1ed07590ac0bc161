"""The paper's closed loop, one sample at a time: keep the whisker at the target deflection
against an unknown object and move along it, leaving contact points in the world frame.

Per sample: the runtime tracker turns z into a filtered tip (whisker frame; with the chip's Z
axis too when the calibration carries a (Y, Z) table: ``runtime.Tracker.update``), the robot's pose
puts it in the world; every ``key_every`` samples a key point is kept (at least ``key_spacing_mm``
from the last); a cubic B-spline through the last ``key_points`` predicts the next, and so the
surface's direction; the sensor turns so that the whisker leans ``tilt_deg`` back from the
surface's inward normal; a PID on z minus the target sets the normal speed, and the tangential
speed takes what is left of the total. The object is kept on the left (counter-clockwise).

The controller's state is one ``follow.phases.Phase``; each sample goes to the handler of the
phase it is in, and every change of phase is one of the named rules of ``follow.phases.RULES``,
logged in the step returned.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from whiskercal.follow.config import FollowConfig
from whiskercal.follow.phases import RULES, TOUCHING, TURNING, Phase, Transition
from whiskercal.follow.predictor import surface_step


class Robot(Protocol):
    """What the loop needs of whatever carries the sensor (a real arm's driver or the twin)."""

    def pose(self) -> np.ndarray:
        """(x mm, y mm, heading rad) of the sensor's base frame in the world frame."""

    def command(self, velocity_mm_s, turn_rad_s: float) -> None:
        """Move at a world-frame velocity (mm/s) and turn at a rate (rad/s)."""


@dataclass(frozen=True)
class Step:
    """What one sample did: the contact point estimated (world, mm; NaN without one), the phase
    that handled the sample (a ``Phase``'s value), whether a slip was seen, the commands sent,
    and the changes of phase made during the sample (``Transition``; a rule that fires while a
    sample is handled takes effect from the next one)."""

    contact_mm: np.ndarray
    phase: str
    slip: bool
    velocity_mm_s: np.ndarray
    turn_rad_s: float
    transitions: tuple = ()


def _unit(angle: float) -> np.ndarray:
    return np.array([math.cos(angle), math.sin(angle)])


_NO_CONTACT = np.full(2, np.nan)


class Follower:
    """The controller (see the module's docstring) over a runtime ``Tracker``; its state is one
    ``Phase`` (``phase``), changed only by the rules of ``follow.phases.RULES``."""

    def __init__(self, tracker, target_z_uT: float, config: FollowConfig = FollowConfig(),
                 reach_mm: float = 78.0, tip_mm_per_uT: float | None = None) -> None:
        """``tip_mm_per_uT``: how far the build's tip moves per µT at the target (the
        calibration's ``tip_motion_mm_per_uT``); the PID's gains scale by its ratio to
        ``config.gains_tip_mm_per_uT`` (None: the gains as they are)."""
        self.tracker, self.target_z_uT, self.config = tracker, float(target_z_uT), config
        self.reach_mm = float(reach_mm)  # centre of rotation to the undeflected tip
        self.gain_scale = 1.0 if tip_mm_per_uT is None else float(tip_mm_per_uT) / config.gains_tip_mm_per_uT
        self.phase = Phase.APPROACH
        self._resume = Phase.PRESS  # the phase a turn about a corner returns to
        self._last_turn: Phase | None = None  # the turning phase the last corner rule moved to
        self._log: list[Transition] = []  # this sample's changes of phase
        self.keys: deque = deque(maxlen=config.key_points)
        self.tangent: np.ndarray | None = None
        self._samples, self._integral, self._last_error = 0, 0.0, None
        self._recent_z: deque = deque(maxlen=max(2, int(config.slip_window_s * config.rate_hz)))
        self._last_raw: np.ndarray | None = None
        self._backing, self._lined_up = 0, False  # back-off samples left; the search's first leg done
        self._retreat: np.ndarray | None = None  # the back-off's direction (None: along the whisker)
        self._bend_mm = math.inf  # radius of the bend through the key points (new at each one)
        self._missing, self._grace = 0, int(round(config.lost_after_s * config.rate_hz))
        # (tangential travel commanded so far, mm; the contact then; |z|): for a tip held ahead
        self._travel, self._progress = 0.0, deque()
        self._search_turned = 0  # turns of the search line about the last key point so far
        self._dwell = 0  # samples following since the last key point
        self._left_outward: np.ndarray | None = None  # the surface left at a concave corner
        # (the corner, world mm; the outward normal of the surface left) while backing out of a
        # concave corner and coming in on the next surface, until it is touched
        self._passing: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def gave_up(self) -> bool:
        """Stopped for good (phase ``stopped``)."""
        return self.phase is Phase.STOPPED

    def update(self, z_uT: float, robot: Robot, axial_uT: float | None = None) -> Step:
        """Feed one z sample (µT from rest) and, when the magnetometer streams it, the chip's Z
        axis (``axial_uT``, µT from its reading at rest); command the robot; return what was
        done. The tracker reads the tip from both when its calibration carries a (Y, Z) table,
        from z alone otherwise (and without ``axial_uT``)."""
        state = (self.tracker.update(float(z_uT)) if axial_uT is None
                 else self.tracker.update(float(z_uT), float(axial_uT)))
        zeroed = getattr(state, "z_uT", math.nan)  # a re-zeroing tracker's z, less its rest
        if zeroed == zeroed:
            z_uT = zeroed
        pose = robot.pose()
        slip, fell_gradually = self._slip(z_uT, state.raw_tip_mm)
        if slip and self.config.slip_resets_filter and hasattr(self.tracker, "reset_filter"):
            self.tracker.reset_filter()  # the filter's state is the tip before the slip
        tip = state.filtered_tip_mm if state.filtered_tip_mm is not None else state.raw_tip_mm
        # bent the other way: the object is on the whisker's far side, no tip to trust
        far_side = bool(z_uT * self.target_z_uT < 0 and state.contact)
        if far_side:
            tip = None
        self._log = []
        velocity, turn, contact, label = self._handle(z_uT, tip, far_side, fell_gradually, pose)
        robot.command(velocity, turn)
        return Step(contact, label.value, slip, velocity, turn, tuple(self._log))

    def _to(self, rule: str, target: Phase | None = None) -> None:
        """Change phase by ``rule`` (``follow.phases.RULES``), logged; ``target`` for the rule
        whose target is the phase a turn interrupted."""
        spec = RULES[rule]
        if self.phase not in spec.sources:
            raise RuntimeError(f"rule {rule!r} fired in phase {self.phase.value}")
        source, self.phase = self.phase, spec.target or target
        if self.phase in TURNING:
            self._resume = source
        self._log.append(Transition(source, self.phase, rule))

    # -- the phases' handlers: each returns (velocity mm/s, turn rad/s, contact, the phase that
    # handled the sample) -----------------------------------------------------------------------
    def _handle(self, z_uT, tip, far_side, fell_gradually, pose):
        """The current phase's handler, after the rules checked at a sample's start."""
        if self.phase is Phase.STOPPED:
            return self._stopped()
        if self.phase in (Phase.BACK_OFF, Phase.SEARCH) and self._near_the_surface_left(pose):
            # the next surface's direction was only guessed: rather than drive the base into
            # the surface the whisker felt up to the corner, stop
            self._to("near the surface left")
            return self._stopped()
        if self.phase is Phase.BACK_OFF and self._backing == 0:  # backed off
            if tip is None:
                self._to("backed off" if self.keys else "backed off, no key point")
            else:
                self._to("touched")
        if self.phase is Phase.BACK_OFF:  # for its whole time, even if the wire still touches:
            return self._back_off(pose)  # it is leaving the object
        if self.phase in TOUCHING:
            if tip is None:
                return self._without_tip(z_uT, far_side, pose)
            return self._touching(z_uT, tip, fell_gradually, pose)
        if tip is not None:
            self._to("touched")
            return self._touching(z_uT, tip, fell_gradually, pose)
        if self.phase is Phase.SEARCH:
            return self._searching(far_side, pose)
        self._integral = 0.0
        return self._approach_velocity(pose), 0.0, _NO_CONTACT, Phase.APPROACH

    def _stopped(self):
        """Stand still from now on: a person must look at why."""
        return np.zeros(2), 0.0, _NO_CONTACT, Phase.STOPPED

    def _without_tip(self, z_uT: float, far_side: bool, pose: np.ndarray):
        """Touching, no tip this sample. A sample or two without one (the collision detector's
        hysteresis near its threshold, the first touch) is not a lost contact: hold still for a
        moment, or, before the target is first reached, press on (standing still, a tip stuck
        by friction at its first touch can hold z just under the threshold until the grace runs
        out, and the sensor backs off, over and over). After that the contact is lost; lost
        with the wire bent the other way, the surface goes on ahead of the tip (a concave
        corner): its direction turns away from the object about the last key point."""
        if self._missing < self._grace:
            self._missing += 1
            velocity, turn = (np.zeros(2), 0.0) if self._pressed() else self._press_on(z_uT, pose)
            return velocity, turn, _NO_CONTACT, self.phase
        if far_side and self.keys and self.tangent is not None:
            self._turn_direction(self.keys[-1], toward_object=False)
            self._restart_keys(self.keys[-1] + self.config.search_standoff_mm * self.tangent)
            self._start_back_off("far side")
        else:
            self._start_back_off("contact lost")
        return self._back_off(pose)

    def _pressed(self) -> bool:
        """Has the target been reached since this contact was made?"""
        return Phase.FOLLOW in (self.phase, self._resume if self.phase in TURNING else None)

    def _start_back_off(self, rule: str) -> None:
        self._to(rule)
        self._backing = int(self.config.backoff_s * self.config.rate_hz)
        self._lined_up, self._retreat = False, None
        self._progress.clear()

    def _back_off(self, pose: np.ndarray):
        """Straight back along the whisker: the wire leaves the object."""
        self._integral = 0.0
        self._backing -= 1
        away = -_unit(pose[2]) if self._retreat is None else self._retreat
        velocity = self.config.approach_speed_mm_s * away
        return velocity, 0.0, _NO_CONTACT, Phase.BACK_OFF

    def _searching(self, far_side: bool, pose: np.ndarray):
        """Searching, no tip: come in again (``_search``); the object met on the whisker's far
        side is a surface ahead (its direction turns away from the object about the last key
        point, and the search comes in a standoff past that corner, so that the whisker's line
        clears the surface it leaves), or, after an edge rule, a line come in over the edge's
        rounding, not onto the face (it comes in further along)."""
        self._integral = 0.0
        if not far_side:
            velocity, turn = self._search(pose)
            if self.phase is Phase.STOPPED:
                return self._stopped()
            return velocity, turn, _NO_CONTACT, Phase.SEARCH
        if self._last_turn is Phase.ROUND_EDGE:
            self._last_turn = None
        else:
            self._turn_direction(self.keys[-1], toward_object=False)
        self._restart_keys(self.keys[-1] + self.config.search_standoff_mm * self.tangent)
        self._start_back_off("far side")
        return self._back_off(pose)

    def _touching(self, z_uT: float, tip: np.ndarray, fell_gradually: bool, pose: np.ndarray):
        """A tip while touching. After a corner rule, until the heading is within
        slow_heading_deg of the new direction, the tip stays on the corner (the last key point)
        and the sensor turns about it; the estimates of a tip held there wander (its axial push
        read as a bend), so they add no key point and fire no rule."""
        self._missing, self._search_turned = 0, 0
        self._passing = None  # a surface touched: the corner passed, if one was
        contact = _rotation(pose[2]) @ tip + pose[:2]
        if self.phase in TURNING:
            lag = abs(_wrap(self._target_heading() - pose[2]))
            if lag >= math.radians(self.config.slow_heading_deg):
                if self._reached(z_uT):
                    self._resume = Phase.FOLLOW
                velocity, turn = self._turn_about(self.keys[-1], z_uT, pose)
                return velocity, turn, _NO_CONTACT, self.phase
            self._to("heading round", self._resume)
        return self._press_or_follow(z_uT, contact, fell_gradually, pose)

    def _reached(self, z_uT: float) -> bool:
        return abs(z_uT) >= self.config.press_share * abs(self.target_z_uT)

    def _press_or_follow(self, z_uT: float, contact: np.ndarray, fell_gradually: bool,
                         pose: np.ndarray):
        """First reach the target deflection, then move along; while pressing, the tip slides
        along the (frictionless) surface, round a bend too, and the heading follows it."""
        label = self.phase
        following = label is Phase.FOLLOW
        if fell_gradually and following:
            # |z| halved within the slip window, step by small step, the wire still touching:
            # not a slip (one snap) but a tip held in a concave corner, pushed along the wire as
            # the sensor moves on. Turning about the corner kept pushing it until z read no
            # contact, the tip still caught, and backing off along the whisker drove the wire
            # into both walls: back out of the corner instead, away from both
            self._pass_corner("held in a corner", np.array([self.tangent[1], -self.tangent[0]]), pose)
            return self._back_off(pose)
        if label is Phase.PRESS and self._reached(z_uT):
            self._to("target reached")
        self._key_point(contact, pose)
        velocity, turn = self._action(z_uT, pose, moving=following)
        if self.phase not in TURNING:  # (a key point's rule, an edge or a step back, may have turned it)
            self._corner_rules(contact, pose, z_uT, float(velocity @ self.tangent), following)
        if self.phase in TURNING:
            return self._at_corner(z_uT, pose, contact, label)
        # turn about the contact, not the sensor's base: the base moves so that the tip stays put
        arm = pose[:2] - contact
        return velocity + turn * np.array([-arm[1], arm[0]]), turn, contact, label

    def _corner_rules(self, contact: np.ndarray, pose: np.ndarray, z_uT: float,
                      tangential_mm_s: float, following: bool) -> None:
        """The edge and concave-corner rules that watch the deflection and the held tip
        (docs/contour.md, the controller's rule 7); each turns the surface's direction."""
        config = self.config
        kept = self._reached(z_uT)
        # counted only while the heading keeps up: turning about the contact adds no key point
        lag = abs(_wrap(self._target_heading() - pose[2]))
        self._dwell = self._dwell + 1 if following and lag < math.radians(config.stop_heading_deg) else 0
        held, rising = self._held_ahead(contact, tangential_mm_s, z_uT) if following else (False, False)
        if following and self._pushed_out(contact):
            # the estimate left the surface's line on the free side: a tip held in a concave
            # corner, its axial push read as a bend toward the base. No convex surface puts the
            # contact there (it bends toward the object), so this is not an edge, though the tip
            # is held as on one (read as an edge, the turn toward the object drove the base into
            # the next wall)
            self._turn_at_corner(self.keys[-1], "pushed out")
        elif following and held:
            # held with the deflection kept, not rising: on an edge (the surface bends toward
            # the object); held as the deflection falls, or rises (the base comes nearer a tip
            # that cannot go on): against a surface ahead (a concave corner)
            self._turn_at_corner(contact, "edge held" if kept and not rising else "held ahead")
        elif (following and lag < math.radians(config.slow_heading_deg)
              and abs(z_uT) > config.rise_share * abs(self.target_z_uT)
              and self._lags(contact, config.rise_progress_share)):
            # the deflection rises well past the target while moving along with the heading
            # caught up, and the tip lags the motion: the base nears a tip that cannot go on, a
            # surface ahead (a concave corner), before the held tip's estimates wander (its axial
            # push read as a bend). A tip that keeps going on is pressed harder by a direction
            # not yet the surface's (after a search, say), not held by a surface ahead
            self._turn_at_corner(contact, "rise ahead")
        elif kept and self._dwell > config.dwell_s * config.rate_hz:
            # no new key point for that long while following at the target: the contact stays
            # on an edge while the sensor turns about it; the surface bends toward the object
            self._turn_at_corner(contact, "edge dwell")

    def _at_corner(self, z_uT: float, pose: np.ndarray, contact: np.ndarray, label: Phase):
        """A corner rule has just turned the direction: turn about the corner, unless that
        would bring the base to the surface it leaves (a concave corner narrower than the bent
        whisker's reach): then stop for good rather than crash."""
        if self._swings_into_left(pose, contact):
            self._pass_corner("corner too narrow", self._left_outward, pose)
            return self._back_off(pose)
        velocity, turn = self._turn_about(self.keys[-1], z_uT, pose)
        return velocity, turn, contact, label

    def _pass_corner(self, rule: str, outward: np.ndarray, pose: np.ndarray) -> None:
        """A tip held in a concave corner (the last key point) that the sensor cannot turn
        about: back off out of it, away from both surfaces (out of the one left, whose outward
        normal is ``outward``, and back along it: backing off along the whisker, the tip held in
        the corner, drove it into the next surface), then come in on the next surface where the
        base, trailing the tip along it as far as it trails it now, stays
        ``corner_clearance_mm`` clear of the one left. The next surface's direction is not
        known yet; a square corner's is guessed (``outward``), and the key points then find the
        true one."""
        corner = np.asarray(self.keys[-1], float).copy()
        self._passing = (corner, outward.copy())
        followed = np.array([-outward[1], outward[0]])  # the direction of the surface left
        trailing = max(float((corner - pose[:2]) @ followed), 0.0)  # mm: the base behind the tip
        self.tangent = outward.copy()
        self._restart_keys(corner + (trailing + self.config.corner_clearance_mm) * outward)
        self._start_back_off(rule)
        self._retreat = _unit(_angle(outward) - math.pi / 4)

    def _turn_about(self, pivot: np.ndarray, z_uT: float, pose: np.ndarray) -> tuple[np.ndarray, float]:
        """Turn about ``pivot`` (world, mm: the corner) toward the heading the surface asks
        for, pressing to the target, with no motion along."""
        velocity, turn = self._action(z_uT, pose, moving=False)
        arm = pose[:2] - pivot
        return velocity + turn * np.array([-arm[1], arm[0]]), turn

    # -- pieces ---------------------------------------------------------------------------------
    def _search(self, pose: np.ndarray) -> tuple[np.ndarray, float]:
        """Come back to the surface where it was last felt, as the first approach did: first
        bring the free tip to ``search_standoff_mm`` short of the last key point along the line
        the whisker should lie on there (turning about the tip), then move along that line.
        Returning straight toward the key point can leave the tip past a corner, or the object
        on the whisker's far side. When the free tip passes the key point by ``search_standoff_mm``
        without a contact, the surface is not where it was felt (or the whisker went past it):
        the sensor stops there for good (phase ``stopped``) rather than push on into the unknown."""
        config = self.config
        heading = self._target_heading()
        along = _unit(heading)
        free_tip = pose[:2] + self.reach_mm * _unit(pose[2])
        start = self.keys[-1] - config.search_standoff_mm * along
        error_heading = _wrap(heading - pose[2])
        if not self._lined_up:
            self._lined_up = (np.linalg.norm(start - free_tip) < 0.5
                              and abs(error_heading) < math.radians(2.0))
        if self._lined_up:
            if (free_tip - self.keys[-1]) @ along > config.search_standoff_mm:
                if self._search_turned >= config.search_turns:
                    self._to("not found")  # the surface is not where it was felt: do not push on
                    return np.zeros(2), 0.0
                # past an edge the surface bends toward the object: look for it there, about
                # the last key point, rather than straight on
                self._search_turned += 1
                self.tangent = _unit(_angle(self.tangent) + math.radians(config.search_turn_deg))
                self._lined_up = False
                return np.zeros(2), 0.0
            return config.approach_speed_mm_s * along, 0.0
        offset = start - free_tip
        distance = float(np.linalg.norm(offset))
        tip_velocity = offset * min(config.approach_speed_mm_s / max(distance, 1e-9), config.rate_hz)
        # turn in step with the free tip closing in (the heading error falls as the square of the
        # distance left, so the line is exact when the tip arrives): the whisker turns about the
        # tip, and turned early (past a concave corner) the base swung into the surface left
        rate = min(3.0 * config.heading_gain_per_s, 2.0 * config.approach_speed_mm_s / max(distance, 1e-9))
        turn = float(np.clip(rate * error_heading, -config.search_turn_rad_s, config.search_turn_rad_s))
        arm = pose[:2] - free_tip  # turn about the free tip
        return tip_velocity + turn * np.array([-arm[1], arm[0]]), turn

    def _held_ahead(self, contact: np.ndarray, tangential_mm_s: float,
                    z_uT: float) -> tuple[bool, bool]:
        """Is the tip held while the sensor moves along (a surface ahead of it: a concave
        corner)? True when the contact has gone less than ``stall_share`` of the last
        ``stall_travel_mm`` of tangential motion commanded along the surface. And has |z|
        risen over that travel (the base nearing a held tip)?"""
        config = self.config
        self._travel += max(tangential_mm_s, 0.0) / config.rate_hz
        self._progress.append((self._travel, contact, abs(z_uT)))
        while len(self._progress) > 1 and self._travel - self._progress[1][0] >= config.stall_travel_mm:
            self._progress.popleft()
        return self._lags(contact, config.stall_share), abs(z_uT) > self._progress[0][2]

    def _pushed_out(self, contact: np.ndarray) -> bool:
        """Is the contact more than ``corner_out_mm`` outside the surface's line through the last
        key point (on the whisker's side, away from the object)?"""
        if len(self.keys) < 2:  # (the first direction is only the approach's)
            return False
        outward = np.array([self.tangent[1], -self.tangent[0]])
        return float((contact - self.keys[-1]) @ outward) > self.config.corner_out_mm

    def _lags(self, contact: np.ndarray, share: float) -> bool:
        """Has the contact gone less than ``share`` of the tangential travel commanded over the
        last ``stall_travel_mm`` (the window ``_held_ahead`` keeps; False until it is full)?"""
        travel, before, _ = self._progress[0]
        if self._travel - travel < self.config.stall_travel_mm:
            return False
        return float((contact - before) @ self.tangent) < share * (self._travel - travel)

    def _turn_at_corner(self, contact: np.ndarray, rule: str) -> None:
        """A corner rule fired at ``contact``: turn the surface's direction there (toward the
        object for a rule that rounds an edge) and move to the rule's turning phase, in which
        the sensor turns about the corner until its heading follows."""
        self._turn_direction(contact, toward_object=RULES[rule].target is Phase.ROUND_EDGE)
        self._to(rule)

    def _turn_direction(self, contact: np.ndarray, toward_object: bool) -> None:
        """The tip is held: the surface turns there, away from the object (a surface ahead, a
        concave corner) or toward it (an edge). Turn its direction by ``corner_turn_deg`` (or
        ``edge_hold_turn_deg``) and start the key points afresh from the corner."""
        turn = self.config.edge_hold_turn_deg if toward_object else -self.config.corner_turn_deg
        self._last_turn = Phase.ROUND_EDGE if toward_object else Phase.ENTER_CORNER
        if not toward_object and self._left_outward is None:  # the surface followed up to here
            self._left_outward = np.array([self.tangent[1], -self.tangent[0]])
        self.tangent = _unit(_angle(self.tangent) + math.radians(turn))
        self._restart_keys(contact)

    def _swings_into_left(self, pose: np.ndarray, contact: np.ndarray) -> bool:
        """After a concave corner's rule: would turning about the corner to the heading asked
        for, the whisker bent as now, bring the base within ``corner_clearance_mm`` of the
        surface left there (its line through the corner)?"""
        if self._last_turn is Phase.ROUND_EDGE or self._left_outward is None:
            return False
        corner = self.keys[-1]
        arm = float(np.linalg.norm(pose[:2] - contact))
        bend = _wrap(_angle(contact - pose[:2]) - pose[2])  # the chord to the tip from the heading
        base = corner - arm * _unit(self._target_heading() + bend)
        return float((base - corner) @ self._left_outward) < self.config.corner_clearance_mm

    def _near_the_surface_left(self, pose: np.ndarray) -> bool:
        """Past a concave corner, off the surface: is the base within ``corner_clearance_mm``
        of the surface left there (its line through the corner)?"""
        if self._passing is None:
            return False
        corner, outward = self._passing
        return float((pose[:2] - corner) @ outward) < self.config.corner_clearance_mm

    def _restart_keys(self, point: np.ndarray) -> None:
        """The key points start afresh from ``point`` (mm, world)."""
        self.keys.clear()
        self.keys.append(point)
        self._bend_mm = math.inf
        self._progress.clear()
        self._dwell = 0

    def _key_point(self, contact: np.ndarray, pose: np.ndarray) -> None:
        self._samples += 1
        if self.tangent is None:  # before any key point: along the surface seen at first contact
            self.tangent = _unit(pose[2] + math.radians(self.config.tilt_deg) - math.pi / 2)
        if self._samples % self.config.key_every:
            return
        if self.keys and np.linalg.norm(contact - self.keys[-1]) < self.config.key_spacing_mm:
            return
        self.keys.append(contact)
        self._dwell = 0
        if len(self.keys) >= 3:  # a surface followed again: no corner left behind
            self._left_outward = None
        if len(self.keys) >= 2 and float((self.keys[-1] - self.keys[-2]) @ self.tangent) < 0.0:
            # the contact went back against the surface's direction: no surface turns back on
            # itself; a tip held in a concave corner, its axial push read as a deflection, moves
            # the estimates toward the base. The corner is the last key point before the step.
            self._turn_at_corner(self.keys[-2], "step back")
            return
        self._bend_mm = self._bend_radius_mm()
        if self.phase is Phase.FOLLOW and len(self.keys) >= 3 and self._round_an_edge():
            return  # (not on the first key points: the first direction is only the approach's)
        if len(self.keys) >= 2:  # a chord until the spline has its key points
            self.tangent = self._turned_toward(self._surface_direction())

    def _round_an_edge(self) -> bool:
        """Past a short convex bend (an edge) the last step between key points turns toward the
        object by more than ``edge_turn_deg``, far more than the key points' scatter turns it
        (a few degrees) or a bend of the paper's radii does: the surface's direction becomes that
        step at once, and the key points start from it (the catch-up rule holds the sensor,
        turning about the contact, until its heading follows)."""
        step = self.keys[-1] - self.keys[-2]
        if _wrap(_angle(step) - _angle(self.tangent)) <= math.radians(self.config.edge_turn_deg):
            return False
        self.tangent = step / float(np.linalg.norm(step))
        self._last_turn = Phase.ROUND_EDGE
        self._to("edge step")
        last_two = list(self.keys)[-2:]
        self.keys.clear()
        self.keys.extend(last_two)
        self._bend_mm = math.inf
        return True

    def _surface_direction(self) -> np.ndarray:
        """The step the surface takes next: from the spline's end to its extrapolation (the
        chord from the first key point to the last until the spline has all its points)."""
        keys = np.array(self.keys)
        if len(keys) < self.keys.maxlen:
            return keys[-1] - keys[0]
        end, following = surface_step(keys, self.config.key_noise_mm)
        return following - end

    def _turned_toward(self, step: np.ndarray) -> np.ndarray:
        """The surface's direction turned toward ``step``, by at most ``key_turn_max_deg``: the
        surface turns smoothly between key points, and a prediction that turns back (noise in a
        few close key points) would send the sensor away from the object. Limiting the turn,
        rather than ignoring such a prediction, cannot leave the direction stuck behind a bend."""
        if float(np.linalg.norm(step)) < 1e-9:
            return self.tangent
        now = math.atan2(self.tangent[1], self.tangent[0])
        change = _wrap(math.atan2(step[1], step[0]) - now)
        limit = math.radians(self.config.key_turn_max_deg)
        return _unit(now + float(np.clip(change, -limit, limit)))

    def _target_heading(self) -> float:
        """The heading (rad) that leans the whisker ``tilt_deg`` back from the inward normal of
        the surface's direction (the object on the left)."""
        inward = np.array([-self.tangent[1], self.tangent[0]])
        return math.atan2(inward[1], inward[0]) - math.radians(self.config.tilt_deg)

    def _action(self, z_uT: float, pose: np.ndarray, moving: bool = True) -> tuple[np.ndarray, float]:
        """Velocity (world, mm/s) and turn (rad/s); only toward the object unless ``moving``."""
        config = self.config
        inward = np.array([-self.tangent[1], self.tangent[0]])  # the object lies on the left
        error_heading = _wrap(self._target_heading() - pose[2])
        normal = self._pid(z_uT)
        tangential = math.sqrt(max(config.total_speed_mm_s ** 2 - normal ** 2, 0.0))
        # around a bend of radius R the heading must turn at v/R: no faster than the turn allows,
        # and slower while the heading lags, so that it catches up before the tip leaves a corner
        tangential = min(tangential, config.turn_max_rad_s * self._bend_mm)
        tangential *= _catch_up_share(abs(error_heading), config) if moving else 0.0
        # standing still past an edge (the lag past the stop), the sensor may turn faster: the
        # tip stays put, and the whisker must come round before its shaft wraps the edge
        limit = (config.turn_max_rad_s if abs(error_heading) < math.radians(config.stop_heading_deg)
                 else config.edge_turn_max_rad_s)
        turn = float(np.clip(config.heading_gain_per_s * error_heading, -limit, limit))
        return tangential * self.tangent + normal * inward, turn

    def _press_on(self, z_uT: float, pose: np.ndarray) -> tuple[np.ndarray, float]:
        """Toward the object, as the press does (as the approach did before any key point)."""
        if self.tangent is not None:
            return self._action(z_uT, pose, moving=False)
        return self._approach_velocity(pose), 0.0

    def _approach_velocity(self, pose: np.ndarray) -> np.ndarray:
        """Along the whisker's lean toward the object, at the approach speed (mm/s, world)."""
        return self.config.approach_speed_mm_s * _unit(pose[2] + math.radians(self.config.tilt_deg))

    def _bend_radius_mm(self) -> float:
        """Radius (mm) of the circle through the oldest, middle and newest key points (inf when
        they are too few or in line)."""
        if len(self.keys) < 3:
            return math.inf
        a, b, c = self.keys[0], self.keys[len(self.keys) // 2], self.keys[-1]
        twice_area = abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
        if twice_area < 1e-9:
            return math.inf
        return float(np.linalg.norm(b - a) * np.linalg.norm(c - b) * np.linalg.norm(c - a) / (2 * twice_area))

    def _pid(self, z_uT: float) -> float:
        """Normal speed (mm/s, toward the object) from the deflection error."""
        config, dt = self.config, 1.0 / self.config.rate_hz
        error = z_uT - self.target_z_uT  # z is negative: too little deflection gives error > 0
        derivative = 0.0 if self._last_error is None else (error - self._last_error) / dt
        self._last_error = error
        limit = config.normal_speed_max_mm_s
        if config.ki_mm_s2_per_uT > 0:  # the integral alone never asks for more than the limit
            bound = limit / (self.gain_scale * config.ki_mm_s2_per_uT)
            self._integral = float(np.clip(self._integral + error * dt, -bound, bound))
        speed = self.gain_scale * (config.kp_mm_s_per_uT * error + config.ki_mm_s2_per_uT * self._integral
                                   + config.kd_mm_per_uT * derivative)
        return float(np.clip(speed, -limit, limit))

    def _slip(self, z_uT: float, raw_tip) -> tuple[bool, bool]:
        """A sudden drop of |z| or a jump of the raw tip (docs/contour.md); and whether the
        drop came gradually (``_gradual_fall``: a tip held in a concave corner)."""
        self._recent_z.append(abs(z_uT))
        dropped = (max(self._recent_z) > abs(self.target_z_uT) * 0.8
                   and abs(z_uT) < self.config.slip_drop * max(self._recent_z))
        jumped = (raw_tip is not None and self._last_raw is not None
                  and float(np.linalg.norm(raw_tip - self._last_raw)) > self.config.slip_jump_mm)
        self._last_raw = None if raw_tip is None else np.asarray(raw_tip, float)
        gradual = bool(dropped and self._gradual_fall())
        if dropped:
            self._recent_z.clear()
        return bool(dropped or jumped), gradual

    def _gradual_fall(self) -> bool:
        """Did the fall of |z| over the slip window come in many small steps (no sample's fall
        over ``gradual_step_share`` of the whole), not as a slip's one snap?"""
        recent = np.array(self._recent_z)
        steps = -np.diff(recent[int(np.argmax(recent)):])
        whole = float(recent.max() - recent[-1])
        return steps.size > 1 and float(steps.max()) < self.config.gradual_step_share * whole


def _angle(direction: np.ndarray) -> float:
    return math.atan2(direction[1], direction[0])


def _wrap(angle: float) -> float:
    """``angle`` (rad) in [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


def _catch_up_share(lag_rad: float, config: FollowConfig) -> float:
    """The share of the tangential speed kept while the heading lags by ``lag_rad``: all of it
    up to ``slow_heading_deg``, none from ``stop_heading_deg``, linear between."""
    slow, stop = math.radians(config.slow_heading_deg), math.radians(config.stop_heading_deg)
    return float(np.clip((stop - lag_rad) / (stop - slow), 0.0, 1.0))


def _rotation(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])
