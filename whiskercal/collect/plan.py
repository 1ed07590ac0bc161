"""Grid plans: which rod positions to visit, in what order, along which path, and how long it takes.

Points are lattice points of the whisker frame inside a reach band and an angle band
(default_grid.toml says why the default bands give the paper's 180 points). Every point is
approached moving in -y (the rod comes from +y, as the contact does), columns in ascending x
with the same final +x approach, so the stage's backlash is always taken up the same way. A
column is visited top to bottom; between columns the rod retracts to a safe y above the whisker.
The tip sweep (``collect.sweep``), when enabled, follows the grid: its points come after the
lattice's in the plan, each approached in -y the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from whiskercal.collect.config import CollectConfig, GridConfig
from whiskercal.collect.sweep import sweep_points
from whiskercal.errors import UsageError
from whiskercal.session.frame import RigFrame

# Lattice points closer than this to a band edge would be in or out by rounding; the default
# bands keep every lattice point more than 0.15 mm / 0.3 deg away from their edges.
_EDGE_EPS = 1e-9


def whisker_to_stage(points_mm: np.ndarray, origin_stage_mm, angle_deg: float) -> np.ndarray:
    """Whisker-frame points (..., 2) mm to stage machine coordinates (..., 2) mm."""
    return RigFrame.from_degrees(origin_stage_mm, angle_deg).to_stage(points_mm)


def stage_to_whisker(points_mm: np.ndarray, origin_stage_mm, angle_deg: float) -> np.ndarray:
    """Stage machine coordinates (..., 2) mm to whisker-frame points (..., 2) mm."""
    return RigFrame.from_degrees(origin_stage_mm, angle_deg).to_whisker(points_mm)


def rig_frame(config: CollectConfig) -> RigFrame:
    """The whisker frame in stage coordinates, as the config's [rig] table states it."""
    return RigFrame.from_degrees(config.rig.origin_stage_mm, config.rig.angle_deg)


def angle_floor_deg(grid: GridConfig, reach_mm) -> np.ndarray:
    """Lower edge of the angle band at a reach (mm), degrees: linear from near to far."""
    share = (np.asarray(reach_mm, float) - grid.reach_min_mm) / (grid.reach_max_mm - grid.reach_min_mm)
    return grid.angle_min_near_deg + (grid.angle_min_far_deg - grid.angle_min_near_deg) * share


def inside_bands(grid: GridConfig, points_mm: np.ndarray) -> np.ndarray:
    """Mask of whisker-frame points (n, 2) mm inside the reach band and the angle band."""
    reach_mm = np.hypot(points_mm[:, 0], points_mm[:, 1])
    angle_deg = np.degrees(np.arctan2(points_mm[:, 1], points_mm[:, 0]))
    return ((reach_mm >= grid.reach_min_mm - _EDGE_EPS) & (reach_mm <= grid.reach_max_mm + _EDGE_EPS)
            & (angle_deg >= angle_floor_deg(grid, reach_mm) - _EDGE_EPS)
            & (angle_deg <= grid.angle_max_deg + _EDGE_EPS))


# the square lattice the bands are cut from, at most (a 1 mm step over a 500 mm reach is about
# a million); a finer step is refused before its arrays are allocated
MAX_LATTICE_POINTS = 1_000_000


def lattice_points(grid: GridConfig) -> np.ndarray:
    """Whisker-frame lattice points (n, 2) mm inside the reach and angle bands (unordered)."""
    n_max = int(np.ceil(grid.reach_max_mm / grid.step_mm))
    if (2 * n_max + 1) ** 2 > MAX_LATTICE_POINTS:
        raise UsageError(f"grid.step_mm = {grid.step_mm:g} over a reach of {grid.reach_max_mm:g} mm "
                         f"asks for a lattice of {(2 * n_max + 1) ** 2:.3g} points, more than "
                         f"{MAX_LATTICE_POINTS:.0e}: choose a coarser step")
    steps = np.arange(-n_max, n_max + 1) * grid.step_mm
    points = np.column_stack([a.ravel() for a in np.meshgrid(steps, steps)])
    return points[inside_bands(grid, points)]


def visiting_order(points_mm: np.ndarray) -> np.ndarray:
    """Indices that sort points column by column (x ascending), each column by y descending."""
    return np.lexsort((-points_mm[:, 1], points_mm[:, 0]))


@dataclass(frozen=True)
class Move:
    """One straight stage move: whisker-frame start and end (mm), feed (mm/min), why."""

    start_mm: np.ndarray
    end_mm: np.ndarray
    feed_mm_min: float
    purpose: str

    @property
    def length_mm(self) -> float:
        """Straight-line length, mm."""
        return float(np.hypot(*(self.end_mm - self.start_mm)))


