"""Figures of the documentation: JSON snapshots under docs/figures/ rendered as tables.

Every measured number a product page shows comes from a JSON that ``whiskercal bench`` or
``whiskercal regress`` writes. ``make bench`` refreshes the snapshots (``snapshot``); ``make docs``
renders them where a page holds a marker ``<!-- figure: NAME -->`` (``render``). A snapshot
names the command that wrote it, and its table says so under it.

    python scripts/docs_figures.py snapshot out/bench     # after whiskercal bench --out out/bench
    python scripts/docs_figures.py transcript out/demo    # after make demo: the tutorial's outputs
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / "docs" / "figures"
DATA = ROOT / "data"


def _number(value, digits: int = 3) -> str:
    if value is None or isinstance(value, str):
        return "–" if value is None else value
    if isinstance(value, bool):
        return "yes" if value else "no"
    if not math.isfinite(float(value)):
        return "–"
    return f"{float(value):.{digits}g}"


def _seconds(value) -> str:
    """A time per call in the unit that keeps it readable."""
    if value is None or not math.isfinite(float(value)):
        return "–"
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("µs", 1e-6)):
        if value >= scale:
            return f"{value / scale:.3g} {unit}"
    return f"{value / 1e-9:.3g} ns"


# NAME -> the bench comparison it snapshots and the columns its table shows
# (key in each row, header, format: "s" a time, else significant digits)
BENCH_TABLES = {
    "tip-extraction": [("method", "method", 0), ("kind", "interpolant", 0),
                       ("setting", "setting", 0), ("setting_unit", "unit", 0),
                       ("time_per_call_s", "time per call", "s"),
                       ("error_vs_reference_mm", "RMS error vs converged trace (mm)", 2),
                       ("error_vs_truth_mm", "RMS error vs twin truth (mm)", 3),
                       ("default", "default", 0)],
    "surface-degree": [("degree", "degree", 0), ("cv_rmse_uT", "CV RMS (µT)", 3),
                       ("truth_rmse_uT", "RMS vs noise-free z (µT)", 3),
                       ("tip_rmse_vs_truth_mm", "tip RMS vs truth (mm)", 3),
                       ("time_per_call_s", "time per evaluation", "s"),
                       ("default", "default", 0)],
    "collection": [("series", "settle", 0), ("samples_per_point", "samples per point", 0),
                   ("stage_time_s", "stage time (s)", 4),
                   ("surface_vs_truth_rmse_uT", "surface RMS vs truth (µT)", 3),
                   ("tip_rmse_vs_truth_mm", "tip RMS vs truth (mm)", 3), ("default", "default", 0)],
    "sensor-family": [("build", "build", 0), ("variant", "data", 0), ("tip_model", "tip model", 0),
                      ("estimated_tip_error_mm", "estimate (mm)", 2),
                      ("tip_curve.rmse_mm", "true RMS (mm)", 2),
                      ("tip_curve.max_mm", "true max (mm)", 2),
                      ("field_table.written", "(Y, Z) table", 0),
                      ("field_table.held_estimated_tip_error_mm", "table estimate, held (mm)", 2),
                      ("field_table.shipped_realistic.rmse_mm", "with friction, true RMS (mm)", 2),
                      ("warned", "warned", 0), ("silent_failure", "silent failure", 0)],
    "mount-cal": [("seed", "seed", 0), ("tip_model", "tip reading", 0),
                  ("true_error.x_mm", "mount off x (mm)", 2), ("true_error.y_mm", "y (mm)", 2),
                  ("true_error.yaw_deg", "yaw (°)", 2),
                  ("fit_error.x_mm", "fit off x (mm)", 2), ("fit_error.y_mm", "y (mm)", 2),
                  ("fit_error.yaw_deg", "yaw (°)", 2), ("std.x_mm", "stated σ x (mm)", 2),
                  ("std.y_mm", "σ y (mm)", 2), ("std.yaw_deg", "σ yaw (°)", 2),
                  ("cylinder.nominal.size_error_mm", "cylinder size error, nominal (mm)", 2),
                  ("cylinder.calibrated.size_error_mm", "calibrated (mm)", 2),
                  ("octagon.nominal.size_error_mm", "octagon, nominal (mm)", 2),
                  ("octagon.calibrated.size_error_mm", "calibrated (mm)", 2)],
    "sensor-sessions": [("build", "build", 0), ("stiffness_ratio", "k_θ·L/EI", 3),
                        ("sessions", "sessions", 0), ("tip_models", "tip model shipped", 0),
                        ("best_rmse_mm", "best seed, true RMS (mm)", 2),
                        ("worst_rmse_mm", "worst seed, true RMS (mm)", 2),
                        ("worst_seed", "worst seed", 0), ("spread_mm", "spread (mm)", 2),
                        ("worst_max_mm", "worst true max (mm)", 2),
                        ("worst_realistic_held_mm", "worst with friction, held (mm)", 2),
                        ("missing_goal", "seeds missing a goal", 0),
                        ("refused", "seeds refused", 0),
                        ("shipped_off_goal", "seeds shipped off goal", 0)],
    "calibration-time": [("build", "build", 0), ("plan", "plan", 0), ("points", "points", 0),
                         ("points_time_s", "stage time, first point to last (s)", 3),
                         ("worst_rmse_mm", "worst seed, true RMS (mm)", 2),
                         ("rmse_over_full_mm", "over the full plan's (mm)", 2),
                         ("worst_realistic_held_mm", "with friction, held (mm)", 2),
                         ("realistic_over_full_mm", "over the full plan's (mm)", 2),
                         ("worst_estimate_mm", "estimate, worst seed (mm)", 2),
                         ("worst_truth_over_estimate", "truth / estimate, worst", 2),
                         ("tip_models", "tip model shipped", 0), ("meets_goal", "goal met", 0)],
    "robot-loop": [("shape", "object", 0), ("rate_hz", "rate (Hz)", 3),
                   ("robot_mean_error_mm", "through rosbridge: mean error (mm)", 2),
                   ("robot_coverage", "coverage", 2),
                   ("in_process_mean_error_mm", "in process: mean error (mm)", 2),
                   ("latency_ms.loop.mean", "loop latency, mean (ms)", 2),
                   ("latency_ms.loop.p95", "loop latency, p95 (ms)", 2)],
    "twin-validate": [("name", "check", 0), ("value", "result", 2), ("limit", "limit", 2),
                      ("ok", "passed", 0), ("detail", "detail", 0)],
    "contour-target": [("tip_model", "tip model", 0), ("shape", "object", 0),
                       ("target_z_uT", "target (µT)", 5), ("default", "chosen target", 0),
                       ("mean_error_mm", "mean error, no alignment (mm)", 2),
                       ("std_error_mm", "std (mm)", 2), ("max_error_mm", "max (mm)", 2),
                       ("aligned_mean_error_mm", "aligned mean (mm)", 2),
                       ("coverage", "coverage", 2), ("contacts_lost", "contacts lost", 0),
                       ("time_to_go_round_s", "round in (s)", 4)],
    "error-budget": [("case", "case (object, plane study depth)", 0), ("nuisance", "nuisance", 0),
                     ("countermeasure_on", "counter-measure on", 0),
                     ("countermeasure", "counter-measure", 0),
                     ("mean_error_mm", "mean error, no alignment (mm)", 3),
                     ("max_error_mm", "max (mm)", 3), ("coverage", "coverage", 2),
                     ("failing", "the study fails the trial", 0),
                     ("contacts_lost", "contacts lost", 0),
                     ("fluctuation_uT", "in-contact fluctuation (µT)", 3),
                     ("estimated_latency_ms", "latency estimate (ms)", 2)],
    "dynamics": [("build", "build", 0), ("first_mode_hz", "first mode (Hz)", 3),
                 ("second_mode_hz", "second (Hz)", 3), ("damping_ratio", "ζ", 2),
                 ("release_z_uT", "z held before the release (µT)", 4),
                 ("ring_down_s", "ring-down to the noise (s)", 3),
                 ("envelope_s", "first mode's envelope (s)", 3), ("noise_uT", "noise σ (µT)", 2),
                 ("error_uT.abrupt.10", "slide error at 10 mm/s, at once (µT)", 3),
                 ("error_uT.abrupt.50", "at 50 mm/s (µT)", 3),
                 ("error_uT.stage.50", "at 50 mm/s, stage's acceleration (µT)", 3),
                 ("past_noise_from_mm_s.abrupt", "past the noise from (mm/s), at once", 3),
                 ("past_noise_from_mm_s.stage", "at the stage's acceleration", 3)],
}
# more tables from one snapshot: NAME -> (the snapshot, its rows from its result, the columns)
EXTRA_TABLES = {
    "error-budget-speed": ("error-budget", lambda result: result["speed_rate_rows"],
                           [("rate_hz", "loop rate (Hz)", 3), ("speed_mm_s", "speed (mm/s)", 3),
                            ("mean_error_mm", "mean error, no alignment (mm)", 3),
                            ("coverage", "coverage", 2), ("contacts_lost", "contacts lost", 0),
                            ("estimated_latency_ms", "latency estimate (ms)", 2)]),
    "error-budget-goal": ("error-budget", lambda result: [
        {"case": case, **verdict,
         "without_set_by_mm": verdict.get("without_mean_error_mm", {}).get(verdict["set_by"])}
        for case, verdict in result["goal"].items()],
                          [("case", "case", 0), ("all_mean_error_mm", "all nuisances, every "
                           "counter-measure (mm)", 3), ("goal_mm", "goal (mm)", 2),
                           ("met", "met", 0), ("set_by", "set by", 0),
                           ("without_set_by_mm", "all but that one (mm)", 3)]),
    "error-budget-fluctuation": ("error-budget", lambda result: [result["contact_fluctuation"]],
                                 [("target_z_uT", "deflection target (µT)", 4),
                                  ("fluctuation_uT", "the twin's in-contact fluctuation (µT)", 3),
                                  ("measured_uT", "the authors' logs (µT)", 0)]),
    "error-budget-levels": ("error-budget", lambda result: [
        {"key": f"{table}.{key}", "value": json.dumps(value), "source": result["sources"][f"{table}.{key}"]}
        for table, values in result["levels"].items() for key, value in values.items()],
                            [("key", "parameter", 0), ("value", "realistic level", 0),
                             ("source", "where it comes from", 0)]),
}
# the sensor files' descriptions (`twin describe`, one JSON per file of sensors/): the columns of
# their table, each a value computed from one description (``_describe_row``)
DESCRIBE_COLUMNS = [("sensor", "sensor", 0), ("ei", "EI (N·mm²)", 4),
                    ("ratio", "k_θ·L/EI", 3), ("kind", "at the paper's deflection: contact", 0),
                    ("force_mN", "force (mN)", 2), ("z_uT", "z (µT)", 4),
                    ("one_to_one", "one-to-one z range (µT)", 0),
                    ("ends", "the range ends", 0),
                    ("peak_share", "largest share of an axis' range", 2),
                    ("saturates", "saturates", 0)]
DESCRIBE_COMMAND = "whiskercal twin describe PATH --json"
# the command that writes each snapshot's source JSON (``make bench`` runs them into out/bench),
# and where in it the table's rows are
SOURCES = {"twin-validate": ("whiskercal twin validate --json", "checks"),
           "sensor-sessions": ("whiskercal bench --only sensor-family (its sessions)",
                               "per_build")}
# the recorded datasets' golden results (written by make record-data, checked by make regress)
GOLDEN_ROWS = [("fit.tip_model", "tip model shipped by the regression's fit", 0),
               ("fit.rmse_uT", "surface fit residual, RMS (µT)", 3),
               ("fit.cv_rmse_uT", "surface fit residual, cross-validated RMS (µT)", 3),
               ("fit.points_used", "grid points fitted", 0),
               ("fit.lookup_vs_truth_rmse_mm", "lookup vs the twin's true tips, RMS (mm)", 3),
               ("fit.lookup_vs_truth_max_mm", "lookup vs the twin's true tips, largest (mm)", 3),
               ("study.target.depth_mm", "study: the chosen depth (mm)", 3),
               ("study.target.z_uT", "study: the chosen target (µT)", 5),
               ("study.failing_depths_mm", "study: failing depths (mm)", 3),
               ("study.passing_mean_filtered_mm", "study: passing trials' mean filtered error (mm)",
                2)]
# one study trial's row in the recorded study's table: golden key suffix, header, digits
STUDY_COLUMNS = [("depth", "depth (mm)", 0), ("contact_fraction", "contact", 2),
                 ("median_z_uT", "median z (µT)", 5), ("filtered_mean_mm", "filtered mean (mm)", 2),
                 ("filtered_std_mm", "filtered std (mm)", 2),
                 ("true_filtered_mean_mm", "vs true tip (mm)", 2), ("n_slips", "slips", 0),
                 ("failing", "failing", 0)]


def _describe_row(description: dict) -> dict:
    """One sensor file's row: its stiffness, the paper's deflection, the one-to-one range (and
    why it ends) and how much of the magnetometer's range the sweep uses."""
    deflection, one = description["paper_deflection"], description["one_to_one"]
    low, high = one["z_range_uT"]
    ends = {"fold": f"z folds at a tip slope of {abs(one['tip_slope_rad']):.2g} rad",
            "sweep_end": "the whole sweep", "contact_lost": "where the rod loses the tip"}
    saturation = description["saturation"]
    return {"sensor": description["sensor_id"], "ei": description["bending_stiffness_n_mm2"],
            "ratio": description["root_ratio_k_theta_l_over_ei"], "kind": deflection["kind"],
            "force_mN": 1e3 * deflection["force_n"], "z_uT": deflection["z_uT"],
            "one_to_one": f"{low:.0f}..{high:.0f}",
            "ends": ends.get(one["ends_at"], one["ends_at"]),
            "peak_share": max(saturation["peak_fraction"]),
            "saturates": "no" if saturation["axis"] is None else
            f"{saturation['axis']} at {saturation['z_uT']:.0f} µT"}


