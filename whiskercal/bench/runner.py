"""Run the comparisons in one process and write DIR/bench.json, one JSON per comparison, PNG charts.

Times are only comparable within one run on one machine, so every comparison runs here, one after
the other, and each Pareto row also gets its time as a ratio to the fastest row of its chart.
A comparison that raises is recorded with its error and the others still run; the caller decides
what a failure means (``whiskercal bench`` exits non-zero).
"""

from __future__ import annotations

import importlib
import json
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from whiskercal import __version__, atomic
from whiskercal.artifacts.h5io import now_iso
from whiskercal.bench.pareto import draw_pareto, front_rows
from whiskercal.bench.timing import machine_info
from whiskercal.errors import UsageError
from whiskercal.paths import ensure_dir


@dataclass(frozen=True)
class Comparison:
    """One comparison: how to run it (full or quick) and what it is about."""

    name: str
    summary: str
    run: Callable[[bool, Callable | None], dict]


def _module_run(module: str, **quick_kwargs) -> Callable[[bool, Callable | None], dict]:
    def run(quick: bool, progress: Callable | None) -> dict:
        return importlib.import_module(module).run(quick=quick, progress=progress, **quick_kwargs)
    return run


def _engines(quick: bool, progress: Callable | None) -> dict:
    from whiskercal.bench import engines
    from whiskercal.twin.physics.elastica import DEFAULT_STEPS

    options = dict(segments=(10,), rk4_steps=(16, DEFAULT_STEPS), alphas=(1.0, 5.0),
                   representations=("chain",), repeats=1) if quick else {}
    result = engines.run(progress=progress, **options)
    for row in result["rows"]:
        row["default"] = row["engine"] == "quasi-static" and row["resolution"] == DEFAULT_STEPS
    spec = dict(result["pareto"])
    result["pareto"] = {"x": spec["x"], "y": spec["y"], "panel": "case_set", "series": ["engine"],
                        "label": spec.get("label", "resolution"), "x_label": "time per case (s)",
                        "y_label": "max tip error / L"}
    result["supports"] = {"engine": "quasi-static", "rk4_steps": DEFAULT_STEPS,
                          "rule": "the twin's engine at its default resolution; MuJoCo cross-checks it"}
    return result


def _twin_speed(quick: bool, progress: Callable | None) -> dict:
    from whiskercal.bench import twin_speed

    if quick:
        result = {**twin_speed.cold_solves(n_rods=10), **twin_speed.warm_rod_path(n_steps=60)}
    else:
        result = twin_speed.run()
    result["supports"] = {"study_fidelity": "quasi-static elastica with stick-slip",
                          "study_realtime_factor": result.get("study_realtime_factor"),
                          "world_realtime_factor": result.get("world_total_realtime_factor"),
                          "world_cpu_factor": result.get("world_total_cpu_factor"),
                          "rule": "the study scene must run faster than real time, in the "
                                  "solver alone and end to end through the simulated world"}
    return result


def _field_speed(quick: bool, progress: Callable | None) -> dict:
    from whiskercal.bench import field_speed

    result = field_speed.run(n_single=200, n_batch=2000) if quick else field_speed.run()
    if not quick:
        result["resolution"] = field_speed.resolution_study()
    errors = result.get("max_error_uT", {})
    result["supports"] = {
        "field_model": "interpolated table",
        "interpolated_max_error_uT": max(errors.get("interpolated_vs_exact_working_range", [np.nan])),
        "dipole_max_error_uT": max(errors.get("dipole_vs_exact_working_range", [np.nan])),
        "interpolated_single_pose_us": result.get("single_pose_us", {}).get("interpolated"),
        "exact_single_pose_us": result.get("single_pose_us", {}).get("exact"),
        "rule": "the interpolated field is far below the sensor's 5.6 µT noise and fast per sample"}
    return result


def _model_speed(quick: bool, progress: Callable | None) -> dict:
    if quick:
        return {"skipped": "the model's speed study runs in the full bench only"}
    from whiskercal.bench import model_speed

    return model_speed.run()


