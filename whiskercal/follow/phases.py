"""The follower's phases and the rules that move it from one to another.

The controller is in exactly one :class:`Phase` at a time. Every change of phase goes through
one named rule of :data:`RULES`, which says the phases it may fire in, the phase it moves to
and why; the controller logs each change as a :class:`Transition` (the run file keeps them).
docs/contour.md describes each rule's test.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum


class Phase(str, Enum):
    """What the controller is doing (its ``value`` is the name a run file records)."""

    APPROACH = "approach"          # no contact yet: along the whisker toward the object
    PRESS = "press"                # touching: pressing to the target, not yet moving along
    FOLLOW = "follow"              # at the target: moving along the surface
    ROUND_EDGE = "round-edge"      # an edge rule turned the direction: turning about the edge
    ENTER_CORNER = "enter-corner"  # a concave-corner rule turned it: turning about the corner
    BACK_OFF = "back-off"          # contact lost: straight back along the whisker
    SEARCH = "search"              # lining the whisker up with the last key point, coming in
    STOPPED = "stopped"            # for good: a person must look at why


TOUCHING = frozenset({Phase.PRESS, Phase.FOLLOW, Phase.ROUND_EDGE, Phase.ENTER_CORNER})
TURNING = frozenset({Phase.ROUND_EDGE, Phase.ENTER_CORNER})
MOVING_ALONG = frozenset({Phase.PRESS, Phase.FOLLOW})  # the phases a turn interrupts


@dataclass(frozen=True)
class Rule:
    """A change of phase: from any of ``sources`` to ``target`` (None: back to the phase the
    turn interrupted, press or follow), for the reason ``why``."""

    sources: frozenset
    target: Phase | None
    why: str


@dataclass(frozen=True)
class Transition:
    """One change of phase, logged: the rule's name and the two phases."""

    source: Phase
    target: Phase
    rule: str


_P = Phase
RULES: dict[str, Rule] = {
    "touched": Rule(frozenset({_P.APPROACH, _P.SEARCH, _P.BACK_OFF}), _P.PRESS,
                    "a tip: the wire touches the object; press to the target before moving along"),
    "target reached": Rule(frozenset({_P.PRESS}), _P.FOLLOW,
                           "|z| reached press_share of the target's: move along from the next sample"),
    "contact lost": Rule(TOUCHING, _P.BACK_OFF,
                         "no tip for lost_after_s: back off along the whisker so that it leaves the object"),
    "far side": Rule(TOUCHING | {_P.SEARCH}, _P.BACK_OFF,
                     "the wire bent the other way (the object on its far side): a surface ahead, "
                     "or a search come in over an edge's rounding; back off, come in further along"),
    "backed off": Rule(frozenset({_P.BACK_OFF}), _P.SEARCH,
                       "backed off for backoff_s: line up with the last key point and come in"),
    "backed off, no key point": Rule(frozenset({_P.BACK_OFF}), _P.APPROACH,
                                     "backed off before any key point was kept: approach as at first"),
    "edge step": Rule(MOVING_ALONG, _P.ROUND_EDGE,
                      "a step between key points turns toward the object by more than edge_turn_deg"),
    "edge held": Rule(frozenset({_P.FOLLOW}), _P.ROUND_EDGE,
                      "the tip held while moving along, |z| kept at the target and not rising"),
    "edge dwell": Rule(frozenset({_P.FOLLOW}), _P.ROUND_EDGE,
                       "following at the target for dwell_s without a new key point"),
    "held ahead": Rule(frozenset({_P.FOLLOW}), _P.ENTER_CORNER,
                       "the tip held while moving along, |z| fallen or rising: a surface ahead"),
    "rise ahead": Rule(frozenset({_P.FOLLOW}), _P.ENTER_CORNER,
                       "|z| past rise_share of the target's with the tip lagging the motion"),
    "pushed out": Rule(frozenset({_P.FOLLOW}), _P.ENTER_CORNER,
                       "the contact more than corner_out_mm outside the surface's line, on the "
                       "whisker's side: a tip held in a concave corner, its axial push read as a bend"),
    "step back": Rule(MOVING_ALONG, _P.ENTER_CORNER,
                      "a key point stepped back against the surface's direction: a tip held in a "
                      "concave corner, its axial push read as a bend"),
    "heading round": Rule(TURNING, None,
                          "the heading is within slow_heading_deg of the new direction"),
    "held in a corner": Rule(frozenset({_P.FOLLOW}), _P.BACK_OFF,
                             "|z| fell by half in many small steps with the wire touching: a tip "
                             "held in a concave corner, pushed along the wire; back off out of the "
                             "corner and come in on the next surface where the base clears the one left"),
    "corner too narrow": Rule(frozenset({_P.ENTER_CORNER}), _P.BACK_OFF,
                              "turning about the corner would bring the base within "
                              "corner_clearance_mm of the surface it leaves: back off out of the "
                              "corner and come in on the next surface where the base clears the one left"),
    "near the surface left": Rule(frozenset({_P.BACK_OFF, _P.SEARCH}), _P.STOPPED,
                                  "off the surface past a concave corner, the base came within "
                                  "corner_clearance_mm of the surface left there"),
    "not found": Rule(frozenset({_P.SEARCH}), _P.STOPPED,
                      "the search passed the last key point search_turns + 1 times without a contact"),
}