@dataclass(frozen=True)
class GridPlan:
    """The planned rod positions in visiting order, in both frames, and the run's config.

    ``sweep_from``: the plan index where the tip sweep's points begin (the length: no sweep).
    """

    rod_center_mm: np.ndarray
    stage_mm: np.ndarray
    config: CollectConfig
    sweep_from: int | None = None

    def __post_init__(self) -> None:
        if self.sweep_from is None:
            object.__setattr__(self, "sweep_from", len(self.rod_center_mm))

    def __len__(self) -> int:
        return len(self.rod_center_mm)

    @property
    def sweep_count(self) -> int:
        """How many of the plan's points are the tip sweep's."""
        return len(self) - self.sweep_from

    @property
    def park_mm(self) -> np.ndarray:
        """Whisker-frame parking position for the static baselines, mm."""
        return np.asarray(self.config.approach.park_mm, float)

    @property
    def frame(self) -> RigFrame:
        """This plan's rig geometry: the whisker frame in stage coordinates."""
        return rig_frame(self.config)

    def to_stage(self, points_mm: np.ndarray) -> np.ndarray:
        """Whisker frame to stage coordinates with this plan's rig geometry."""
        return self.frame.to_stage(points_mm)

    def to_whisker(self, points_mm: np.ndarray) -> np.ndarray:
        """Stage coordinates to the whisker frame with this plan's rig geometry."""
        return self.frame.to_whisker(points_mm)

    def moves_to(self, start_mm: np.ndarray, target_mm: np.ndarray, to_park: bool = False) -> list[Move]:
        """The moves from ``start_mm`` to a grid point (or the park position), whisker frame.

        The next point down the same column is one approach move. Anything else retracts to the
        safe y, crosses at the safe y (overshooting in -x first if the target lies in -x), and
        descends onto the target in -y.
        """
        start_mm, target_mm = np.asarray(start_mm, float), np.asarray(target_mm, float)
        motion, approach = self.config.motion, self.config.approach
        same_column = np.isclose(start_mm[0], target_mm[0]) and target_mm[1] < start_mm[1]
        if same_column and not to_park:
            return [Move(start_mm, target_mm, motion.approach_feed_mm_min, "approach")]
        safe_y = max(approach.safe_y_mm, target_mm[1]) if to_park else approach.safe_y_mm
        waypoints = [start_mm] + self._detour_past_tip(start_mm)
        waypoints.append(np.array([waypoints[-1][0], max(waypoints[-1][1], safe_y)]))
        if target_mm[0] < waypoints[-1][0] - _EDGE_EPS:
            waypoints.append(np.array([target_mm[0] - approach.overtravel_mm, waypoints[-1][1]]))
        waypoints.append(np.array([target_mm[0], waypoints[-1][1]]))
        waypoints.append(np.array([target_mm[0], max(safe_y, target_mm[1])]))
        moves = [Move(a, b, motion.travel_feed_mm_min, "travel")
                 for a, b in zip(waypoints[:-1], waypoints[1:]) if not np.allclose(a, b)]
        feed = motion.travel_feed_mm_min if to_park else motion.approach_feed_mm_min
        if not np.allclose(waypoints[-1], target_mm):
            moves.append(Move(waypoints[-1], target_mm, feed, "park" if to_park else "approach"))
        return moves

    def _detour_past_tip(self, start_mm: np.ndarray) -> list[np.ndarray]:
        """A waypoint past the tip when the rod starts under the whisker (e.g. after homing).

        Rising in +y from below the angle band would hit the shaft from the wrong side, and
        behind the root stands the sensor, so the rod first moves along x to beyond the tip.
        """
        rig = self.config.rig
        clear_x = rig.whisker_reach_mm + rig.rod_radius_mm
        angle_deg = np.degrees(np.arctan2(start_mm[1], start_mm[0]))
        lowest_deg = min(self.config.grid.angle_min_near_deg, self.config.grid.angle_min_far_deg)
        below = start_mm[0] < clear_x and start_mm[1] < -rig.rod_radius_mm
        under = below and (angle_deg < lowest_deg - 5.0 or self._at_sweep_point(start_mm))
        return [np.array([clear_x, start_mm[1]])] if under else []

    def _at_sweep_point(self, point_mm: np.ndarray) -> bool:
        """Is the rod at a tip-sweep point? There the wire may have slipped past the rod and
        sprung back above it, so the rod leaves outward past the tip, never straight up."""
        sweep = self.rod_center_mm[self.sweep_from:]
        return bool(len(sweep)) and bool(np.min(np.hypot(*(sweep - point_mm).T)) < 1e-6)

    def path(self, start_index: int = 0) -> list[Move]:
        """Every move of a run from the park position over the points and back, whisker frame."""
        moves, here = [], self.park_mm
        for target in self.rod_center_mm[start_index:]:
            moves += self.moves_to(here, target)
            here = target
        return moves + self.moves_to(here, self.park_mm, to_park=True)


def build_plan(config: CollectConfig) -> GridPlan:
    """The grid plan for a configuration.

    Raises
    ------
    UsageError
        When the bands give a number of points other than ``grid.expected_points`` (if set).
    """
    points = lattice_points(config.grid)
    expected = config.grid.expected_points
    if expected and len(points) != expected:
        raise UsageError(f"the grid bands give {len(points)} points, not the expected {expected}; "
                         "adjust the bands or set grid.expected_points = 0")
    ordered = np.vstack([points[visiting_order(points)],
                         sweep_points(config.sweep, config.rig.trace_length_mm)])
    rig = config.rig
    return GridPlan(ordered, whisker_to_stage(ordered, rig.origin_stage_mm, rig.angle_deg), config,
                    len(points))
