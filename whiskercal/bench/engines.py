"""Speed against accuracy of the twin's two engines on the same static cases.

Engines and their resolutions:

- ``quasi-static``: the shooting elastica (`whiskercal.twin.physics.elastica`), resolution = RK4 steps
  along the wire;
- ``mujoco-chain`` and ``mujoco-flex``: the MuJoCo engine (`whiskercal.twin.engines.mujoco_engine`),
  resolution = segments along the wire.

Case sets, each with its own reference:

- ``cantilever``: rigid root, tip load perpendicular to the undeformed axis, α = P·L²/EI in
  {0.5, 1, 2, 5, 10}; reference: the exact elastica (`mujoco_reference.cantilever_tip`).
- ``suspended``: the same loads on the default whisker's compliant root (offset stub, hinge,
  translation); reference: the exact elastica with the root's moment balance
  (`mujoco_reference.suspended_tip`).
- ``rod``: the touch rod at a few positions, solved by the quasi-static `solve_rod`. MuJoCo
  meets it twice: ``mujoco-chain`` / ``mujoco-flex`` get the equivalent dead load (the contact
  force at the contact's material point), ``mujoco-chain-contact`` finds the contact itself
  (capsules against a cylinder). Both are compared with the quasi-static tip: this checks the
  two engines against each other, not against an exact solution, so the quasi-static engine
  has no row here.

`run()` returns a JSON-able dict: one row per (case set, engine, resolution) with the time per
case and the tip error in mm and in fractions of L, enough to draw a Pareto chart of time
against error per case set (the ``whiskercal bench`` command draws it).
"""

from __future__ import annotations

import math
import platform
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict

import numpy as np

from whiskercal.twin.physics import elastica as el
from whiskercal.twin.physics.contacts import base_params
from whiskercal.twin.engines.mujoco_model import RodSpec
from whiskercal.twin.engines.mujoco_reference import cantilever_tip, suspended_tip
from whiskercal.twin.physics.whisker import WhiskerParams

ALPHAS = (0.5, 1.0, 2.0, 5.0, 10.0)
SEGMENTS = (10, 20, 40, 80)
RK4_STEPS = (8, 16, 32, 64, 96)
# Rod centres (mm, whisker frame) as (x along the whisker, how far the rod pushes past y = 0).
ROD_RADIUS_MM = 1.0
ROD_POSITIONS_MM = ((30.0, 3.0), (30.0, 10.0), (50.0, 10.0), (70.0, 10.0))
REPEATS = 3


def run(segments: Sequence[int] = SEGMENTS, rk4_steps: Sequence[int] = RK4_STEPS,
        alphas: Sequence[float] = ALPHAS, representations: Sequence[str] = ("chain", "flex"),
        repeats: int = REPEATS, whisker: WhiskerParams | None = None,
        progress: Callable[[dict], None] | None = None) -> dict:
    """Time and error of every engine at every resolution on every case set.

    Parameters
    ----------
    segments : sequence of int
        MuJoCo resolutions (segments along the wire).
    rk4_steps : sequence of int
        Quasi-static resolutions (RK4 steps along the wire).
    alphas : sequence of float
        Load parameters P·L²/EI of the cantilever and suspended cases.
    representations : sequence of {"chain", "flex"}
        MuJoCo representations to run; empty to skip MuJoCo.
    repeats : int
        Timed repetitions of each case; the fastest is kept (the least disturbed by the machine).
    whisker : WhiskerParams, optional
        The whisker (default: `WhiskerParams()`).
    progress : callable, optional
        Called with each row as it is finished (the full run takes about a minute and a half,
        most of it the flex at 80 segments).

    Returns
    -------
    dict
        ``{"benchmark", "units", "whisker", "machine", "case_sets", "rows", "pareto",
        "skipped"}``; each row has ``case_set``, ``engine``, ``resolution``,
        ``resolution_unit``, ``time_per_case_s``, ``max_error_mm``, ``rms_error_mm``,
        ``max_error_fraction_of_length`` and ``cases`` (per-case time, error, steps).
    """
    whisker = whisker or WhiskerParams()
    spec = RodSpec.from_whisker(whisker)
    case_sets = _case_sets(whisker, spec, alphas)
    rows: list[dict] = []
    skipped: list[str] = []
    for name, cases in case_sets.items():
        if name != "rod":
            for steps in rk4_steps:
                rows.append(_row(name, "quasi-static", steps, "rk4 steps", cases,
                                 _quasi_static_solver(spec, name, steps), spec, repeats))
                _report(progress, rows[-1])
        for row in _mujoco_rows(name, cases, spec, segments, representations, repeats, skipped):
            rows.append(row)
            _report(progress, row)
    return {
        "benchmark": "twin-engines",
        "units": {"time": "s", "error": "mm", "load": "N", "alpha": "P*L^2/EI"},
        "whisker": {k: v for k, v in asdict(whisker).items() if isinstance(v, (int, float))},
        "machine": {"python": platform.python_version(), "processor": platform.machine()},
        "case_sets": {name: [_describe(c) for c in cases] for name, cases in case_sets.items()},
        "rows": rows,
        "pareto": {"x": "time_per_case_s", "y": "max_error_fraction_of_length",
                   "series": ["case_set", "engine"], "label": "resolution"},
        "skipped": sorted(set(skipped)),
    }


