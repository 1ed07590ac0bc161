"""A whisker sensor carried by a planar robot against an object: the contour scenes' rig.

The robot holds the sensor's base frame at a pose (x, y mm; heading rad: the direction of the
undeflected whisker) in the world frame; it takes a velocity command (world frame, mm/s) and a
heading rate (rad/s), each limited as a robot's would be, and integrates them over each control
period. Each period the object is seen from the sensor, the twin solves the whisker against it
(its shape contact: tip, shaft or tangential; frictionless, or with the plane's Coulomb
stick-slip at the tip, ``friction``, whose stuck point it carries from period to period in the
world frame), and the magnet and magnetometer turn the suspension's pose into z (µT from rest,
with the sensor's noise), and the chip's Z axis likewise (``axial_uT``: a real magnetometer
streams all three axes, and a calibration with a (Y, Z) table reads the tip from both). The truth (tip, contact, kind) is reported in the world
frame. Everything runs in-process, as fast as the solver goes. ``nuisances``
(``twin.nuisances``, off unless given) adds what a real rig does: the field's drift, the
suspension's creep, the surface's roughness under the tip (convex objects), and a late, noisy
reported pose with jittered periods. ``dynamics`` (``twin.nuisances.DynamicsTable``, off
unless it has modes) lets the reading follow the wire's bending modes on top of the statics
(``physics.dynamics``): a release or a slip rings, a slide lags.

An open wall (``outlines.WallOutline``) comes as overlapping convex pieces, one a square behind
each concave corner. Each period the whisker is solved against every piece within its reach +
NEAR_MARGIN_MM of the base, each from the side it met the wire (a piece newly in the wire's way
from the side it reaches least deep: the next wall of a concave corner, or an edge the whisker
has swung past, push from its -y side), a corner's square only as the tip held on the corner;
the contact is the most deflecting solution whose wire stays out of every other piece. When
none does, or the sensor's base is inside the wall, the sample's kind is "collision" (a contour
run stops there). Not modelled: two contacts at once other than a tip held in a concave corner
(docs/contour.md, "The wall").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.twin.nuisances import Nuisances, PoseChannel, SensorNuisances
from whiskercal.twin.outlines import Outline
from whiskercal.twin.physics.coulomb import Coulomb
from whiskercal.twin.physics.dynamics import RingingRoot
from whiskercal.twin.physics.obstacles import Circle, Polygon
from whiskercal.twin.physics.polygon import entry_side, solve_at_vertex
from whiskercal.twin.physics.shape_friction import Stick
from whiskercal.twin.physics.sensor import TwinPhysics


@dataclass(frozen=True)
class RobotLimits:
    """The carrying robot's limits: speed (mm/s) and turn rate (rad/s)."""

    speed_mm_s: float = 40.0
    turn_rad_s: float = 1.0


@dataclass(frozen=True)
class MobileSample:
    """One control period's measurement (Y axis ``z_uT`` and Z axis ``axial_uT``, each µT from
    its reading at rest, with noise) and the twin's truth (world frame, mm; ``slips``: the tip's
    slip events in the period, with stick-slip friction)."""

    z_uT: float
    kind: str
    tip_mm: np.ndarray
    contact_mm: np.ndarray
    axial_uT: float = float("nan")
    slips: int = 0