def _describe_figure() -> str:
    snap = _snapshot("twin-describe")
    rows = [_describe_row(d) for d in snap["result"]["sensors"]]
    return (markdown_table(rows, DESCRIBE_COLUMNS)
            + f"\n\n*From `docs/figures/twin-describe.json`, written by `{snap['written_by']}` "
            "for each file of `sensors/` (default magnetometer settings).*\n")


def _golden_value(value, digits: int) -> str:
    if isinstance(value, list):
        return ", ".join(_number(v, digits) for v in value) or "none"
    return value if isinstance(value, str) else _number(value, digits)


def _get(row: dict, key: str):
    """``row[key]``, where a dotted key reaches into nested dicts (None where absent)."""
    value = row
    for part in key.split("."):
        value = value.get(part) if isinstance(value, dict) else None
    return value


def _cell(row: dict, key: str, style) -> str:
    value = _get(row, key)
    if isinstance(value, list):
        return ", ".join(str(v) for v in value) or "none"
    if style == "s":
        return _seconds(value)
    if style == 0:
        return _number(value) if isinstance(value, (bool, float)) or value is None else str(value)
    return _number(value, style)


def markdown_table(rows: list[dict], columns) -> str:
    """A markdown table of ``rows`` with ``columns`` (key, header, format)."""
    lines = ["| " + " | ".join(header for _, header, _ in columns) + " |",
             "|" + " --- |" * len(columns)]
    lines += ["| " + " | ".join(_cell(row, key, style).replace("|", "\\|")
                                for key, _, style in columns) + " |" for row in rows]
    return "\n".join(lines)


