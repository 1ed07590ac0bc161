"""An object's outline from a short text: ``circle:d=160``, ``rounded-rect:w=160,h=160,r=40``,
``polygon:n=8,side=70,r=30`` or ``polyline:FILE`` (mm).

The three shapes are convex cores grown by a corner radius, built with the twin's own outlines
(``twin.outlines.Outline``), centred at the origin: ``circle`` of diameter ``d``; ``rounded-rect``
``w`` wide (along x) and ``h`` high with corners of radius ``r`` (default 0); ``polygon`` a
regular polygon of ``n`` sides, each ``side`` long before its corners are rounded to radius ``r``
(default 0), one side at the bottom (the twin's octagon: ``polygon:n=8,side=70,r=30``).
``polyline:FILE`` is the polyline through the points of FILE (x y per line, mm; separated by
spaces, tabs or a comma; ``#`` starts a comment), closed when its last point repeats its first.
The outline is a shapely geometry, so distances are to the continuous outline, not to samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import shapely
from scipy.spatial import cKDTree

from whiskercal.checks import integer, number, positive
from whiskercal.errors import UsageError
from whiskercal.twin.outlines import Outline, regular_core

KINDS = ("circle", "rounded-rect", "polygon", "polyline")
_KEYS = {"circle": ("d",), "rounded-rect": ("w", "h", "r"), "polygon": ("n", "side", "r")}
_REQUIRED = {"circle": ("d",), "rounded-rect": ("w", "h"), "polygon": ("n", "side")}
_ARC_STEP_RAD = math.radians(0.25)  # corner arcs as chords 0.25° apart: sag under 1e-3 mm at r 100
_SEGMENT_MM = 0.5  # a fit's nearest points: the outline cut into segments this long at most


@dataclass(frozen=True)
class SpecOutline:
    """An outline to evaluate against: its spec text, the geometry (mm) and whether it is closed."""

    spec: str
    kind: str
    geometry: shapely.LinearRing | shapely.LineString
    source: str | None = None  # the polyline's file

    @property
    def closed(self) -> bool:
        """True when the outline goes round an object."""
        return isinstance(self.geometry, shapely.LinearRing)

    @property
    def length_mm(self) -> float:
        """Length of the outline, mm."""
        return float(self.geometry.length)

    @property
    def vertices_mm(self) -> np.ndarray:
        """The outline's vertices (n, 2), mm (closed: the first repeated at the end)."""
        return np.asarray(self.geometry.coords, float)

    @property
    def centre_mm(self) -> np.ndarray:
        """Centre of the outline's vertices' bounding box, mm (a fit's first guess)."""
        low, high = self.vertices_mm.min(axis=0), self.vertices_mm.max(axis=0)
        return (low + high) / 2

    @property
    def size_mm(self) -> float:
        """Diagonal of the outline's bounding box, mm."""
        return float(np.linalg.norm(np.ptp(self.vertices_mm, axis=0)))

    @cached_property
    def segments(self) -> tuple[np.ndarray, np.ndarray, cKDTree]:
        """The outline as segments no longer than _SEGMENT_MM (their starts and ends, (m, 2))
        and a k-d tree over their vertices, for :meth:`nearest`."""
        dense = shapely.get_coordinates(shapely.segmentize(self.geometry, _SEGMENT_MM))
        return dense[:-1], dense[1:], cKDTree(dense[:-1] if self.closed else dense)

    def nearest(self, points_mm: np.ndarray) -> np.ndarray:
        """The outline's point nearest to each point (n, 2), in the outline's frame (mm): the
        nearest on the two segments about the nearest vertex, which is the nearest on the whole
        outline wherever its segments are short against the point's distance to any other part
        of it (what a fit needs; the figures take shapely's distance to the whole outline)."""
        starts, ends, tree = self.segments
        _, index = tree.query(points_mm)
        count = len(starts)
        before = (index - 1) % count if self.closed else np.maximum(index - 1, 0)
        feet = [_foot(points_mm, starts[segment], ends[segment])
                for segment in (before, np.minimum(index, count - 1))]
        closer = np.linalg.norm(points_mm - feet[0], axis=1) < np.linalg.norm(points_mm - feet[1], axis=1)
        return np.where(closer[:, None], feet[0], feet[1])

    def describe(self) -> dict:
        """JSON-able: the spec, kind, closed and length."""
        return {"spec": self.spec, "kind": self.kind, "closed": self.closed,
                "length_mm": self.length_mm}