def _report(progress: Callable[[dict], None] | None, row: dict) -> None:
    if progress is not None:
        progress(row)


def _case_sets(whisker: WhiskerParams, spec: RodSpec, alphas: Sequence[float]) -> dict:
    """Each case: the load (arc mm, force N) and the reference tip (mm) it is judged against."""
    length = spec.length_mm
    clamped = spec.clamped()
    cantilever = [
        {"alpha": a, "arc_mm": length, "force_n": [0.0, a * spec.force_scale_n],
         "reference_tip_mm": (cantilever_tip(a) * length).tolist(), "reference": "exact elastica"}
        for a in alphas
    ]
    suspended = [
        {"alpha": a, "arc_mm": length, "force_n": [0.0, a * spec.force_scale_n],
         "reference_tip_mm": suspended_tip(spec, a * spec.force_scale_n).tip_mm.tolist(),
         "reference": "exact elastica with root moment balance"}
        for a in alphas
    ]
    return {"cantilever": _with_spec(cantilever, clamped), "suspended": _with_spec(suspended, spec),
            "rod": _with_spec(_rod_cases(whisker), spec)}


def _with_spec(cases: list[dict], spec: RodSpec) -> list[dict]:
    return [dict(case, spec=spec) for case in cases]


def _rod_cases(whisker: WhiskerParams) -> list[dict]:
    """Touch-rod equilibria from the quasi-static engine, as loads for MuJoCo."""
    from whiskercal.twin.physics.mechanics import solve_rod

    cases = []
    for x_mm, push_mm in ROD_POSITIONS_MM:
        center = (x_mm, ROD_RADIUS_MM - push_mm)
        eq = solve_rod(whisker, center, ROD_RADIUS_MM)
        if not eq.in_contact:  # the wire slipped past this rod: nothing to compare
            continue
        cases.append({"rod_center_mm": list(center), "rod_radius_mm": ROD_RADIUS_MM,
                      "arc_mm": float(eq.contact_arc_mm), "force_n": eq.force_n.tolist(),
                      "reference_tip_mm": eq.tip_mm.tolist(),
                      "reference": "quasi-static solve_rod"})
    return cases


def _describe(case: dict) -> dict:
    return {k: v for k, v in case.items() if k != "spec"}


def _quasi_static_solver(spec: RodSpec, case_set: str, steps: int) -> Callable[[dict], tuple]:
    """A solver of one tip-load case by the shooting elastica at ``steps`` RK4 steps."""
    if case_set == "cantilever":
        from whiskercal.twin.physics.cantilever import cantilever_tip as shooting_tip

        def solve(case: dict) -> tuple[np.ndarray, int]:
            return np.asarray(shooting_tip(case["alpha"], steps)) * spec.length_mm, steps
        return solve
    whisker = WhiskerParams(spec.length_mm, spec.diameter_mm, spec.youngs_modulus_n_per_mm2,
                            spec.root_offset_mm, spec.root_rotational_stiffness_n_mm_per_rad,
                            spec.root_translational_stiffness_n_per_mm)

    def solve_suspended(case: dict) -> tuple[np.ndarray, int]:
        return _shooting_suspended_tip(whisker, case["alpha"], steps) * spec.length_mm, steps
    return solve_suspended


