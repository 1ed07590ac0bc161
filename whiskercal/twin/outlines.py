"""The contour scenes' objects, seen from above, in the world frame (mm): extruded convex shapes
and an open wall.

Each is a convex core (a point or a convex polygon) grown by a corner radius, as the paper's
objects are: a cylinder (Ø 160 mm), a square prism with rounded corners (160 mm wide, 40 mm
radius) and an octagonal prism (70 mm sides, 30 mm corner radius). The whisker meets them through
the twin's frictionless shape contact (``physics.obstacles.Circle`` / ``Polygon``).

The wall (:class:`WallOutline`) is open and not convex: a straight wall 300 mm long with a 20 mm
step out half-way (its top edge rounded, 3 mm), ending in a 90° concave corner where a second
wall, 150 mm long, turns toward the robot. The twin meets it as overlapping convex pieces
(``obstacle()``). Two more open scenes take a parameter (:func:`open_scene`): ``corner:deg=N``,
a straight wall 300 mm long into a concave corner whose free side opens N degrees (60 to 120),
and out along a second wall 150 mm long; ``step:mm=H``, a straight wall with a step of H mm
(4 to 40) down toward the object half-way along its first 300 mm (the step's top edge rounded,
3 mm), going on 150 mm past the step's foot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from whiskercal.errors import UsageError
from whiskercal.twin.physics.obstacles import Circle, Polygon

SHAPES = ("cylinder", "rounded-rect", "octagon")  # the closed convex objects
WALL = "wall"
SCENES = SHAPES + (WALL,)
_ARC_STEP_RAD = math.radians(3.0)  # corner arcs as polygon edges 3° apart (0.014 mm sag at 40 mm)


@dataclass(frozen=True)
class Outline:
    """A convex core (vertices, counter-clockwise; one vertex for a disc) grown by ``radius_mm``."""

    name: str
    core_mm: np.ndarray
    radius_mm: float
    closed = True  # the outline goes round the object

    def obstacle(self):
        """The object as the twin's contact solver takes it (world frame, mm)."""
        if len(self.core_mm) == 1:
            return Circle(self.core_mm[0], self.radius_mm)
        return Polygon(self.points(_ARC_STEP_RAD))

    def points(self, step_rad: float = math.radians(0.5)) -> np.ndarray:
        """The outline as counter-clockwise points (n, 2), corner arcs every ``step_rad``."""
        if len(self.core_mm) == 1:
            angles = np.arange(0.0, 2 * math.pi, step_rad)
            return self.core_mm[0] + self.radius_mm * np.column_stack([np.cos(angles), np.sin(angles)])
        parts = []
        core = self.core_mm
        for i, vertex in enumerate(core):
            before, after = core[i - 1], core[(i + 1) % len(core)]
            start = _outward_angle(before, vertex)
            end = _outward_angle(vertex, after)
            end += 2 * math.pi if end < start else 0.0
            angles = np.linspace(start, end, max(2, int(math.ceil((end - start) / step_rad)) + 1))
            parts.append(vertex + self.radius_mm * np.column_stack([np.cos(angles), np.sin(angles)]))
        return np.vstack(parts)

    def dense(self, spacing_mm: float = 0.05) -> np.ndarray:
        """Points along the whole outline no more than ``spacing_mm`` apart (for distances)."""
        ring = self.points()
        ring = np.vstack([ring, ring[:1]])
        pieces = []
        for a, b in zip(ring[:-1], ring[1:]):
            count = max(1, int(math.ceil(np.linalg.norm(b - a) / spacing_mm)))
            pieces.append(a + (b - a) * (np.arange(count)[:, None] / count))
        return np.vstack(pieces)

    @property
    def perimeter_mm(self) -> float:
        """Length of the outline, mm."""
        ring = self.points()
        return float(np.sum(np.linalg.norm(np.roll(ring, -1, axis=0) - ring, axis=1)))