COMPARISONS = {c.name: c for c in (
    Comparison("tip-extraction", "paper trace vs adaptive trace vs lookup",
               _module_run("whiskercal.bench.tip_extraction")),
    Comparison("tip-accuracy", "level set vs mechanics-informed fit (Y; Y and Z; magnet map on "
               "Y and Z) across builds, on the tip curve and on plane contacts with friction",
               _module_run("whiskercal.bench.tip_accuracy")),
    Comparison("sensor-family", "every build of the family calibrated as fit does: accuracy, "
               "its estimate, silent failures", _module_run("whiskercal.bench.sensor_family")),
    Comparison("surface-degree", "polynomial degree 1..8: CV error vs evaluation time",
               _module_run("whiskercal.bench.surface_degree")),
    Comparison("collection", "samples per point and settle time vs fit error and stage time",
               _module_run("whiskercal.bench.collection")),
    Comparison("engines", "the twin's quasi-static engine vs MuJoCo", _engines),
    Comparison("twin-speed", "the twin's mechanics against real time", _twin_speed),
    Comparison("field-speed", "magnet field evaluation paths", _field_speed),
    Comparison("model-speed", "the model's per-sample costs", _model_speed),
    Comparison("tracker-speed", "the runtime tracker's cost per sample, and a replayed stream's",
               _module_run("whiskercal.bench.tracker_speed")),
    Comparison("stability", "where each method fails, and whether it is detected",
               _module_run("whiskercal.bench.stability")),
    Comparison("shaft-localizer", "contact anywhere on the shaft: batch Gauss-Newton vs particles",
               _module_run("whiskercal.bench.shaft_localizer")),
    Comparison("fit-speed", "whiskercal fit's wall time against its tip error on the recorded "
               "datasets, for each tip model (level set, mechanics, the default)",
               _module_run("whiskercal.bench.fit_speed")),
    Comparison("contour-target", "contour error against the deflection target; the follower's "
               "cost per sample", _module_run("whiskercal.bench.contour_target")),
    Comparison("error-budget", "contour error with each real-rig nuisance (drift, creep, contact "
               "fluctuation, the robot's pose and rate) alone and together, with and without its "
               "counter-measure; against robot speed and loop rate",
               _module_run("whiskercal.bench.error_budget")),
    Comparison("robot-loop", "contour run --robot through the twin's rosbridge server at 300 and "
               "30 Hz against the in-process loop; the loop's latency",
               _module_run("whiskercal.bench.robot_loop")),
    Comparison("dynamics", "the wire's bending modes on the twin's statics: ring-down after a "
               "release, and the quasi-static reading's error while the rod slides, per build",
               _module_run("whiskercal.bench.dynamics")),
    Comparison("calibration-time", "each collect plan's stage time against its shipped tip error "
               "on the family, through collect and fit with the twin's dynamics on",
               _module_run("whiskercal.bench.calibration_time")),
    Comparison("mount-cal", "mount-cal on the twin: the nominal and the fitted mount against the "
               "true one, and the contour's size error through each",
               _module_run("whiskercal.bench.mount_cal")),
)}


def select(only: tuple[str, ...] | list[str] | None) -> list[Comparison]:
    """The comparisons named in ``only`` (all when empty), in the registry's order."""
    if not only:
        return list(COMPARISONS.values())
    unknown = [name for name in only if name not in COMPARISONS]
    if unknown:
        raise UsageError(f"unknown comparison {', '.join(unknown)}; choose from "
                         f"{', '.join(COMPARISONS)}")
    return [c for c in COMPARISONS.values() if c.name in only]


def add_time_ratios(rows: list[dict], x_key: str) -> None:
    """Each row's time as a multiple of the fastest row's (same run, same machine)."""
    times = [r[x_key] for r in rows if np.isfinite(r.get(x_key, np.nan)) and r[x_key] > 0]
    if times:
        fastest = min(times)
        for row in rows:
            row["time_ratio_to_fastest"] = row.get(x_key, np.nan) / fastest


# each Pareto chart a result may ask for (its key) and the suffix of its file, NAME{suffix}.png
PARETO_CHARTS = (("pareto", ""), ("pareto_truth", "-truth"), ("pareto_realistic", "-realistic"),
                 ("pareto_lookup", "-lookup"))


