"""Tip loads followed through a contact, for (Y, Z) readings that fold.

On some builds one (Y, Z) reading fits tip loads of quite different directions: on a suspension
four times the default's stiffness, pushes 35° apart can leave the magnet in poses the chip
reads alike, with tips 10-30 mm apart, and no (Y, Z) table can answer them (docs/calibration.md,
"Where one reading folds"). The readings of one contact still trace a continuous path from
rest, and near rest no two loads share a reading, so a follower that holds one load and, for
each new sample, moves only to loads next to it stays on the branch the contact is on:

- a reading *fits* a load when, placed between the load's grid neighbours by the local slope
  (a 2x2 solve, never past the loads' edge), it lies within ``FITS_SIGMAS`` of it, Y and Z
  scaled by their noise; the tip is read at that place, so it varies smoothly;
- a contact's first reading takes the smallest load that fits (a contact grows from rest);
- each later one takes the best load within ``WINDOW`` of the held one, a turn of direction
  costing ``TURN_COST`` a row;
- when none there fits (a buckling push snaps; a contact moved faster than the window), the
  load that fits closest on the grid within ``REACH``; near rest (``NEAR_REST_SIGMAS``), where
  all directions read alike and the first choice may have been another, the contact starts
  over among loads no larger than the held one's neighbours; else the reading gets no tip (the
  contact left the loads) rather than a far branch's that happens to read the same.

The loads are a regular grid of force direction (rows) and size (columns), each with its (Y, Z)
µT and tip mm, NaN where none was solved (``whiskercal.mechfit.branch_surface`` makes it from
the fitted mechanics; the artifact's ``/load_branches`` carries it).
"""

from __future__ import annotations

import math

import numpy as np

WINDOW = (3, 6)
"""Rows (directions, 1° apart) and columns (sizes) searched on either side of the held load for
each new sample: a press turns its force slowly (a sliding plane not at all), its size fast."""
TURN_COST = 4.0
"""What turning the held load's direction by one row costs, in squared noise units: where a
press's path runs along a fold, loads of other directions fit its readings as well, and only
the direction's persistence keeps it on its own."""
FITS_SIGMAS = 6.0
"""How near (noise units) a reading placed between a load's neighbours must lie to fit it."""
REACH = (3, 20)
"""Rows and columns the held load may move by when its window has no load that fits."""
NEAR_REST_SIGMAS = 100.0
"""A held load reading within this of rest (noise units) may have the wrong direction: with
nothing near it that fits, the contact starts over."""
MAX_CANDIDATES = 256
"""Loads tried at most when the window has none that fits: those whose grid reading lies within
``FITS_SIGMAS`` and one cell of the reading, in the order the case asks for."""


class LoadBranches:
    """Tip loads on a (direction, size) grid: ``fields_uT`` (na, nm, 2) (Y, Z) from rest,
    ``tips_mm`` (na, nm, 2), NaN where no load; ``noise_uT`` (2,) weighs the two axes;
    ``y_range_uT`` (low, high): readings outside it get no tip."""

    def __init__(self, fields_uT, tips_mm, noise_uT, y_range_uT) -> None:
        self.fields_uT = np.asarray(fields_uT, float)
        self.tips_mm = np.asarray(tips_mm, float)
        self.noise_uT = np.asarray(noise_uT, float)
        self.y_range_uT = (float(y_range_uT[0]), float(y_range_uT[1]))
        scaled = self.fields_uT / self.noise_uT
        self._scaled = np.where(np.isfinite(scaled), scaled, np.inf)
        self._cell = _cell_sizes(self._scaled)

    @classmethod
    def from_arrays(cls, arrays: dict) -> "LoadBranches":
        """From the artifact's ``/load_branches`` arrays (``fields_uT``, ``tip_mm``,
        ``noise_uT``, ``y_range_uT``)."""
        return cls(arrays["fields_uT"], arrays["tip_mm"], arrays["noise_uT"],
                   arrays["y_range_uT"])

    def at_rest(self, y_uT: float, z_uT: float) -> bool:
        """Does the reading lie within ``FITS_SIGMAS`` of rest?"""
        return math.hypot(y_uT / self.noise_uT[0], z_uT / self.noise_uT[1]) <= FITS_SIGMAS

    @property
    def shape(self) -> tuple[int, int]:
        return self.fields_uT.shape[:2]

    def follower(self) -> "BranchFollower":
        return BranchFollower(self)


