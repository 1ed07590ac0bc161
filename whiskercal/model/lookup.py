"""The tip lookup: tips traced at a few z values, and a fast interpolant z -> (x_tip, y_tip).

Tracing is far too slow for 300 Hz, so tips are traced once at ``n`` z values over the calibrated
range, evenly spaced in z, and an interpolant is built. (Even spacing in z keeps the piece index
O(1); samples spread evenly along the tip's path would give that up without being closer to the
twin's true tips.)
The interpolant's kind is chosen by hold-out error against dense traces. Every kind is stored
as a table of polynomial pieces on the uniform z grid (a single piece for the global
polynomial), so evaluation is one index computation and a Horner loop: plain floats for one
sample, numpy for a batch.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.interpolate import Akima1DInterpolator, CubicSpline, PchipInterpolator, PPoly

from whiskercal.model.errors import ModelError, TraceError, ZOutOfRangeError
from whiskercal.model.trace import TRACERS, LevelSetProblem, get_tracer

KINDS = ("linear", "cubic", "pchip", "akima", "polynomial")
POLYNOMIAL_DEGREE = 5  # the authors' characterized model: one 5th-order polynomial per axis
OUT_OF_RANGE_POLICIES = ("raise", "nan", "clip")
# Most levels of the lookup's dense set (samples and hold-out) that may be bridged rather than
# traced: isolated failures inside the range are skipped, a broken range is refused.
MAX_UNTRACED_FRACTION = 0.05


def check_out_of_range(policy: str) -> None:
    """Refuse an ``out_of_range`` policy other than :data:`OUT_OF_RANGE_POLICIES`."""
    if policy not in OUT_OF_RANGE_POLICIES:
        raise ModelError(f"out_of_range must be one of {', '.join(OUT_OF_RANGE_POLICIES)}, "
                         f"not {policy!r}")


def piece_table(z_knots_uT: np.ndarray, tips_mm: np.ndarray, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Breakpoints (m+1,) and coefficients (m, order, 2), highest power first, of one kind.

    Local variable: z - breakpoint (µT). The breakpoints are the knots, or the range's two ends
    for the global polynomial.
    """
    z, tips = np.asarray(z_knots_uT, float), np.asarray(tips_mm, float)
    if kind == "polynomial":
        degree = min(POLYNOMIAL_DEGREE, len(z) - 1)
        # fit in a scaled variable, then expand about the low end so the table is one piece
        scale = (z[-1] - z[0]) / 2
        fits = [np.polynomial.Polynomial.fit((z - z[0]) / scale, tips[:, k], degree, domain=[0, 2],
                                             window=[0, 2]) for k in range(2)]
        coefficients = np.stack([f.coef[::-1] / scale ** np.arange(degree, -1, -1) for f in fits],
                                axis=-1)
        return np.array([z[0], z[-1]]), coefficients[None, :, :]
    if kind == "linear":
        slopes = np.diff(tips, axis=0) / np.diff(z)[:, None]
        return z, np.stack([slopes, tips[:-1]], axis=1)
    builders = {"cubic": CubicSpline, "pchip": PchipInterpolator, "akima": Akima1DInterpolator}
    if kind not in builders:
        raise ModelError(f"unknown interpolant {kind!r}; choose one of {', '.join(KINDS)}")
    spline: PPoly = builders[kind](z, tips, axis=0)
    return z, np.moveaxis(spline.c, 0, 1)  # (order, m, 2) -> (m, order, 2)


