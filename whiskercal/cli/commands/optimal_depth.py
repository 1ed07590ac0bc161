"""``whiskercal optimal-depth``: the flat-plane study (``run``) and its analysis (``report``)."""

from __future__ import annotations

from pathlib import Path

import click

from whiskercal.atomic import refuse_existing, refuse_input_as_output
from whiskercal.cli.app import App, abort, echo_json, force_option, pass_app


@click.group("optimal-depth")
def command() -> None:
    """Choose the deflection target with the flat-plane study.

    `run` slides a flat plane past the whisker at several contact distances while recording the
    sensor; `report` localizes the tip in every trial with a calibration artifact, measures the
    error against the plane, flags slips and tangential contact, chooses the target and writes it
    into a new version of the artifact.
    """


@command.command("run")
@click.option("--stage", "stage_url", required=True, envvar="WHISKERCAL_STAGE",
              help="Stage port: /dev/ttyUSB0 or sim://NAME/stage?scene=plane [env: WHISKERCAL_STAGE].")
@click.option("--sensor", "sensor_url", required=True, envvar="WHISKERCAL_SENSOR",
              help="Sensor port: /dev/ttyUSB1 or sim://NAME/sensor [env: WHISKERCAL_SENSOR].")
@click.option("--out", "out_path", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="The study file to write (HDF5).")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=Path),
              help="TOML file overriding the documented defaults (whiskercal/study/default_study.toml).")
@click.option("--resume", is_flag=True, help="Continue a partial study file; finished trials are kept.")
@click.option("--json", "as_json", is_flag=True, help="Print the run's summary as JSON.")
@click.option("--force", is_flag=True,
              help="Replace a finished study in --out (the new file, written whole, is renamed "
                   "over it); a partial study is continued with --resume, never replaced.")
@pass_app
def run_command(app: App, stage_url: str, sensor_url: str, out_path: Path, config_path: Path | None,
                resume: bool, as_json: bool, force: bool) -> None:
    """Run the flat-plane study: first contact, then one constant-velocity slide per depth."""
    from whiskercal.cli.progress import progress_bar
    from whiskercal.study.config import load_config
    from whiskercal.study.run import run_study

    refuse_input_as_output(out_path, [config_path], "the study file")
    config = load_config(config_path)
    with progress_bar(app, "trials", description="study", as_json=as_json) as bar:
        summary = run_study(stage_url, sensor_url, out_path, config, resume=resume,
                            progress=bar.update if bar else None, force=force)
    result = {**summary.__dict__, "wall_time_s": round(summary.wall_time_s, 3)}
    for warning in summary.warnings:
        click.echo(f"warning: {warning}", err=True)
    if as_json:
        echo_json(result)
        return
    click.echo(f"{out_path}: {len(summary.trials_done)} trials done, "
               f"{len(summary.trials_skipped)} kept from before; "
               f"stage time {summary.stage_time_s:.1f} s, wall time {result['wall_time_s']:.1f} s")