def _snapshot(name: str) -> dict:
    path = FIGURES / f"{name}.json"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such figure snapshot (make bench writes it)")
    return json.loads(path.read_text(encoding="utf-8"))


def _bench_figure(name: str) -> str:
    rows_key = SOURCES.get(name, ("", "rows"))[1]
    source, rows_of, columns = EXTRA_TABLES.get(name, (name, lambda result: result[rows_key],
                                                       BENCH_TABLES.get(name)))
    snap = _snapshot(source)
    machine = snap["result"].get("machine", {})
    where = ", ".join(f"{k} {machine[k]}" for k in ("python", "numpy", "cpu_count") if k in machine)
    name = source
    return (markdown_table(rows_of(snap["result"]), columns)
            + f"\n\n*From `docs/figures/{name}.json`, written by `{snap['written_by']}`"
            + (f" ({where})" if where else "") + "."
            + (" Times compare only within one run." if name not in SOURCES else "") + "*\n")


def _golden_figure() -> str:
    goldens = {p.parent.name: json.loads(p.read_text(encoding="utf-8"))
               for p in sorted(DATA.glob("*/golden.json"))}
    columns = [("quantity", "quantity", 0)] + [(n, n, 0) for n in goldens]
    rows = []
    for key, words, digits in GOLDEN_ROWS:
        row = {"quantity": words}
        for name, golden in goldens.items():
            value = golden["quantities"].get(key, {}).get("value")
            row[name] = _golden_value(value, digits or 6)
        rows.append(row)
    return (markdown_table(rows, columns) + "\n\n*From `data/*/golden.json`, written by "
            "`make record-data` and checked by `make regress` (`whiskercal regress data`).*\n")