def _outward_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Direction of the outward normal of the counter-clockwise edge a -> b, rad."""
    edge = b - a
    return math.atan2(-edge[0], edge[1])


def regular_core(sides: int, apothem_mm: float) -> np.ndarray:
    """A regular polygon's vertices (sides, 2), counter-clockwise about the origin, one edge at
    the bottom (its outward normal along -y), ``apothem_mm`` from the centre to each edge."""
    angles = (np.arange(sides) + 0.5) * 2 * math.pi / sides - math.pi / 2
    return apothem_mm / math.cos(math.pi / sides) * np.column_stack([np.cos(angles), np.sin(angles)])


def outline(name: str, center_mm=(0.0, 0.0), rotation_rad: float = 0.0):
    """One of :data:`SCENES`, or an open scene with its parameter (:func:`open_scene`), centred
    at ``center_mm`` and turned by ``rotation_rad`` (an open scene stands where it is built, its
    concave corner at the origin)."""
    if name == WALL:
        return WallOutline(WALL, WALL_CORNERS_MM.copy(), WALL_EDGE_RADIUS_MM)
    if name.split(":")[0] in OPEN_KINDS:
        return open_scene(name)
    if name == "cylinder":
        core, radius = np.zeros((1, 2)), 80.0
    elif name == "rounded-rect":  # 160 mm wide, corners of 40 mm radius
        core, radius = regular_core(4, 80.0 - 40.0), 40.0
    elif name == "octagon":  # 70 mm sides, corners of 30 mm radius
        apothem = 70.0 / (2 * math.tan(math.pi / 8))
        core, radius = regular_core(8, apothem - 30.0), 30.0
    else:
        raise UsageError(f"unknown shape {name!r}; use one of {', '.join(SCENES)}, "
                         "corner:deg=N or step:mm=H")
    turn = np.array([[math.cos(rotation_rad), -math.sin(rotation_rad)],
                     [math.sin(rotation_rad), math.cos(rotation_rad)]])
    return Outline(name, core @ turn.T + np.asarray(center_mm, float), radius)


def recorded(name: str, core_mm, radius_mm: float):
    """An outline as a contour run records it (its name, core and radius)."""
    kind = {WALL: WallOutline, "corner": CornerOutline, "step": StepOutline}.get(name.split(":")[0], Outline)
    return kind(name, np.asarray(core_mm, float), float(radius_mm))


OPEN_KINDS = {"corner": ("deg", 60.0, 120.0), "step": ("mm", 4.0, 40.0)}  # parameter, its range


def open_scene(name: str):
    """``corner:deg=N`` or ``step:mm=H`` (the module's docstring); UsageError names what is
    wrong with any other."""
    kind, _, parameter = name.partition(":")
    key, low, high = OPEN_KINDS[kind]
    given, _, text = parameter.partition("=")
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if given != key or not low <= value <= high:
        raise UsageError(f"shape {name!r}: write {kind}:{key}=V with V from {low:g} to {high:g}")
    if kind == "corner":
        direction = np.array([math.cos(math.radians(value)), math.sin(math.radians(value))])
        return CornerOutline(name, np.array([[300.0, 0.0], [0.0, 0.0], list(150.0 * direction)]), 0.0)
    core = np.array([[300.0, value], [150.0, value], [150.0, 0.0], [-150.0, 0.0]])
    return StepOutline(name, core, WALL_EDGE_RADIUS_MM)


# The wall's surface, the solid on the left walking along it: the step's top (y = 20 mm), the step
# down at x = 150 mm, the wall (y = 0) to the concave corner at the origin, the second wall (x = 0).
WALL_CORNERS_MM = np.array([[300.0, 20.0], [150.0, 20.0], [150.0, 0.0], [0.0, 0.0], [0.0, 150.0]])
WALL_EDGE_RADIUS_MM = 3.0
_WALL_DEPTH_MM = 60.0    # how thick the pieces are behind the surface (deeper than any whisker)
_WALL_BEYOND_MM = 100.0  # the pieces go on past the outline's open ends: the wall does not stop


@dataclass(frozen=True)
class WallOutline:
    """An open outline through ``core_mm`` (its corners, the solid on the left), its convex
    corners rounded by ``radius_mm``, its concave ones sharp."""

    name: str
    core_mm: np.ndarray
    radius_mm: float
    closed = False

    def obstacle(self) -> tuple[Polygon, ...]:
        """The wall as overlapping convex pieces whose union is the solid: the step, the wall
        before it, the second wall, and one square behind each concave corner (the step's foot,
        the corner at the origin). A corner's square has the corner as its vertex, with the two
        walls' normals on either side: a tip held in the corner, pushed by both walls at once,
        is its tip-on-vertex contact. The twin solves the whisker against one piece at a time
        and keeps a solution whose wire stays out of every other piece (``twin.mobile``)."""
        (x_end, y_step), (x_step, _), _, _, (_, y_end) = self.core_mm
        depth, beyond, radius = _WALL_DEPTH_MM, _WALL_BEYOND_MM, self.radius_mm
        angles = np.linspace(math.pi / 2, math.pi, 31)
        edge = np.array([x_step + radius, y_step - radius]) + radius * np.column_stack(
            [np.cos(angles), np.sin(angles)])
        step = np.vstack([[[x_step, -depth], [x_end + beyond, -depth], [x_end + beyond, y_step]], edge])
        # the wall before the step goes on under the corner at the origin, as a corner scene's
        # first wall does: ended there, its vertex stood at the corner, and a tip backed out of
        # the corner along it found no solution that kept the wire out of the solid
        low = np.array([[-depth, -depth], [x_step, -depth], [x_step, 0.0], [-depth, 0.0]])
        side = np.array([[-depth, -depth], [0.0, -depth], [0.0, y_end + beyond], [-depth, y_end + beyond]])
        foot = np.array([[x_step, -depth], [x_step + depth, -depth], [x_step + depth, 0.0], [x_step, 0.0]])
        corner = np.array([[-depth, -depth], [0.0, -depth], [0.0, 0.0], [-depth, 0.0]])
        return tuple(Polygon(piece) for piece in (step, low, side, foot, corner))

    def corner_pieces(self) -> dict[int, int]:
        """Which pieces of ``obstacle()`` stand for a concave corner: piece index -> the index of
        its vertex at the corner."""
        return {3: 3, 4: 2}

    def points(self, step_rad: float = math.radians(0.5)) -> np.ndarray:
        """The outline as points (n, 2) from its first corner to its last, convex corners as
        arcs every ``step_rad``."""
        core, parts = self.core_mm, [self.core_mm[:1]]
        for before, vertex, after in zip(core[:-2], core[1:-1], core[2:]):
            first, second = _outward(before, vertex), _outward(vertex, after)
            turn = math.remainder(math.atan2(second[1], second[0]) - math.atan2(first[1], first[0]), 2 * math.pi)
            if turn <= 0:  # concave: the corner stays sharp
                parts.append(vertex[None])
                continue
            centre = vertex + np.linalg.solve(np.array([first, second]), [-self.radius_mm] * 2)
            start = math.atan2(first[1], first[0])
            angles = start + np.linspace(0.0, turn, max(2, int(math.ceil(turn / step_rad)) + 1))
            parts.append(centre + self.radius_mm * np.column_stack([np.cos(angles), np.sin(angles)]))
        parts.append(core[-1:])
        return np.vstack(parts)

    def dense(self, spacing_mm: float = 0.05) -> np.ndarray:
        """Points along the outline, end to end, no more than ``spacing_mm`` apart."""
        line, pieces = self.points(), []
        for a, b in zip(line[:-1], line[1:]):
            count = max(1, int(math.ceil(np.linalg.norm(b - a) / spacing_mm)))
            pieces.append(a + (b - a) * (np.arange(count)[:, None] / count))
        return np.vstack(pieces + [line[-1:]])

    @property
    def perimeter_mm(self) -> float:
        """Length of the outline from end to end, mm."""
        return float(np.sum(np.linalg.norm(np.diff(self.points(), axis=0), axis=1)))

    def past_end(self, point_mm: np.ndarray) -> bool:
        """Does ``point_mm`` (world) lie beyond the outline's far end, along its last side (where
        the solid goes on only so that no false edge stands at the end)?"""
        last, end = self.core_mm[-2], self.core_mm[-1]
        return bool((np.asarray(point_mm, float) - end) @ (end - last) > 0.0)


def _outward(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Unit outward normal (to the right walking from a to b: the solid is on the left)."""
    edge = (b - a) / np.linalg.norm(b - a)
    return np.array([edge[1], -edge[0]])