@command.command("report")
@click.argument("study_path", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--artifact", "artifact_path", required=True,
              type=click.Path(dir_okay=False, path_type=Path),
              help="The calibration artifact (CAL.h5) that localizes the tip.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              help="Directory for the figures and the artifact with the target [default: next to STUDY].")
@click.option("--out-artifact", "out_artifact", type=click.Path(dir_okay=False, path_type=Path),
              help="Where to write the artifact with the target [default: DIR/<CAL>-target.h5].")
@click.option("--no-figures", is_flag=True, help="Skip drawing the PNG figures.")
@click.option("--allow-missing", is_flag=True,
              help="Analyse a study that lacks planned trials (they count as failing).")
@click.option("--margin-weight", "margin_weight_mm", type=float, default=0.1, show_default=True,
              help="Target rule: penalty (mm) for a depth one step from a failing one.")
@click.option("--tie", "tie_mm", type=float, default=0.05, show_default=True,
              help="Target rule: scores within this (mm) of the lowest tie, and the shallowest "
                   "tied depth wins.")
@click.option("--allow-other-sensor", is_flag=True,
              help="Analyse a study of another sensor id, or planned for another whisker reach, "
              "than the artifact's, with a warning; refused otherwise.")
@click.option("--json", "as_json", is_flag=True, help="Print the per-trial table and the choice as JSON.")
@force_option
def report_command(study_path: Path, artifact_path: Path, out_dir: Path | None,
                   out_artifact: Path | None, no_figures: bool, allow_missing: bool,
                   margin_weight_mm: float, tie_mm: float, allow_other_sensor: bool,
                   as_json: bool, force: bool) -> None:
    """Analyse a study: errors, slips, failing trials; choose and write the target.

    STUDY_PATH is the file `optimal-depth run` wrote.
    """
    from whiskercal import runtime
    from whiskercal.artifacts.cross_check import check_study_for_target
    from whiskercal.checks import number
    from whiskercal.study.artifact_target import target_artifact_path, write_target
    from whiskercal.study.figures import figure_paths, write_figures
    from whiskercal.study.report import build_report

    number(margin_weight_mm, "--margin-weight", low=0, unit="mm")  # before any work
    number(tie_mm, "--tie", low=0, unit="mm")
    out_dir = out_dir or Path(study_path).parent
    destination = out_artifact or target_artifact_path(artifact_path, out_dir)
    outputs = [destination] + ([] if no_figures else figure_paths(out_dir))
    for output in outputs:
        refuse_input_as_output(output, [study_path, artifact_path])  # before any work
    refuse_existing(outputs, force)
    calibration = runtime.load(artifact_path)
    for warning in check_study_for_target(artifact_path, study_path, allow_other_sensor):
        click.echo(f"warning: {warning}", err=True)
    report = build_report(study_path, calibration, margin_weight_mm=margin_weight_mm,
                          allow_missing=allow_missing, tie_mm=tie_mm)
    if not no_figures:
        report.figures = write_figures(report.series, report.rows, out_dir)
    if report.choice is not None:
        report.artifact_out = write_target(artifact_path, destination, report.choice,
                                           report.study.sha256)
    if as_json:
        echo_json(report.as_dict())
    else:
        click.echo(format_table(report))
    if report.choice is None:
        abort(f"no target written: {report.no_target}")


def format_table(report) -> str:
    """The per-trial table and the choice as text."""
    lines = [f"{'depth':>6} {'contact':>7} {'median z':>9} {'raw mean±std':>14} "
             f"{'filt mean±std':>14} {'vs true tip':>11} {'slips':>5}  verdict",
             f"{'mm':>6} {'':>7} {'µT':>9} {'mm':>14} {'mm':>14} {'mm':>11}"]
    for row in report.rows:
        verdict = "FAIL: " + "; ".join(row.reasons) if row.failing else "ok"
        lines.append(f"{row.depth_mm:6g} {row.contact_fraction:7.0%} {row.median_z_uT:9.0f} "
                     f"{row.raw_mean_mm:6.3f}±{row.raw_std_mm:<7.3f} "
                     f"{row.filtered_mean_mm:6.3f}±{row.filtered_std_mm:<7.3f} "
                     f"{row.true_filtered_mean_mm:11.3f} {row.n_slips:5d}  {verdict}")
    if report.choice is not None:
        choice = report.choice
        scores = ", ".join(f"{depth:g} mm {score:.3f}" for depth, score in choice.scores_mm.items())
        lines += ["", f"target: {choice.z_uT:.0f} µT at {choice.depth_mm:g} mm",
                  f"rule:   {choice.rule}", f"scores: {scores} (mm)", f"why:    {choice.reason}"]
        if report.artifact_out:
            lines.append(f"wrote:  {report.artifact_out}")
    else:
        lines += ["", f"no target: {report.no_target}"]
    lines += [f"figure: {path}" for path in report.figures]
    return "\n".join(lines)
