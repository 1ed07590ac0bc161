"""Coulomb friction at the whisker's tip, quasi-static stick-slip: the parameters and the slip rule.

One model for every surface the tip sticks to: the study's sliding plane (`physics.plane`) and the
contour scenes' objects (`physics.shape_friction`). A sticking tip stays glued to its point of the
surface while the tangential force it needs stays inside the static cone |F_t| <= mu_s·F_n; past
it the tip slides with |F_t| = mu_k·F_n, overshoots, and comes to rest (and sticks again) at the
rest ratio (`Coulomb.rest_ratio`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from whiskercal.checks import number
from whiskercal.errors import UsageError

# PLA against a nitinol wire's end: dry polymer-on-metal friction is 0.2-0.4; the static and
# kinetic values were then tuned with the study sweep in docs/twin.md ("Mechanics").
DEFAULT_MU_STATIC = 0.30
DEFAULT_MU_KINETIC = 0.22
# A slip overshoots the kinetic equilibrium almost as far as an undamped spring-mass would: the
# nitinol wire and the spiral suspension damp the tip's swing little (damping ratio ~0.03 gives
# exp(-pi*0.03) = 0.91 of the overshoot); `Coulomb.slip_rebound`, docs/twin.md.
DEFAULT_SLIP_REBOUND = 0.9
# Below this gap between mu_s and the rest ratio the tip cannot re-stick: it slides steadily.
STEADY_SLIDE_RATIO = 1e-9


@dataclass(frozen=True)
class Coulomb:
    """Friction at the tip (dimensionless).

    Attributes
    ----------
    mu_static, mu_kinetic : float
        Coulomb coefficients (static >= kinetic >= 0).
    slip_rebound : float
        How far a slip overshoots the kinetic equilibrium, 0..1: the tip comes to rest where
        |F_t|/F_n = mu_k - slip_rebound·(mu_s - mu_k) (`rest_ratio`). 0 is a slip that stops
        as soon as kinetic friction balances (fully damped); 1 the undamped spring-mass, whose
        first stop lies as far below mu_k·F_n as the breakaway lay above it.
    """

    mu_static: float = DEFAULT_MU_STATIC
    mu_kinetic: float = DEFAULT_MU_KINETIC
    slip_rebound: float = DEFAULT_SLIP_REBOUND

    def __post_init__(self) -> None:
        number(self.mu_kinetic, "mu_kinetic", low=0.0)
        if number(self.mu_static, "mu_static", low=0.0) < self.mu_kinetic:
            raise UsageError("mu_static must be at least mu_kinetic.")
        number(self.slip_rebound, "slip_rebound", low=0.0, high=1.0)

    @property
    def rest_ratio(self) -> float:
        """|F_t|/F_n where a slipping tip comes to rest and sticks again (see `slip_rebound`)."""
        overshoot = self.slip_rebound * (self.mu_static - self.mu_kinetic)
        return max(self.mu_kinetic - overshoot, -self.mu_static)

    @property
    def sticks(self) -> bool:
        """Can a slipping tip stick again? (No when mu_s equals the rest ratio: steady sliding.)"""
        return self.mu_static - self.rest_ratio > STEADY_SLIDE_RATIO


def slips_within_step(ratio_start: float, ratio_stuck: float, friction) -> tuple[float, int]:
    """Friction ratio F_t/F_n at the end of a step that overloads the static cone, and the
    number of slip events in the step.

    While stuck, the ratio grows almost linearly with the surface's motion over one small step,
    from `ratio_start` (the previous state) to `ratio_stuck` (the stuck solve at the new pose,
    beyond ±mu_s). It breaks loose where the line crosses the cone's edge, the tip slides and
    comes to rest at the rest ratio (`friction.rest_ratio`), sticks there, and the rest of the
    step's motion loads it again; every further period of mu_s - rest ratio is one more slip.
    The count is therefore independent of how finely the path is stepped. `friction`: anything
    with `mu_static` and `rest_ratio` (a `Coulomb`, a `Plane`).
    """
    sign = math.copysign(1.0, ratio_stuck)
    growth = sign * (ratio_stuck - ratio_start)
    before = max(0.0, friction.mu_static - sign * ratio_start)   # load left before breakaway
    after = max(0.0, growth - before)                            # load applied after it
    period = friction.mu_static - friction.rest_ratio
    extra = int(after // period)
    return sign * (friction.rest_ratio + after - extra * period), 1 + extra