class TipLookup:
    """z (µT) -> tip (mm) from a piece table on uniform breakpoints.

    Parameters
    ----------
    z_knots_uT : ndarray (n,)
        Increasing, evenly spaced sample z values; their ends are the calibrated range.
    tips_mm : ndarray (n, 2)
        Traced tips at those z.
    kind : str
        One of :data:`KINDS`.
    """

    def __init__(self, z_knots_uT: np.ndarray, tips_mm: np.ndarray, kind: str,
                 trusted_z_uT: tuple[float, float] | None = None) -> None:
        self.z_knots_uT = np.asarray(z_knots_uT, float)
        self.tips_mm = np.asarray(tips_mm, float)
        self.kind = kind
        steps = np.diff(self.z_knots_uT)
        if len(self.z_knots_uT) < 2 or np.any(steps <= 0):
            raise ModelError("lookup knots must be at least two increasing z values")
        if np.ptp(steps) > 1e-9 * np.ptp(self.z_knots_uT):
            raise ModelError("lookup knots must be evenly spaced in z")
        breaks, self._table = piece_table(self.z_knots_uT, self.tips_mm, kind)
        self._z0 = float(breaks[0])  # the pieces' origin; the accepted range may be narrower
        self.z_min_uT, self.z_max_uT = float(breaks[0]), float(breaks[-1])
        self._n_pieces = len(breaks) - 1
        self._inv_width = self._n_pieces / (self.z_max_uT - self.z_min_uT)
        self._range_name = "the calibrated range"
        if trusted_z_uT is not None:
            self._restrict(*trusted_z_uT)
        self._break_list = np.asarray(breaks, float).tolist()
        self._flat_table = np.ascontiguousarray(
            np.concatenate([self._table[:, :, 0], self._table[:, :, 1]], axis=1))
        self._rows = [[tuple(c) for c in piece] for piece in self._table.tolist()]

    def _restrict(self, low_uT: float, high_uT: float) -> None:
        if not self.z_min_uT <= low_uT <= high_uT <= self.z_max_uT:
            raise ModelError(f"the trusted range [{low_uT:.1f}, {high_uT:.1f}] µT does not lie "
                             f"inside the lookup's [{self.z_min_uT:.1f}, {self.z_max_uT:.1f}] µT")
        self.z_min_uT, self.z_max_uT = float(low_uT), float(high_uT)
        self._range_name = "the trusted range (tips beyond it are extrapolated past the grid)"

    def _out_of_range(self, z: float) -> ZOutOfRangeError:
        return ZOutOfRangeError(f"z = {z:.1f} µT is outside {self._range_name} "
                                f"[{self.z_min_uT:.1f}, {self.z_max_uT:.1f}] µT")

    def tip_scalar(self, z_uT: float, out_of_range: str = "raise") -> tuple[float, float]:
        """One tip (x, y) mm from one z in plain floats (the per-sample path)."""
        if not self.z_min_uT <= z_uT <= self.z_max_uT:
            if out_of_range == "clip" and z_uT == z_uT:
                z_uT = min(max(z_uT, self.z_min_uT), self.z_max_uT)
            elif out_of_range == "raise":
                raise self._out_of_range(z_uT)
            else:
                return float("nan"), float("nan")
        piece = min(int((z_uT - self._z0) * self._inv_width), self._n_pieces - 1)
        t = z_uT - self._break_list[piece]
        x = y = 0.0
        for cx, cy in self._rows[piece]:
            x, y = x * t + cx, y * t + cy
        return x, y

    def __call__(self, z_uT, out_of_range: str = "raise") -> np.ndarray:
        """Tips (..., 2) mm for z (...) µT; ``out_of_range`` is "raise", "nan" or "clip"."""
        check_out_of_range(out_of_range)
        z = np.asarray(z_uT, float)
        if z.ndim == 0:
            return np.array(self.tip_scalar(float(z), out_of_range))
        return self._batch(z, out_of_range)

    def _batch(self, z: np.ndarray, out_of_range: str) -> np.ndarray:
        flat = z.reshape(-1)
        outside = ~((flat >= self.z_min_uT) & (flat <= self.z_max_uT))  # NaN counts as outside
        any_outside = bool(outside.any())
        if any_outside:
            if out_of_range == "raise":
                raise self._out_of_range(float(flat[outside][0]))
            flat = np.clip(flat, self.z_min_uT, self.z_max_uT)
            flat[np.isnan(flat)] = self.z_min_uT  # a placeholder: its row is set to NaN below
        cells = (flat - self._z0) * self._inv_width
        piece = cells.astype(np.intp)
        np.minimum(piece, self._n_pieces - 1, out=piece)
        t = (cells - piece) / self._inv_width  # z - the piece's breakpoint, without a gather
        rows = self._flat_table.take(piece, axis=0)  # (n, 2 * order): x then y coefficients
        order = self._table.shape[1]
        x, y = rows[:, 0].copy(), rows[:, order].copy()
        for k in range(1, order):
            x *= t
            x += rows[:, k]
            y *= t
            y += rows[:, order + k]
        tips = np.stack([x, y], axis=-1)
        if any_outside:
            tips[outside if out_of_range == "nan" else np.isnan(z.reshape(-1))] = np.nan
        return tips.reshape(z.shape + (2,))


