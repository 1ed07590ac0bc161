"""Assemble the calibration report: one self-contained HTML file per calibration artifact.

Sections: the summary (what shipped, in words and units, then the evidence), grid and fit
residuals (with the raw grid), level sets and traced tips, the lookup and its error (against the
twin's truth when the raw grid has one), the flat-plane study (with a study file), the
speed-accuracy charts (with a bench directory), provenance.
"""

from __future__ import annotations

import json
import platform
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from whiskercal import __version__, atomic
from whiskercal.artifacts.calibration import (CalibrationData, lookup_of, read_calibration,
                                              surface_of)
from whiskercal.artifacts.h5io import now_iso, sha256_file
from whiskercal.atomic import inside, refuse_input_as_output
from whiskercal.errors import ArtifactError, UsageError
from whiskercal.paths import ensure_dir
from whiskercal.report import figures, outcome
from whiskercal.report.html import Section, esc, figure, key_values, paragraph, render, table

if TYPE_CHECKING:
    from whiskercal.fit.truth import TruthComparison


def _summary(data: CalibrationData) -> Section:
    """What shipped first (tip model, table, threshold, warnings), then the evidence."""
    body = key_values(outcome.shipped(data)) + "<h3>Warnings fit gave</h3><ul>"
    body += "".join(f"<li>{esc(w)}</li>" for w in outcome.warnings_lines(data)) + "</ul>"
    surface = {"surface": f"degree {data.degree}, {data.coordinates}",
               "lookup": f"{len(data.lookup_z_uT)} samples, {data.lookup_kind}, z "
                         f"{data.lookup_z_uT[0]:.0f} .. {data.lookup_z_uT[-1]:.0f} µT",
               "level-set tracer": data.tracer, "trace length (mm)": data.trace_length_mm}
    body += "<h3>Evidence</h3>" + key_values({**surface, **outcome.evidence(data)})
    return Section("Summary", body)


def _fit_options(data: CalibrationData):
    """The options the artifact was fitted with (its config), else ones matching its surface."""
    from dataclasses import fields

    from whiskercal.model.calibrate import CalibrationOptions

    stored = data.config.get("options", {}) if isinstance(data.config, dict) else {}
    known = {f.name for f in fields(CalibrationOptions)}
    options = {k: tuple(v) if isinstance(v, list) else v for k, v in stored.items() if k in known}
    options.setdefault("degree", data.degree)
    options.setdefault("coordinates", data.coordinates)
    options.setdefault("trace_length_mm", data.trace_length_mm)
    return CalibrationOptions(**options)


def _residuals(data: CalibrationData, raw) -> Section:
    if raw is None:
        return Section("Grid and fit residuals", paragraph("No raw grid given (--raw): the grid "
                                                           "and its residuals are not shown."))
    from whiskercal.fit import calibrate_raw
    from whiskercal.fit.run import level_set_points

    # refit with the artifact's own options: the points it used, moved onto the shaft as it did
    # (the grid's own points: a tip sweep is the mechanics' alone)
    raw = level_set_points(raw)
    refit = calibrate_raw(raw, _fit_options(data))
    residual = surface_of(data)(refit.contact_points_mm) - refit.z_uT
    unused = raw.rod_center_mm[~refit.used]
    rms = float(np.sqrt(np.mean(residual ** 2)))
    note = paragraph(f"{int(refit.used.sum())} of {len(raw.z_uT)} grid points were fitted (the others, "
                     f"grey crosses, carry no contact or lie inside the trace's entry circle); the "
                     f"rod centres are moved by the rod radius ({raw.rod_radius_mm:g} mm) onto the "
                     f"shaft. Residual RMS {rms:.4f} µT. {_positions_note(raw)}")
    png = figures.grid_residuals(data, refit.contact_points_mm, residual, unused)
    return Section("Grid and fit residuals",
                   note + figure(png, "grid contact points coloured by the fit residual"))


def _positions_note(raw) -> str:
    """Whether the grid's positions were measured, or only commanded (a stage without encoders)."""
    if raw.encoders == "none":
        return ("Open loop: the stage had no encoders, so the positions are the commanded ones "
                "and a missed step would have gone unnoticed.")
    if raw.encoders == "unknown":
        return "Whether the stage's positions were measured is not recorded in this file."
    return "The positions were measured by the stage's encoders."


def _truth(data: CalibrationData, raw) -> TruthComparison | None:
    """The artifact's lookup against the twin's true tips: from the twin sensor of a raw grid
    that has /truth, else from the truth stored in the artifact; None without either."""
    from whiskercal.fit.truth import compare_lookup, lookup_vs_twin_truth

    lookup = lookup_of(data)
    found = lookup_vs_twin_truth(raw, lookup) if raw is not None else None
    if found is None and data.truth and "z_uT" in data.truth and "true_tip_mm" in data.truth:
        found = compare_lookup(lookup, data.truth["z_uT"], data.truth["true_tip_mm"])
    return found


def _lookup(data: CalibrationData, raw) -> Section:
    truth = _truth(data, raw)
    note = paragraph("Against the twin's true tips (tip contact)." if truth is not None else
                     "No ground truth: the raw grid has no /truth (a real rig).")
    return Section("Lookup z → tip", note + figure(figures.lookup_curve(data, truth),
                                                   "lookup curve and its error"))


def _level_sets(data: CalibrationData) -> Section:
    return Section("Level sets and traced tips",
                   figure(figures.level_sets(data), "level sets traced from the root"))


STUDY_COLUMNS = ("depth_mm", "contact_fraction", "median_z_uT", "raw_mean_mm", "filtered_mean_mm",
                 "filtered_std_mm", "n_slips", "tangential", "failing", "true_filtered_mean_mm")