def rotation(angle_rad: float) -> np.ndarray:
    """The 2-D rotation matrix of ``angle_rad``."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, -s], [s, c]])


class MobileSensor:
    """The sensor on a planar robot, against one object (see the module's docstring).

    Parameters
    ----------
    sensor
        The sensor build (``twin.params.SensorParams``).
    outline
        The object, world frame.
    pose
        Start pose (x mm, y mm, heading rad) of the sensor's base frame.
    seed
        Seeds the magnetometer noise.
    friction
        Coulomb friction at the tip (``physics.shape_friction``: stick-slip, or with mu_s = mu_k
        sticking inside the cone and sliding on its edge), on the convex objects; None:
        frictionless.
    nuisances
        What a real rig adds (``twin.nuisances.Nuisances``); None or all off: the ideal twin.
    dynamics
        The wire's bending modes (``twin.nuisances.DynamicsTable``); None or no modes:
        quasi-static.
    """

    def __init__(self, sensor, outline: Outline, pose, seed: int = 0,
                 limits: RobotLimits = RobotLimits(), friction: Coulomb | None = None,
                 nuisances: Nuisances | None = None, dynamics=None) -> None:
        self.physics, self.sensor = TwinPhysics(sensor), sensor
        self.outline, self.limits = outline, limits
        self._obstacle = outline.obstacle()
        if friction is not None and isinstance(self._obstacle, tuple):
            raise UsageError("friction is not modelled on the wall")
        self.friction = friction
        self._stick_world = None  # (anchor in the world, mm; friction ratio) while the tip sticks
        self._corners = outline.corner_pieces() if isinstance(self._obstacle, tuple) else {}
        self._pieces_previous: dict[int, tuple] = {}  # the wall's warm starts and sides, by piece
        self._last_tip = None  # the wall's last tip in contact (world, mm)
        # the sensor was driven into the wall, or its wire could not be kept out of it (kind
        # "collision"): a contour run stops there
        self.collided = False
        self._pose = np.asarray(pose, float).copy()
        self._velocity, self._turn = np.zeros(2), 0.0
        self._noise_uT = float(sensor.magnetometer.noise_uT_rms[1])
        self._axial_noise_uT = float(sensor.magnetometer.noise_uT_rms[2])
        rest = self.physics.field_uT(self.physics.free())
        self._rest_y, self._rest_z = float(rest[1]), float(rest[2])
        self._rng = np.random.default_rng(seed)
        # the Z axis's noise from its own stream, so that the Y stream (and every run recorded
        # before the Z axis was) stays the same for a seed
        self._axial_rng = np.random.default_rng([seed, 2])
        self._previous = None
        # edges farther than this from the base cannot meet the whisker (mm; see _near_part)
        self._keep_mm = float(sensor.whisker.reach_mm) + NEAR_MARGIN_MM
        self._near = None  # (base position, first edge, count) of the last near run
        self._runs: dict[tuple[int, int], Polygon] = {}  # near runs met so far, world frame
        self._t_s = 0.0  # robot time (s), the periods' true lengths summed
        real = nuisances is not None and not nuisances.off
        self._nuisances = SensorNuisances(nuisances, seed) if real else None
        self._channel = PoseChannel(nuisances.robot, seed) if real else None
        self._touch = None  # (contact, surface normal) of the last sample in contact, world
        # the wire's modes; their response starts at rest in the first period's equilibrium
        self._modes = None if dynamics is None or dynamics.off else dynamics.modes_of(sensor.whisker)
        self._ringing = None
        if self._channel is not None:
            self._channel.record(0.0, self._pose)
            self._reported = self._channel.reported(0.0)

    # -- the Robot interface -----------------------------------------------------------------
    def pose(self) -> np.ndarray:
        """(x mm, y mm, heading rad) of the sensor's base frame in the world, as the robot
        reports it (late and noisy with the robot's nuisances; the truth is ``true_pose``)."""
        return (self._pose if self._channel is None else self._reported).copy()

    def true_pose(self) -> np.ndarray:
        """The base frame's true pose (x mm, y mm, heading rad)."""
        return self._pose.copy()

    def command(self, velocity_mm_s, turn_rad_s: float) -> None:
        """Move at ``velocity_mm_s`` (world frame) and turn at ``turn_rad_s`` until told otherwise."""
        velocity = np.asarray(velocity_mm_s, float)
        speed = float(np.hypot(*velocity))
        if speed > self.limits.speed_mm_s:
            velocity = velocity * (self.limits.speed_mm_s / speed)
        self._velocity = velocity
        self._turn = float(np.clip(turn_rad_s, -self.limits.turn_rad_s, self.limits.turn_rad_s))

    # -- the world ----------------------------------------------------------------------------
    def step(self, dt_s: float) -> MobileSample:
        """Move for ``dt_s`` s under the last command (jittered with the robot's nuisances),
        then measure."""
        if self._channel is not None:
            dt_s = self._channel.period_s(dt_s)
        self._pose[:2] += self._velocity * dt_s
        self._pose[2] += self._turn * dt_s
        self._t_s += dt_s
        if self._channel is not None:
            self._channel.record(self._t_s, self._pose)
            self._reported = self._channel.reported(self._t_s)
        if isinstance(self._obstacle, tuple):
            equilibrium = self._solve_pieces()
        else:
            obstacle, first = self._seen_from_sensor()
            count = len(getattr(self._obstacle, "vertices_mm", ()))
            previous = _reindexed(self._previous, -first, count)
            short = self._short_of_the_clamp(obstacle)
            if short is not None:
                # the contact model takes objects beyond the rigid clamp only: one short of it
                # is clear of the wire, or has the sensor's base inside it (a crash: what the
                # twin models ends there)
                self.collided, equilibrium = short, self.physics.free()
            elif self.friction is None:
                equilibrium = self.physics.solve_shape(self._roughened(obstacle), previous)
            else:
                equilibrium = self._solve_sticking(self._roughened(obstacle), previous)
            equilibrium = _reindexed(equilibrium, first, count)
            if equilibrium.slipped_past and not (self._previous is not None
                                                 and self._previous.in_contact):
                # a first touch the cold solve could not bring in (its lateral path from first
                # touch fails at a fraction of a mm of overlap for some angles) is no slip past
                # a wire that never touched: the next period tries it again
                equilibrium = replace(equilibrium, slipped_past=False)
        self._previous = equilibrium
        kind = "collision" if self.collided else equilibrium.kind
        field = self._field_uT(equilibrium, dt_s)
        z = float(field[1]) - self._rest_y + float(self._rng.normal(0.0, self._noise_uT))
        axial = float(field[2]) - self._rest_z + float(self._axial_rng.normal(0.0, self._axial_noise_uT))
        tip = self.to_world(equilibrium.tip_mm)
        return MobileSample(z, kind, tip, self.to_world(equilibrium.contact_mm), axial,
                            equilibrium.slips)

    def _field_uT(self, equilibrium, dt_s: float) -> np.ndarray:
        """The field at the chip (3,) µT: the magnet's at the suspension's pose (ringing with
        the dynamics' modes), with the nuisances' creep of the root rotation and drift of the
        reading."""
        if self._nuisances is None and self._modes is None:
            return self.physics.field_uT(equilibrium)
        from whiskercal.twin.physics.magnet import field_uT

        rotation, shift = equilibrium.root_rotation_rad, equilibrium.root_shift_mm
        if self._modes is not None:
            if self._ringing is None:
                self._ringing = RingingRoot(self._modes, rotation, shift, self._t_s)
            rotation, shift = self._ringing.at(self._t_s, rotation, shift)
        if self._nuisances is None:
            return np.asarray(field_uT(self.sensor.magnet, rotation, shift), float)
        rotation += self._nuisances.creep(rotation, dt_s)
        field = np.asarray(field_uT(self.sensor.magnet, rotation, shift), float)
        moving = bool(np.any(self._velocity) or self._turn)
        return self._nuisances.field_uT(field, self._t_s, moving)

    def _roughened(self, obstacle):
        """The object (sensor frame) moved along the surface's normal at the last contact by the
        height of the surface there (``twin.nuisances``: roughness); as it is without."""
        if self._nuisances is None or self._nuisances.table.contact.roughness_rms_mm == 0.0:
            return obstacle
        previous = self._previous
        if previous is None or not previous.in_contact:
            self._touch = None
            return obstacle
        turn = rotation(self._pose[2])
        force = np.asarray(previous.force_n, float)
        if self._touch is None or np.any(force):
            normal = turn @ force / max(float(np.hypot(*force)), 1e-12)
            self._touch = (self.to_world(previous.contact_mm), normal)
        contact, normal = self._touch
        shift = turn.T @ normal * self._nuisances.height_mm(contact)
        if isinstance(obstacle, Circle):
            return replace(obstacle, center_mm=np.asarray(obstacle.center_mm) + shift)
        return obstacle.seen_from(np.eye(2), -shift)

    def _short_of_the_clamp(self, obstacle) -> bool | None:
        """For a circle (sensor frame) whose centre lies short of the clamp across the wire's
        line: does it reach the wire beyond the clamp (the base is then inside it)? None for
        any other object."""
        if not isinstance(obstacle, Circle):
            return None
        (x, y), radius = obstacle.center_mm, obstacle.radius_mm
        clamp = self.sensor.whisker.root_offset_mm
        if x > clamp or abs(y) >= radius:
            return None
        return bool(x + math.sqrt(radius ** 2 - y ** 2) > clamp)

    def _solve_sticking(self, obstacle, previous):
        """The stick-slip solve, its stuck point carried in the world frame (the object stands
        still in it; the sensor's frame moves each period)."""
        turn, origin = rotation(-self._pose[2]), self._pose[:2]
        stick = None
        if self._stick_world is not None:
            anchor, ratio = self._stick_world
            stick = Stick(turn @ (anchor - origin), ratio)
        equilibrium, stick = self.physics.solve_shape_sticking(obstacle, self.friction, previous,
                                                               stick)
        self._stick_world = None if stick is None else (self.to_world(stick.anchor_mm), stick.ratio)
        return equilibrium

    def _solve_pieces(self):
        """The equilibrium against the wall's pieces (see the module's docstring); each piece
        warm-starts from its own last solve, from the side it met the wire."""
        turn, origin = rotation(-self._pose[2]), self._pose[:2]
        seen, solved = {}, {}
        for index, piece in enumerate(self._obstacle):
            if piece.edge_distances_mm(origin).min() <= self._keep_mm:
                seen[index] = (piece.vertices_mm - origin) @ turn.T
        whisker = self.sensor.whisker
        for index, vertices in seen.items():
            previous, side = self._pieces_previous.get(index, (None, 1))
            if index in self._corners:
                solved[index] = (self._held(vertices, self._corners[index], previous), 1)
                continue
            if previous is None or not previous.in_contact:
                # a piece newly in the wire's way (or one the wire has slipped past) meets it
                # from the side it reaches least deep: the wall ahead of the tip in a concave
                # corner, or an edge the whisker has swung past, pushes from the -y side
                previous, side = None, entry_side(whisker, Polygon(vertices))
            solved[index] = (self.physics.solve_shape(Polygon(vertices, side=side), previous), side)
        pieces = {index: Polygon(vertices) for index, vertices in seen.items()}
        kept, clear = _kept(solved, pieces, self.physics.free())
        self._pieces_previous = solved
        # the sensor's base (its centre of rotation and clamp) driven into the solid, or no
        # single contact that keeps the wire out of it: what the twin models ends there
        stub = np.array([[0.0, 0.0], [whisker.root_offset_mm, 0.0]])
        self.collided = not clear or any(piece.reaches(stub) for piece in pieces.values())
        self._last_tip = None if not kept.in_contact else self.to_world(kept.tip_mm)
        return kept

    def _held(self, vertices: np.ndarray, corner: int, previous):
        """A concave corner's piece: the tip held on its corner vertex, tried while it was held
        or when the last tip came within HOLD_NEAR_MM of the corner (free otherwise: the
        corner's square has no other contact the solid can have)."""
        held_before = previous is not None and previous.in_contact
        if not held_before and (self._last_tip is None or np.linalg.norm(
                self.to_world(vertices[corner]) - self._last_tip) > HOLD_NEAR_MM):
            return self.physics.free()
        return solve_at_vertex(self.sensor.whisker, Polygon(vertices), corner,
                               previous if held_before else self._previous)

    def to_world(self, point_mm) -> np.ndarray:
        """A point of the sensor's base frame in the world frame."""
        return rotation(self._pose[2]) @ np.asarray(point_mm, float) + self._pose[:2]

    def _seen_from_sensor(self):
        """The object in the sensor's base frame, and the index in the whole outline of its first
        vertex. The contact model takes it as pushing from the whisker's +y side, where the
        follower keeps it; a whisker driven round to the object's other side is beyond what it
        models (the follower backs off when it reads z of the other sign)."""
        turn, origin = rotation(-self._pose[2]), self._pose[:2]
        if isinstance(self._obstacle, Circle):
            return replace(self._obstacle, center_mm=turn @ (self._obstacle.center_mm - origin)), 0
        first, part = self._near_part(origin)
        return part.seen_from(turn, origin), first

    def _near_part(self, origin: np.ndarray) -> tuple[int, Polygon]:
        """The run of the outline's edges that come within ``_keep_mm`` of the sensor's base, as
        a convex polygon (closed by a chord inside the object), and the index of its first vertex.

        The whisker never reaches farther than its reach from the base, and it can only get
        into the part cut off through edges farther than that, so the contact is the same; the
        solve, whose cost grows with the number of edges, is faster. The whole
        outline is kept without a warm start (the solver then brings the object in from where it
        first touches the straight whisker, up to the margin's 40 mm away), or when the near
        edges are not one run.
        """
        vertices = self._obstacle.vertices_mm
        warm = self._previous is not None and len(self._previous.solution) > 3
        if self._near is None or np.linalg.norm(origin - self._near[0]) > NEAR_REUSE_MM:
            self._near = (origin.copy(), *self._near_run(origin))
        _, first, count = self._near
        if not warm or first is None or count < 2:  # a polygon needs three vertices
            return 0, self._obstacle
        if (self._previous.solution[-1] - first) % len(vertices) >= count:  # its contact is not
            return 0, self._obstacle                                          # among the near edges
        if (first, count) not in self._runs:
            self._runs[first, count] = Polygon(vertices[(first + np.arange(count + 1)) % len(vertices)])
        return first, self._runs[first, count]

    def _near_run(self, origin: np.ndarray) -> tuple[int | None, int]:
        """First index and number of the edges within ``_keep_mm`` + NEAR_REUSE_MM of
        ``origin`` (so that the run still holds while the base stays within NEAR_REUSE_MM of
        it); (None, 0) when they are not one run."""
        near = self._obstacle.edge_distances_mm(origin) <= self._keep_mm + NEAR_REUSE_MM
        starts = np.flatnonzero(near & ~np.roll(near, 1))
        return (int(starts[0]), int(near.sum())) if len(starts) == 1 else (None, 0)


NEAR_MARGIN_MM = 40.0
NEAR_REUSE_MM = 2.0


def _kept(solved: dict, pieces: dict, free):
    """Of each piece's solution, the one that deflects the whisker most among those whose wire
    stays out of every other piece: one piece's contact is then the solid's. In a concave corner
    the walls' own solutions cut into each other and the corner's square (the tip held on its
    vertex, pushed by both walls) is kept. When every solution cuts into another piece, the one
    that deflects most is kept, and flagged (False: no contact keeps the wire out of the solid)."""
    touching = sorted((index for index, (equilibrium, _) in solved.items() if equilibrium.in_contact),
                      key=lambda index: -abs(solved[index][0].root_rotation_rad))
    for index in touching:  # most deflected first: the first whose wire is clear is the contact
        wire = solved[index][0].shape_mm(WIRE_NODES)[1:]
        low, high = wire.min(axis=0), wire.max(axis=0)
        if not any(piece.crosses_polyline(wire, OVERLAP_TOL_MM) for other, piece in pieces.items()
                   if other != index and np.all(piece.vertices_mm.min(axis=0) <= high)
                   and np.all(piece.vertices_mm.max(axis=0) >= low)):
            return solved[index][0], True
    return (solved[touching[0]][0], False) if touching else (free, True)


WIRE_NODES = 24  # points along the wire checked against the other pieces
OVERLAP_TOL_MM = 1e-3  # a wire lying on another piece's surface (a corner's square) is out of it
HOLD_NEAR_MM = 1.0  # a tip this near a concave corner may be held in it


def _reindexed(equilibrium, shift: int, count: int):
    """``equilibrium`` with the polygon corner/edge index of its warm start moved by ``shift``
    (modulo the outline's ``count`` vertices: between the whole outline's numbering and a near
    part's); a circle's has none."""
    if equilibrium is None or len(equilibrium.solution) <= 3 or shift == 0:
        return equilibrium
    *head, index = equilibrium.solution
    return replace(equilibrium, solution=(*head, (index + shift) % count))