def output_paths(out_dir: str | Path, chosen) -> list[Path]:
    """Every file a bench of the ``chosen`` comparisons may write into ``out_dir``: bench.json,
    one JSON per comparison and each chart it may draw."""
    out_dir = Path(out_dir)
    paths = [out_dir / "bench.json"]
    for comparison in chosen:
        paths.append(out_dir / f"{comparison.name}.json")
        paths += [out_dir / f"{comparison.name}{suffix}.png" for _, suffix in PARETO_CHARTS]
    return paths


def _charts(name: str, result: dict, out_dir: Path) -> list[str]:
    charts = []
    if name == "stability":
        from whiskercal.bench.stability_chart import draw_stability

        charts.append(draw_stability(result, out_dir / "stability.png").name)
    if name == "error-budget":
        from whiskercal.bench.error_budget import draw as draw_budget

        charts.append(draw_budget(result, out_dir / "error-budget.png").name)
    if name == "dynamics":
        from whiskercal.bench.dynamics import draw as draw_dynamics

        charts.append(draw_dynamics(result, out_dir / "dynamics.png").name)
    if name == "contour-target":
        from whiskercal.bench.contour_target import draw

        charts.append(draw(result, out_dir / "contour-target.png").name)
    for key, suffix in PARETO_CHARTS:
        spec = result.get(key)
        if spec and result.get("rows"):
            add_time_ratios(result["rows"], spec["x"])
            path = draw_pareto(result["rows"], spec, out_dir / f"{name}{suffix}.png",
                               title=f"{name}: {spec.get('y_label', spec['y'])}")
            result.setdefault("front", {})[key] = [
                {k: r.get(k) for k in ("method", "engine", "kind", "label", spec["x"], spec["y"])
                 if k in r} for r in front_rows(result["rows"], spec["x"], spec["y"])]
            charts.append(path.name)
    return charts


def _jsonable(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return str(value)


def write_json(path: Path, payload: dict) -> Path:
    """Write JSON with numpy values converted (NaN stays NaN, as Python's json writes it)."""
    return atomic.write_text(path, json.dumps(payload, indent=2, default=_jsonable))


def run_one(comparison: Comparison, out_dir: Path, quick: bool,
            progress: Callable | None = None) -> dict:
    """Run one comparison, write its JSON and charts; return its entry of bench.json."""
    started = time.perf_counter()
    try:
        result = comparison.run(quick, progress)
        charts = _charts(comparison.name, result, out_dir)
    except Exception as error:  # a broken comparison must not hide the others' results
        return {"status": "error", "error": f"{type(error).__name__}: {error}",
                "traceback": traceback.format_exc(), "elapsed_s": time.perf_counter() - started}
    write_json(out_dir / f"{comparison.name}.json", result)
    return {"status": "ok", "summary": comparison.summary, "json": f"{comparison.name}.json",
            "charts": charts, "supports": result.get("supports"),
            "elapsed_s": time.perf_counter() - started}


def run_bench(out_dir: str | Path, only=None, quick: bool = False,
              on_start: Callable[[str], None] | None = None,
              progress: Callable | None = None, force: bool = False) -> dict:
    """Run the selected comparisons and write ``out_dir``/bench.json; return its content.

    An earlier bench's file in ``out_dir`` (:func:`output_paths`) is refused before any
    comparison runs, unless ``force``; each file is replaced atomically.
    """
    out_dir = Path(out_dir)
    chosen = select(only)
    atomic.refuse_existing(output_paths(out_dir, chosen), force, "the bench output")
    ensure_dir(out_dir)
    bench = {"benchmark": "whiskercal-bench", "created": now_iso(), "whiskercal_version": __version__,
             "quick": quick, "machine": machine_info(), "comparisons": {}}
    for comparison in chosen:
        if on_start is not None:
            on_start(comparison.name)
        bench["comparisons"][comparison.name] = run_one(comparison, out_dir, quick, progress)
    bench["defaults"] = {name: entry.get("supports") for name, entry in bench["comparisons"].items()
                         if entry.get("supports")}
    write_json(out_dir / "bench.json", bench)
    return bench
