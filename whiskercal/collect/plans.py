"""Named collection plans: the default ``full`` plan and shorter ones chosen on the twin.

A named plan is a layer of settings between the defaults (default_grid.toml) and a user's file:
the lattice step, the tip sweep's positions, the settle time and the feeds. Its lengths
are stated for the default 78 mm trace and scale with a build's trace length as the reach band
does (``config.follow_trace_length``), so a plan keeps about the same point count, and stage
time per millimetre of wire, on every build. A key the user's file gives still wins.

``quick`` was chosen with ``whiskercal bench --only calibration-time`` (docs/calibration.md):

- a 7 mm lattice in the same bands: the mechanics-informed fit has a handful of parameters,
  and a coarser lattice over the same reaches and angles still spans what pins them; its
  outermost column ends no further from the band's far edge than the 3 mm lattice's (1.75 mm
  against 2.75 mm short of it for a 78 mm trace), which the level-set trace to the tip needs
  (a 7.5 mm lattice stops over 4 mm short, further than ``fit`` extrapolates);
- five tip-sweep positions at the trace length itself, on rays from -5 to -40 deg (the full
  sweep's span): a sweep point costs a long approach from above the whisker where the grid's
  points cost a short step down their column, and the sweep is what pins the tip (the bench's
  ``coarse-lattice`` plan, this lattice with the whole sweep, tells the two apart); the deeper
  rays load the tip toward the root, which the short 60 mm build needs for its suspension to
  be identified (docs/research/2026-12-03-quick-plan.md);
- a 0.1 s settle: after a stop at the stage's acceleration the wire's modes leave the averaged
  reading within its own noise (the bench's ``settle`` rows, from the twin's ring-down);
- the approach at the default travel feed (1500 mm/min) and the moves clear of the whisker at
  the stage's rate (3000 mm/min): on the twin's modes a slide at the stage's acceleration up
  to 50 mm/s stays below one sample's noise (``bench --only dynamics``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from whiskercal.errors import UsageError

# the trace length the plans' lengths are stated for, mm (config.DEFAULT_TRACE_LENGTH_MM)
PLAN_TRACE_LENGTH_MM = 78.0


@dataclass(frozen=True)
class NamedPlan:
    """What a plan changes from the defaults (None: keep the default's value).

    Lengths in mm for a 78 mm trace, scaled by trace length / 78 mm for other builds; angles in
    deg, times in s, feeds in mm/min.
    """

    name: str
    summary: str
    step_mm: float | None = None
    sweep_angles: int | None = None
    sweep_angle_last_deg: float | None = None
    sweep_offsets_mm: tuple[float, ...] | None = None
    settle_s: float | None = None
    approach_feed_mm_min: float | None = None
    travel_feed_mm_min: float | None = None

    def overrides(self, trace_length_mm: float = PLAN_TRACE_LENGTH_MM) -> dict[str, Any]:
        """The config tables this plan sets, for a build of ``trace_length_mm`` (mm)."""
        scale = float(trace_length_mm) / PLAN_TRACE_LENGTH_MM
        tables: dict[str, dict[str, Any]] = {"grid": {}, "sweep": {}, "acquisition": {},
                                             "motion": {}}
        if self.step_mm is not None:
            # the band gives another count than the paper's 180 points
            tables["grid"].update(step_mm=round(self.step_mm * scale, 3), expected_points=0)
        if self.sweep_angles is not None:
            tables["sweep"]["angles"] = self.sweep_angles
        if self.sweep_angle_last_deg is not None:
            tables["sweep"]["angle_last_deg"] = self.sweep_angle_last_deg
        if self.sweep_offsets_mm is not None:
            tables["sweep"]["offsets_mm"] = [round(o * scale, 2) for o in self.sweep_offsets_mm]
        if self.settle_s is not None:
            tables["acquisition"]["settle_s"] = self.settle_s
        if self.approach_feed_mm_min is not None:
            tables["motion"]["approach_feed_mm_min"] = self.approach_feed_mm_min
        if self.travel_feed_mm_min is not None:
            tables["motion"]["travel_feed_mm_min"] = self.travel_feed_mm_min
        return {name: table for name, table in tables.items() if table}


FULL = NamedPlan("full", "the paper's 180-point lattice and the 28-point tip sweep, 0.3 s settle")
QUICK = NamedPlan("quick", "a 7 mm lattice, 5 tip-sweep points at the tip from -5 to -40 deg, "
                  "0.1 s settle, approach at 1500 mm/min, travel at 3000 mm/min", step_mm=7.0,
                  sweep_angles=5, sweep_angle_last_deg=-40.0, sweep_offsets_mm=(0.0,),
                  settle_s=0.1, approach_feed_mm_min=1500.0, travel_feed_mm_min=3000.0)
PLANS = {plan.name: plan for plan in (FULL, QUICK)}
DEFAULT_PLAN = "full"


def named_plan(name: str) -> NamedPlan:
    """The plan called ``name``.

    Raises
    ------
    UsageError
        For a name no plan has (one line listing the names).
    """
    if name not in PLANS:
        raise UsageError(f"unknown plan {name!r}; choose from {', '.join(PLANS)}")
    return PLANS[name]