def _rounded_edge(corner_mm: np.ndarray, radius_mm: float) -> np.ndarray:
    """The arc (31 points) that rounds a 90° convex edge from +x round to -y of ``corner_mm``
    (the top edge of a step down toward -x, the solid below and to the right)."""
    angles = np.linspace(math.pi / 2, math.pi, 31)
    centre = corner_mm + np.array([radius_mm, -radius_mm])
    return centre + radius_mm * np.column_stack([np.cos(angles), np.sin(angles)])


@dataclass(frozen=True)
class CornerOutline(WallOutline):
    """A straight wall (y = 0, walked toward -x, the solid below) into a concave corner at the
    origin and out along a second wall (its last core point's direction, the solid on its
    left): the corner's free side opens as far as that direction's angle."""

    def obstacle(self) -> tuple[Polygon, ...]:
        """The two walls' pieces (each a half-plane's slab, which the solid contains) and the
        corner's parallelogram, whose vertex at the corner lies between the two walls' normals
        (a tip held there, pushed by both, is its tip-on-vertex contact)."""
        (x_end, _), corner, second = self.core_mm
        depth, beyond = _WALL_DEPTH_MM, _WALL_BEYOND_MM
        along = second / np.linalg.norm(second)
        behind = np.array([-along[1], along[0]])  # the solid's side of the second wall
        first = np.array([[-depth, -depth], [x_end + beyond, -depth], [x_end + beyond, 0.0], [-depth, 0.0]])
        length = float(np.linalg.norm(second)) + beyond
        wall = np.array([corner - depth * along, corner + length * along,
                         corner + length * along + depth * behind, corner - depth * along + depth * behind])
        back = np.array([-depth, 0.0])
        square = np.array([corner + back - depth * along, corner - depth * along, corner, corner + back])
        return tuple(Polygon(piece) for piece in (first, wall, square))

    def corner_pieces(self) -> dict[int, int]:
        return {2: 2}


@dataclass(frozen=True)
class StepOutline(WallOutline):
    """A straight wall with a step down toward the object (walked toward -x, the solid below):
    the step's top (y = H), its rounded edge, its face (x = 150 mm), the concave foot, the wall
    beyond (y = 0)."""

    def obstacle(self) -> tuple[Polygon, ...]:
        """The step's block (with its rounded edge), the lower wall's slab and a square behind
        the step's foot (the foot its vertex between the two walls' normals)."""
        (x_end, height), (x_step, _), _, (x_far, _) = self.core_mm
        depth, beyond = _WALL_DEPTH_MM, _WALL_BEYOND_MM
        edge = _rounded_edge(np.array([x_step, height]), self.radius_mm)
        step = np.vstack([[[x_step, -depth], [x_end + beyond, -depth], [x_end + beyond, height]], edge])
        low = np.array([[x_far - beyond, -depth], [x_step, -depth], [x_step, 0.0], [x_far - beyond, 0.0]])
        foot = np.array([[x_step, -depth], [x_step + depth, -depth], [x_step + depth, 0.0], [x_step, 0.0]])
        return tuple(Polygon(piece) for piece in (step, low, foot))

    def corner_pieces(self) -> dict[int, int]:
        return {2: 3}