def _study_figure(dataset: str) -> str:
    path = DATA / dataset / "golden.json"
    if not path.is_file():
        raise KeyError(f"unknown figure study-{dataset}: no {path}")
    golden = json.loads(path.read_text(encoding="utf-8"))
    quantities, fit_args = golden["quantities"], " ".join(golden["pipeline"]["fit_args"])
    depths = sorted({key.split("[")[1].split("mm]")[0] for key in quantities
                     if key.startswith("study.trial[")}, key=float)
    def trial(depth: str, key: str):
        return quantities.get(f"study.trial[{depth}mm].{key}", {}).get("value")

    rows = [{"depth": depth, **{key: trial(depth, key) for key, _, _ in STUDY_COLUMNS[1:]}}
            for depth in depths]
    target = quantities["study.target.z_uT"]["value"]
    depth = quantities["study.target.depth_mm"]["value"]
    return (markdown_table(rows, STUDY_COLUMNS) + f"\n\nTarget chosen: {target:.0f} µT at "
            f"{depth:g} mm, through `whiskercal fit {fit_args}`. "
            f"*From `data/{dataset}/golden.json`, written by `make record-data` and checked by "
            "`make regress`.*\n")


def render(name: str) -> str:
    """The markdown a figure marker stands for."""
    if name == "recorded-datasets":
        return _golden_figure()
    if name.startswith("study-"):
        return _study_figure(name[len("study-"):])
    if name == "twin-describe":
        return _describe_figure()
    if name in BENCH_TABLES or name in EXTRA_TABLES:
        return _bench_figure(name)
    raise KeyError(f"unknown figure {name!r}; known: recorded-datasets, study-DATASET, "
                   f"twin-describe, {', '.join(BENCH_TABLES)}")


