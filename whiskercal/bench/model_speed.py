"""Speed against accuracy of the calibration models, measured in one run.

``run()`` returns a JSON-able dict:

- ``tracers``: the paper's fixed-step tracer at several steps and the adaptive tracer, on a
  surface with curved level sets (z = g(θ + κ r)); time per trace, and error against the
  exactly computed tip (the straight root segment plus the spiral, by quadrature).
- ``speedup_fast_vs_paper``: time of the paper's 1e-3 mm tracer over the adaptive one, same run.
- ``lookup``: one-sample call time (µs) and batch throughput (samples/s) per interpolant.
- ``lookup_size``: hold-out RMSE (mm) by sample count and interpolant, and build time.
- ``surface_degree``: CV RMSE per degree on a noisy grid, and the degree the 1-SE rule picks.

Everything is seeded; the surfaces are analytic, so the numbers do not depend on the twin.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq

from whiskercal.model.lookup import KINDS, TipLookup, build_lookup
from whiskercal.model.surface import fit_surface
from whiskercal.model.trace import Domain, LevelSetProblem, trace_fast, trace_paper

LENGTH_MM = 78.0
ENTRY_MM = 26.0
KAPPA = 0.004  # rad/mm: how fast the level sets turn with distance from the root


def _g_uT(theta):
    return 12000.0 * theta + 3000.0 * theta ** 2 + 1500.0 * theta ** 3


def _grid_mm(reach=(12.5, 90.0), angle_deg=(-70.0, 0.0), step=3.0) -> np.ndarray:
    steps = np.arange(-31, 32) * step
    x, y = (a.ravel() for a in np.meshgrid(steps, steps))
    r, a = np.hypot(x, y), np.degrees(np.arctan2(y, x))
    keep = (r >= reach[0]) & (r <= reach[1]) & (a >= angle_deg[0]) & (a <= angle_deg[1])
    return np.column_stack([x[keep], y[keep]])


def _bent_z(points):
    return _g_uT(np.arctan2(points[:, 1], points[:, 0]) + KAPPA * np.hypot(points[:, 0], points[:, 1]))


def _exact_tip(z_uT: float) -> np.ndarray:
    c = brentq(lambda t: _g_uT(t) - z_uT, -1.5, 0.5)
    speed = lambda r: math.sqrt(1.0 + (KAPPA * r) ** 2)
    rest = LENGTH_MM - ENTRY_MM
    r_tip = brentq(lambda r: quad(speed, ENTRY_MM, r, epsabs=1e-13)[0] - rest, ENTRY_MM,
                   ENTRY_MM + rest)
    return r_tip * np.array([math.cos(c - KAPPA * r_tip), math.sin(c - KAPPA * r_tip)])


def _problem(noise_uT: float = 0.0, seed: int = 0) -> LevelSetProblem:
    points = _grid_mm()
    z = _bent_z(points) + np.random.default_rng(seed).normal(0.0, noise_uT, len(points))
    surface, _ = fit_surface(points, z, 6, "polar")
    return LevelSetProblem(surface, Domain.from_points(points, 1.0), LENGTH_MM,
                           (float(z.min()), float(z.max())), ENTRY_MM)


def _timed(function, repeats: int = 1) -> tuple[float, object]:
    start = time.perf_counter()
    for _ in range(repeats):
        result = function()
    return (time.perf_counter() - start) / repeats, result


def bench_tracers(z_values=(-6000.0, -2500.0, -600.0), paper_steps=(1e-1, 1e-2, 1e-3)) -> dict:
    """Time and error of each tracer (mean over ``z_values``)."""
    problem = _problem()
    exact = {z: _exact_tip(z) for z in z_values}
    rows = []
    for step in paper_steps:
        runs = [_timed(lambda z=z: trace_paper(problem, z, step_mm=step)) for z in z_values]
        rows.append(_tracer_row(f"paper step {step:g} mm", runs, exact, z_values))
    fast_runs = [_timed(lambda z=z: trace_fast(problem, z), repeats=20) for z in z_values]
    rows.append(_tracer_row("fast (Dormand-Prince 5(4), rtol 1e-10)", fast_runs, exact, z_values))
    paper_1um = next(r for r in rows if r["method"].startswith("paper step 0.001"))
    agreement = max(np.linalg.norm(f[1].tip_mm - p.tip_mm) for f, p in
                    zip(fast_runs, [trace_paper(problem, z) for z in z_values]))
    return {"tracers": rows, "speedup_fast_vs_paper": paper_1um["time_s"] / rows[-1]["time_s"],
            "fast_vs_paper_max_mm": float(agreement)}


def _tracer_row(name, runs, exact, z_values) -> dict:
    errors = [np.linalg.norm(result.tip_mm - exact[z]) for (_, result), z in zip(runs, z_values)]
    return {"method": name, "time_s": float(np.mean([t for t, _ in runs])),
            "max_error_mm": float(np.max(errors)),
            "evaluations": int(np.mean([r.evaluations for _, r in runs]))}


def bench_lookup(n_batch: int = 2_000_000, seed: int = 0) -> dict:
    """One-sample time and batch throughput of every interpolant (20 samples)."""
    z = np.linspace(-9000.0, -100.0, 20)
    tips = np.column_stack([78.0 * np.cos(z / 9000.0), 78.0 * np.sin(z / 9000.0)])
    probe = np.random.default_rng(seed).uniform(z[0], z[-1], n_batch)
    out = {}
    for kind in KINDS:
        lookup = TipLookup(z, tips, kind)
        single, _ = _timed(lambda: lookup.tip_scalar(-4321.0), repeats=20000)
        call, _ = _timed(lambda: lookup(-4321.0), repeats=20000)
        lookup(probe[:1000])
        batch, _ = _timed(lambda: lookup(probe), repeats=3)
        out[kind] = {"tip_scalar_us": single * 1e6, "call_scalar_us": call * 1e6,
                     "batch_samples_per_s": n_batch / batch}
    return out


def bench_lookup_size(samples=(5, 10, 20, 40), seed: int = 0) -> dict:
    """Hold-out RMSE (mm) per interpolant by sample count, with build time (s)."""
    problem = _problem(noise_uT=1.0, seed=seed)
    rows = {}
    for n in samples:
        elapsed, (lookup, report) = _timed(lambda n=n: build_lookup(problem, n))
        rows[str(n)] = {"build_s": elapsed, "chosen": report.kind,
                        "holdout_rmse_mm": {k: float(v) for k, v in report.rmse_by_kind_mm.items()}}
    return rows


def bench_surface_degree(noise_uT: float = 5.0, seed: int = 0) -> dict:
    """CV RMSE by degree (µT) on the curved-level-set grid with noise, and the 1-SE choice."""
    points = _grid_mm(reach=(12.5, 65.0), angle_deg=(-44.5, 0.0))
    z = _bent_z(points) + np.random.default_rng(seed).normal(0.0, noise_uT, len(points))
    out = {}
    for coordinates in ("polar", "cartesian"):
        elapsed, (surface, report) = _timed(lambda c=coordinates: fit_surface(points, z, "auto", c))
        out[coordinates] = {"chosen_degree": surface.degree, "fit_s": elapsed,
                            "cv_rmse_by_degree_uT": dict(zip(map(str, report.degrees.tolist()),
                                                             report.cv_rmse_by_degree.tolist()))}
    return out


def run() -> dict:
    """All model benchmarks, JSON-able."""
    return {"tracing": bench_tracers(), "lookup": bench_lookup(),
            "lookup_size": bench_lookup_size(), "surface_degree": bench_surface_degree()}


if __name__ == "__main__":  # pragma: no cover
    import json

    print(json.dumps(run(), indent=2))