@dataclass(frozen=True)
class LookupReport:
    """Hold-out evidence for the interpolant choice (mm)."""

    kind: str
    holdout_rmse_mm: float          # Euclidean RMSE of the chosen kind
    holdout_rmse_xy_mm: np.ndarray  # per axis, chosen kind
    rmse_by_kind_mm: dict           # kind -> Euclidean hold-out RMSE
    holdout_z_uT: np.ndarray
    holdout_tips_mm: np.ndarray
    knot_extension_mm: np.ndarray | None = None  # straight extension past the grid per sample
    max_extension_mm: float = float("nan")       # the longest among all traces (samples, hold-out)
    # levels inside the range the tracer could not follow, bridged from the traced levels beside
    # them (``bridge_untraced``), and why the first of them failed
    untraced_z_uT: np.ndarray = field(default_factory=lambda: np.zeros(0))
    untraced_reason: str = ""


def supported_z_range(problem: LevelSetProblem, tracer: str = "fast", iterations: int = 12,
                      ) -> tuple[float, float]:
    """The part of the data's z range over which the trace succeeds (µT).

    The ends of the data's range are often not traceable (their level sets leave the grid before
    reaching the tip's arc length); each end is moved inward by bisection to the last z that traces.
    """
    low, high = problem.z_range_uT
    middle = _traceable_middle(problem, tracer)
    return (bisect_end(problem, tracer, middle, low, iterations),
            bisect_end(problem, tracer, middle, high, iterations))


def traces_ok(problem: LevelSetProblem, tracer: str, z: float) -> bool:
    """True when ``tracer`` reaches the tip at z (µT) without a :class:`TraceError`."""
    try:
        TRACERS[tracer](problem, z)
    except TraceError:
        return False
    return True


def _traceable_middle(problem: LevelSetProblem, tracer: str) -> float:
    low, high = problem.z_range_uT
    for fraction in (0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8):
        z = low + fraction * (high - low)
        if traces_ok(problem, tracer, z):
            return z
    raise ModelError("no z in the calibrated range can be traced to the tip: the grid does not "
                     "cover the whisker out to its trace length")


def bisect_end(problem, tracer, good: float, end: float, iterations: int) -> float:
    """The z (µT) nearest ``end`` that still traces, bisecting from a z that does (``good``)."""
    if traces_ok(problem, tracer, end):
        return end
    bad = end
    for _ in range(iterations):
        middle = (good + bad) / 2
        good, bad = (middle, bad) if traces_ok(problem, tracer, middle) else (good, middle)
    return good