def _study(cal_path: Path, study_path: Path | None) -> Section | None:
    if study_path is None:
        return None
    from whiskercal.runtime import load
    from whiskercal.study.figures import write_figures
    from whiskercal.study.report import build_report

    report = build_report(study_path, load(cal_path), allow_missing=True)
    rows = [dict(r.as_dict(), reasons="; ".join(r.reasons)) for r in report.rows]
    body = table(rows, STUDY_COLUMNS + ("reasons",))
    body += paragraph(f"chosen target: {report.choice.as_dict()}" if report.choice
                      else f"no target: {report.no_target}")
    with tempfile.TemporaryDirectory() as scratch:
        for path in write_figures(report.series, report.rows, Path(scratch)):
            body += figure(path.read_bytes(), f"study: {path.stem.replace('_', ' ')}")
    return Section("Flat-plane study", body)


def _bench(bench_dir: Path | None) -> Section | None:
    if bench_dir is None:
        return None
    index = bench_dir / "bench.json"
    if not index.is_file():
        raise UsageError(f"{bench_dir} holds no bench.json: run `whiskercal bench --out {bench_dir}`")
    try:
        bench = json.loads(index.read_text(encoding="utf-8"))
    except ValueError as error:
        raise UsageError(f"{index} is not a readable bench result ({error}): run "
                         f"`whiskercal bench --out {bench_dir}` again") from None
    body = paragraph(f"measured {bench.get('created')} on {bench.get('machine', {}).get('processor')} "
                     f"({bench.get('machine', {}).get('cpu_count')} cores), quick={bench.get('quick')}")
    for name, entry in bench.get("comparisons", {}).items():
        body += f"<h3>{name}</h3>"
        if entry.get("status") != "ok":
            body += paragraph(f"failed: {entry.get('error')}", "fail")
            continue
        supports = {k: v for k, v in (entry.get("supports") or {}).items()
                    if not isinstance(v, (dict, list))}
        body += key_values(supports) if supports else ""
        for chart in entry.get("charts", []):
            chart_path = inside(bench_dir, str(chart), f"{index}: the chart")  # named by a data file
            if chart_path.is_file():
                body += figure(chart_path.read_bytes(), f"{name}: {chart}")
    return Section("Speed against accuracy", body)


def _provenance(cal_path: Path, data: CalibrationData, raw, study_path, bench_dir) -> Section:
    files = [{"file": "calibration", "path": str(cal_path), "sha256": sha256_file(cal_path)}]
    if raw is not None:
        files.append({"file": "raw grid", "path": raw.path, "sha256": raw.sha256})
    if study_path is not None:
        files.append({"file": "study", "path": str(study_path), "sha256": sha256_file(study_path)})
    if bench_dir is not None:
        files.append({"file": "bench", "path": str(bench_dir / "bench.json"),
                      "sha256": sha256_file(bench_dir / "bench.json")})
    body = table(files, ["file", "path", "sha256"])
    pairs = {"calibration created": data.created, "calibration whiskercal version": data.whiskercal_version,
             "calibration schema version": data.schema_version,
             **{f"input {k}": v for k, v in data.inputs.items()},
             **{f"version {k}": v for k, v in data.config.get("versions", {}).items()},
             "report created": now_iso(), "report whiskercal version": __version__,
             "report python": platform.python_version()}
    if raw is not None and raw.sensor_id != data.sensor_id:
        body += paragraph(f"the raw grid's sensor {raw.sensor_id!r} is not the calibration's "
                          f"{data.sensor_id!r}", "fail")
    return Section("Provenance", body + key_values(pairs))


def build_html(cal_path: str | Path, raw_path: str | Path | None = None,
               study_path: str | Path | None = None, bench_dir: str | Path | None = None) -> str:
    """The report's HTML for a calibration artifact and the optional raw grid, study and bench."""
    from whiskercal.artifacts.raw_grid import read_raw_grid

    cal_path = Path(cal_path)
    data = read_calibration(cal_path)
    raw = read_raw_grid(raw_path) if raw_path is not None else None
    study_path = Path(study_path) if study_path is not None else None
    bench_dir = Path(bench_dir) if bench_dir is not None else None
    if study_path is not None and not study_path.is_file():
        raise ArtifactError(f"{study_path}: no such study file")
    sections = [_summary(data), _residuals(data, raw), _level_sets(data), _lookup(data, raw),
                _study(cal_path, study_path), _bench(bench_dir),
                _provenance(cal_path, data, raw, study_path, bench_dir)]
    return render(f"whiskercal calibration report: {data.sensor_id}", [s for s in sections if s])


def write_report(out_path: str | Path, cal_path, raw_path=None, study_path=None, bench_dir=None) -> Path:
    """Write the report to ``out_path`` (replaced atomically; refused when it is one of the
    files the report reads)."""
    out_path = Path(out_path)
    refuse_input_as_output(out_path, report_inputs(cal_path, raw_path, study_path, bench_dir),
                           "the report")
    page = build_html(cal_path, raw_path, study_path, bench_dir)
    ensure_dir(out_path.parent)
    return atomic.write_text(out_path, page)


def report_inputs(cal_path, raw_path=None, study_path=None, bench_dir=None) -> list[Path]:
    """Every file the report reads: the artifact, raw grid, study, bench.json and its charts."""
    inputs = [Path(p) for p in (cal_path, raw_path, study_path) if p is not None]
    if bench_dir is not None and Path(bench_dir).is_dir():
        inputs += [Path(bench_dir) / "bench.json", *sorted(Path(bench_dir).glob("*.png"))]
    return inputs