def _bench_result(bench_dir: Path, name: str) -> dict | None:
    """A tabled comparison's result from a bench directory (the sessions: sensor-family's
    ``sessions`` part), None where the bench did not write it."""
    source = bench_dir / ("sensor-family.json" if name == "sensor-sessions" else f"{name}.json")
    if not source.is_file():
        return None
    result = json.loads(source.read_text(encoding="utf-8"))
    if name != "sensor-sessions":
        return result
    return {**result["sessions"], "machine": result.get("machine", {})} \
        if "sessions" in result else None


def snapshot(bench_dir: Path) -> list[Path]:
    """Copy each tabled comparison's JSON from a bench directory into docs/figures/."""
    written = []
    for name in BENCH_TABLES:
        result = _bench_result(bench_dir, name)
        if result is None:
            continue
        command = SOURCES.get(name, ("whiskercal bench" + (" --quick" if result.get("quick")
                                                          else ""),))[0]
        payload = {"written_by": command, "comparison": name,
                   "snapshot_by": "make bench (scripts/docs_figures.py snapshot)",
                   "result": result}
        target = FIGURES / f"{name}.json"
        target.write_text(json.dumps(payload, indent=1, allow_nan=True) + "\n", encoding="utf-8")
        written.append(target)
    descriptions = sorted(bench_dir.glob("twin-describe-*.json"))
    if descriptions:
        payload = {"written_by": DESCRIBE_COMMAND, "comparison": "twin-describe",
                   "snapshot_by": "make bench (scripts/docs_figures.py snapshot)",
                   "result": {"sensors": [json.loads(p.read_text(encoding="utf-8"))
                                          for p in descriptions]}}
        target = FIGURES / "twin-describe.json"
        target.write_text(json.dumps(payload, indent=1, allow_nan=True) + "\n", encoding="utf-8")
        written.append(target)
    return written


# the tutorial's example outputs: what `make demo` printed at each step (scripts/demo.sh keeps
# them in OUT/transcript/), included in docs/walkthrough.md by pymdownx.snippets
TRANSCRIPTS = FIGURES / "walkthrough"
TRANSCRIPT_NAMES = ("collect-dry-run", "collect", "fit", "study-report", "report", "runtime")


def transcript(demo_dir: Path) -> list[Path]:
    """Copy the demo's transcript (OUT/transcript/NAME.txt) into docs/figures/walkthrough/."""
    missing = [n for n in TRANSCRIPT_NAMES if not (demo_dir / "transcript" / f"{n}.txt").is_file()]
    if missing:
        raise FileNotFoundError(f"{demo_dir}/transcript lacks {', '.join(missing)}: run make demo")
    TRANSCRIPTS.mkdir(exist_ok=True)
    written = []
    for name in TRANSCRIPT_NAMES:
        text = (demo_dir / "transcript" / f"{name}.txt").read_text(encoding="utf-8")
        target = TRANSCRIPTS / f"{name}.txt"
        target.write_text(text.rstrip("\n") + "\n", encoding="utf-8")
        written.append(target)
    return written


COMMANDS = {"snapshot": snapshot, "transcript": transcript}

if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in COMMANDS:
        sys.exit("usage: python scripts/docs_figures.py snapshot BENCH_DIR\n"
                 "       python scripts/docs_figures.py transcript DEMO_OUT")
    for path in COMMANDS[sys.argv[1]](Path(sys.argv[2])):
        print(f"wrote {path.relative_to(ROOT)}")