def _shooting_suspended_tip(whisker: WhiskerParams, alpha: float, steps: int) -> np.ndarray:
    """Tip (units of L) of the suspended whisker under a tip load, by the shooting engine.

    The same continuation in unit load steps as the engine's own cantilever check.
    """
    p = base_params(whisker)
    z = np.zeros(1)
    for load in np.linspace(0.0, alpha, max(1, math.ceil(alpha)) + 1)[1:]:
        p[el.P_FY] = load
        z, converged, _ = el.newton(el.CANTILEVER, z, p, steps, 1e-12, 50)
        if not converged:
            return np.full(2, np.nan)
    _, _, _, tip_x, tip_y = el.end_state(el.CANTILEVER, z, p, steps)
    return np.array([tip_x, tip_y])


def _mujoco_rows(case_set: str, cases: list[dict], spec: RodSpec, segments: Sequence[int],
                 representations: Sequence[str], repeats: int, skipped: list[str]):
    """MuJoCo rows of one case set, one at a time (a generator, so progress can follow)."""
    try:
        import mujoco  # noqa: F401  (optional dependency)
    except ImportError:
        skipped.append("mujoco: not installed (pip install whiskercal[bench])")
        return
    for representation in representations:
        for n in segments:
            yield _mujoco_row(case_set, cases, spec, n, representation, False, repeats)
            if case_set == "rod" and representation == "chain":
                yield _mujoco_row(case_set, cases, spec, n, representation, True, repeats)


def _mujoco_row(case_set: str, cases: list[dict], spec: RodSpec, segments: int,
                representation: str, contact: bool, repeats: int) -> dict:
    """One MuJoCo row: equivalent dead loads, or (``contact``) the rod through MuJoCo contact."""
    from whiskercal.twin.engines.mujoco_engine import MujocoWhisker

    started = time.perf_counter()
    radius = cases[0]["rod_radius_mm"] if contact else None
    engine = MujocoWhisker(cases[0]["spec"], segments, representation, rod_radius_mm=radius)
    build_s = time.perf_counter() - started

    def solve(case: dict) -> tuple[np.ndarray, int]:
        if contact:
            result = engine.solve_rod(case["rod_center_mm"])
        else:
            result = engine.solve_point_load(case["arc_mm"], case["force_n"])
        return result.tip_mm, result.steps

    name = f"mujoco-{representation}" + ("-contact" if contact else "")
    row = _row(case_set, name, segments, "segments", cases, solve, spec, repeats)
    row["build_time_s"] = build_s
    return row


def _row(case_set: str, engine: str, resolution: int, unit: str, cases: list[dict],
         solve: Callable[[dict], tuple], spec: RodSpec, repeats: int) -> dict:
    """Run every case ``repeats`` times; keep the fastest time and the (deterministic) tip."""
    solve(cases[0])  # warm-up: compilation and caches stay out of the timing
    per_case = []
    for case in cases:
        times = []
        for _ in range(max(1, repeats)):
            started = time.perf_counter()
            tip_mm, steps = solve(case)
            times.append(time.perf_counter() - started)
        error_mm = float(np.linalg.norm(np.asarray(tip_mm) - np.asarray(case["reference_tip_mm"])))
        per_case.append({"time_s": min(times), "error_mm": error_mm, "steps": int(steps),
                         "tip_mm": np.asarray(tip_mm, dtype=float).tolist()})
    errors = np.array([c["error_mm"] for c in per_case])
    return {
        "case_set": case_set, "engine": engine, "resolution": int(resolution),
        "resolution_unit": unit,
        "time_per_case_s": float(np.mean([c["time_s"] for c in per_case])),
        "max_error_mm": float(np.max(errors)),
        "rms_error_mm": float(np.sqrt(np.mean(errors**2))),
        "max_error_fraction_of_length": float(np.max(errors) / spec.length_mm),
        "cases": per_case,
    }