def build_lookup(problem: LevelSetProblem, n_samples: int = 20, tracer: str = "fast",
                 kind: str = "auto", holdout_per_interval: int = 9) -> tuple[TipLookup, LookupReport]:
    """Trace ``n_samples`` tips over the supported range and pick the interpolant by hold-out.

    The hold-out set is ``holdout_per_interval`` z values strictly inside every sample interval,
    traced with the same tracer; the chosen kind has the smallest Euclidean hold-out RMSE there
    (or ``kind`` is forced).
    """
    if n_samples < 2:
        raise ModelError("the lookup needs at least 2 samples")
    trace = get_tracer(tracer)
    if kind != "auto" and kind not in KINDS:
        raise ModelError(f"unknown interpolant {kind!r}; choose one of {', '.join(KINDS)} or auto")
    if kind == "akima" and n_samples < 3:
        raise ModelError("the akima interpolant needs at least 3 samples")
    low, high = supported_z_range(problem, tracer)
    problem = _with_range(problem, (low, high))
    dense_z = np.linspace(low, high, (n_samples - 1) * (holdout_per_interval + 1) + 1)
    dense_tips, extensions, traced, reason = _trace_levels(trace, problem, dense_z)
    dense_tips, extensions = bridge_untraced(dense_z, dense_tips, extensions, traced)
    every = holdout_per_interval + 1
    z_knots, tips = dense_z[::every], dense_tips[::every]
    holdout = traced.copy()  # a bridged level is no evidence against the interpolant
    holdout[::every] = False
    holdout_z, holdout_tips = dense_z[holdout], dense_tips[holdout]
    errors = {k: _holdout_error(TipLookup(z_knots, tips, k), holdout_z, holdout_tips)
              for k in KINDS if k != "akima" or n_samples >= 3}
    chosen = min(errors, key=lambda k: errors[k][0]) if kind == "auto" else kind
    report = LookupReport(chosen, errors[chosen][0], errors[chosen][1],
                          {k: e[0] for k, e in errors.items()}, holdout_z, holdout_tips,
                          extensions[::every], float(extensions.max()),
                          dense_z[~traced], reason)
    return TipLookup(z_knots, tips, chosen), report


def _trace_levels(trace, problem: LevelSetProblem, z_uT: np.ndarray,
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """Tips (n, 2) mm and extensions (n,) mm of each level (NaN where the trace failed), which
    levels traced, and why the first failure failed ("" when none did)."""
    tips, extensions = np.full((len(z_uT), 2), np.nan), np.full(len(z_uT), np.nan)
    traced, reason = np.zeros(len(z_uT), bool), ""
    for i, z in enumerate(z_uT):
        try:
            result = trace(problem, float(z))
        except TraceError as error:
            reason = reason or str(error)
            continue
        tips[i], extensions[i], traced[i] = result.tip_mm, result.extension_mm, True
    return tips, extensions, traced, reason


def bridge_untraced(z_uT: np.ndarray, tips_mm: np.ndarray, extensions_mm: np.ndarray,
                    traced: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fill the tips (mm) and extensions (mm) of untraced levels from the traced ones.

    A level set the tracer cannot follow inside a range whose neighbours trace (a saddle or a
    grid hole the trace steps into) says nothing about the tips beside it; a cubic spline
    through the traced levels, a tenth of a sample interval apart, bridges it. The lookup stays
    sound only while every gap is a single level between traced ones, and few: two untraced
    levels in a row, an untraced end, or more than :data:`MAX_UNTRACED_FRACTION` of the levels
    is refused (ModelError), as the lookup would then rest on tips nobody traced.
    """
    if traced.all():
        return tips_mm, extensions_mm
    gaps = ~traced
    if gaps[0] or gaps[-1] or np.any(gaps[1:] & gaps[:-1]) or gaps.mean() > MAX_UNTRACED_FRACTION:
        where = ", ".join(f"{z:.0f}" for z in z_uT[gaps][:5])
        raise ModelError(f"the level sets at z = {where} µT cannot be traced ({int(gaps.sum())} "
                         f"of {len(z_uT)} levels, not isolated ones): the lookup over this "
                         "range would not be sound; collect a denser grid there")
    tips_mm, extensions_mm = tips_mm.copy(), extensions_mm.copy()
    tips_mm[gaps] = CubicSpline(z_uT[traced], tips_mm[traced])(z_uT[gaps])
    extensions_mm[gaps] = np.interp(z_uT[gaps], z_uT[traced], extensions_mm[traced])
    return tips_mm, extensions_mm


def _holdout_error(lookup: TipLookup, z: np.ndarray, tips: np.ndarray) -> tuple[float, np.ndarray]:
    residual = lookup(z) - tips
    return (float(np.sqrt(np.mean(np.sum(residual ** 2, axis=1)))),
            np.sqrt(np.mean(residual ** 2, axis=0)))


def _with_range(problem: LevelSetProblem, z_range: tuple[float, float]) -> LevelSetProblem:
    return replace(problem, z_range_uT=(float(z_range[0]), float(z_range[1])))