class BranchFollower:
    """One contact's load, followed sample by sample (module docstring); :meth:`reset` between
    contacts."""

    def __init__(self, branches: LoadBranches, window: tuple[int, int] = WINDOW) -> None:
        self.branches = branches
        self.window = window
        self.held: tuple[int, int] | None = None

    def reset(self) -> None:
        """A new contact: the next sample searches every load."""
        self.held = None

    def tip_scalar(self, y_uT: float, z_uT: float) -> tuple[float, float]:
        """The tip (x, y) mm of the held branch's load at this reading; NaN outside the Y range,
        for a non-finite reading and beyond every load (the held load is kept)."""
        low, high = self.branches.y_range_uT
        if not (low <= y_uT <= high and math.isfinite(z_uT)):
            return math.nan, math.nan
        reading = np.array([y_uT, z_uT]) / self.branches.noise_uT
        found = self._next_load(reading)
        if found is None:  # beyond every load: no tip, and the branch held stays
            return math.nan, math.nan
        self.held, tip = found
        return float(tip[0]), float(tip[1])

    def _next_load(self, reading: np.ndarray):
        """(load, tip) to hold for this reading (module docstring), None when no load fits."""
        if self.held is None:
            return self._first_that_fits(reading, _smallest_first)
        found = self._in_window(reading)
        if found is not None:
            return found
        held, shape = self.held, self.branches.shape
        found = self._first_that_fits(
            reading, lambda rows, sizes, d: (rows - held[0]) ** 2 + (sizes - held[1]) ** 2,
            _span(held[0], REACH[0], shape[0]), _span(held[1], REACH[1], shape[1]))
        scaled = self.branches._scaled[held]
        if found is not None or scaled @ scaled > NEAR_REST_SIGMAS ** 2:
            return found
        return self._first_that_fits(reading, _smallest_first,
                                     sizes_span=(0, held[1] + self.window[1] + 1))

    def _in_window(self, reading: np.ndarray):
        """The best load within ``WINDOW`` of the held one, turns costed; None if it fits not."""
        (a0, a1), (m0, m1) = (_span(c, w, n) for c, w, n in
                              zip(self.held, self.window, self.branches.shape))
        local = _squared_distances(self.branches._scaled[a0:a1, m0:m1], reading)
        turn = (np.arange(a0, a1) - self.held[0])[:, None] ** 2
        k = np.unravel_index(int(np.argmin(local + TURN_COST * turn)), local.shape)
        at = (a0 + int(k[0]), m0 + int(k[1]))
        tip, misfit = _placed(self.branches, at, reading)
        return (at, tip) if misfit <= FITS_SIGMAS ** 2 else None

    def _first_that_fits(self, reading, order, rows_span=(0, None), sizes_span=(0, None)):
        """The first load, in ``order(rows, sizes, squared distances)``, among those near the
        reading (rows and sizes within the spans), that explains it once placed between its
        neighbours; None when none does."""
        every = np.full(self.branches.shape, np.inf)
        block = (slice(*rows_span), slice(*sizes_span))
        every[block] = _squared_distances(self.branches._scaled[block], reading)
        rows, sizes = np.nonzero(every <= (FITS_SIGMAS + self.branches._cell) ** 2)
        if not len(rows):
            return None
        for k in np.argsort(order(rows, sizes, every[rows, sizes] + 1e-12),
                            kind="stable")[:MAX_CANDIDATES]:
            at = (int(rows[k]), int(sizes[k]))
            tip, misfit = _placed(self.branches, at, reading)
            if misfit <= FITS_SIGMAS ** 2:
                return at, tip
        return None


def _cell_sizes(scaled: np.ndarray) -> np.ndarray:
    """Each load's largest distance to a grid neighbour with a load (noise units; 0 alone)."""
    cell = np.zeros(scaled.shape[:2])
    for axis in (0, 1):
        with np.errstate(invalid="ignore"):  # inf - inf where neither has a load
            step = np.linalg.norm(np.diff(scaled, axis=axis), axis=-1)
        step = np.where(np.isfinite(step), step, 0.0)
        ahead = [slice(None)] * 2
        ahead[axis] = slice(0, -1)
        behind = [slice(None)] * 2
        behind[axis] = slice(1, None)
        cell[tuple(ahead)] = np.maximum(cell[tuple(ahead)], step)
        cell[tuple(behind)] = np.maximum(cell[tuple(behind)], step)
    return cell


def _smallest_first(rows, sizes, squared):
    """Candidates by size, then by distance: a contact grows from rest."""
    return sizes + squared / squared.max()


def _span(center: int, window: int, size: int) -> tuple[int, int]:
    return max(center - window, 0), min(center + window + 1, size)


def _squared_distances(scaled: np.ndarray, reading: np.ndarray) -> np.ndarray:
    d = scaled - reading
    return np.nan_to_num(d[..., 0] ** 2 + d[..., 1] ** 2, nan=np.inf, posinf=np.inf)


def _placed(branches: LoadBranches, at: tuple[int, int], reading: np.ndarray):
    """(tip mm, squared misfit in noise units) of the reading placed by the local slope near
    the grid load ``at`` (at most one cell away)."""
    i, j = at
    scaled, tips = branches._scaled, branches.tips_mm
    steps = [_step(scaled, tips, i, j, axis) for axis in (0, 1)]
    here = reading - scaled[i, j]
    if any(s is None for s in steps):
        return tips[i, j], float(here @ here)
    jac = np.column_stack([steps[0][0], steps[1][0]])
    try:
        offset = np.linalg.solve(jac, here)
    except np.linalg.LinAlgError:
        return tips[i, j], float(here @ here)
    # within the neighbours that exist: never past the edge of the loads
    offset = np.clip(offset, [s[2] for s in steps], [s[3] for s in steps])
    left = here - jac @ offset
    return tips[i, j] + offset[0] * steps[0][1] + offset[1] * steps[1][1], float(left @ left)


def _step(scaled, tips, i, j, axis):
    """(d field, d tip) per grid step along ``axis`` at (i, j), and how far (in steps) a
    reading may be placed behind and ahead: central where both neighbours exist, one-sided
    where one does, None where neither."""
    size = scaled.shape[axis]
    ahead = (i + 1, j) if axis == 0 else (i, j + 1)
    behind = (i - 1, j) if axis == 0 else (i, j - 1)
    have = [k for k in (ahead, behind)
            if 0 <= k[axis] < size and np.all(np.isfinite(scaled[k]))]
    if len(have) == 2:
        return (scaled[ahead] - scaled[behind]) / 2, (tips[ahead] - tips[behind]) / 2, -1.0, 1.0
    if have == [ahead]:
        return scaled[ahead] - scaled[i, j], tips[ahead] - tips[i, j], 0.0, 1.0
    if have == [behind]:
        return scaled[i, j] - scaled[behind], tips[i, j] - tips[behind], -1.0, 0.0
    return None