def _foot(points_mm: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Each point's nearest point on its segment start -> end (all (n, 2), mm)."""
    edge = ends - starts
    along = np.sum((points_mm - starts) * edge, axis=1) / np.maximum(np.sum(edge ** 2, axis=1), 1e-300)
    return starts + np.clip(along, 0.0, 1.0)[:, None] * edge


def parse_outline(spec: str) -> SpecOutline:
    """The outline ``spec`` names (module docstring); a UsageError names what is wrong."""
    kind, _, rest = str(spec).partition(":")
    kind = kind.strip().lower()
    if kind not in KINDS or not rest.strip():
        raise UsageError(f"--outline {spec!r}: use circle:d=D, rounded-rect:w=W,h=H,r=R, "
                         "polygon:n=N,side=S,r=R or polyline:FILE (mm)")
    if kind == "polyline":
        return SpecOutline(spec, kind, _polyline(Path(rest.strip())), rest.strip())
    values = _key_values(spec, kind, rest)
    core, radius = _core(spec, kind, values)
    ring = Outline(kind, core, radius).points(_ARC_STEP_RAD)
    return SpecOutline(spec, kind, shapely.LinearRing(ring))


def _key_values(spec: str, kind: str, rest: str) -> dict[str, str]:
    """``k=v`` pairs, each key known to ``kind`` and given once; the required ones present."""
    values: dict[str, str] = {}
    for item in rest.split(","):
        key, equals, value = item.partition("=")
        key = key.strip().lower()
        if not equals or key not in _KEYS[kind] or key in values:
            raise UsageError(f"--outline {spec!r}: {item.strip()!r} is not one of "
                             f"{', '.join(k + '=' for k in _KEYS[kind])} (each once)")
        values[key] = value.strip()
    missing = [key for key in _REQUIRED[kind] if key not in values]
    if missing:
        raise UsageError(f"--outline {spec!r}: {kind} needs {', '.join(k + '=' for k in missing)}")
    return values


def _core(spec: str, kind: str, values: dict[str, str]) -> tuple[np.ndarray, float]:
    """The convex core (vertices, mm) and the corner radius (mm) of a shape."""
    name = f"--outline {kind}"
    radius = number(values.get("r", 0.0), f"{name} r", low=0.0, unit="mm")
    if kind == "circle":
        return np.zeros((1, 2)), positive(values["d"], f"{name} d", unit="mm") / 2
    if kind == "rounded-rect":
        width = positive(values["w"], f"{name} w", unit="mm")
        height = positive(values["h"], f"{name} h", unit="mm")
        if 2 * radius >= min(width, height):
            raise UsageError(f"--outline {spec!r}: r must be less than half of w and of h "
                             "(for a circle use circle:d=D)")
        a, b = width / 2 - radius, height / 2 - radius
        return np.array([[a, -b], [a, b], [-a, b], [-a, -b]]), radius
    sides = integer(values["n"], f"{name} n", low=3)
    apothem = positive(values["side"], f"{name} side", unit="mm") / (2 * math.tan(math.pi / sides))
    if radius >= apothem:
        raise UsageError(f"--outline {spec!r}: r must be less than the polygon's apothem "
                         f"({apothem:.4g} mm)")
    return regular_core(sides, apothem - radius), radius


def _polyline(path: Path) -> shapely.LinearRing | shapely.LineString:
    """The polyline through a file's points; a ring when the last point repeats the first."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        reason = getattr(error, "strerror", None) or error
        raise UsageError(f"--outline polyline:{path}: cannot read it ({reason})") from None
    points = []
    for number_, line in enumerate(text.splitlines(), start=1):
        cells = line.split("#", 1)[0].replace(",", " ").split()
        if not cells:
            continue
        if len(cells) != 2:
            raise UsageError(f"{path}: line {number_} has {len(cells)} fields; a polyline is x y "
                             "per line (mm)")
        points.append([number(cell, f"{path} line {number_}", unit="mm") for cell in cells])
    points = np.array(points, float).reshape(-1, 2)
    if len(points) < 2 or np.ptp(points, axis=0).max() == 0:
        raise UsageError(f"{path}: a polyline needs at least two distinct points (x y per line, mm)")
    if len(points) >= 4 and np.array_equal(points[0], points[-1]):
        return shapely.LinearRing(points)
    return shapely.LineString(points)
