"""``whiskercal shaft-study``: contacts anywhere on the shaft (``run``) and the localizer on them
(``report``)."""

from __future__ import annotations

import math
from pathlib import Path

import click

from whiskercal.atomic import refuse_existing, refuse_input_as_output
from whiskercal.cli.app import App, echo_json, force_option, pass_app


@click.group("shaft-study")
def command() -> None:
    """Localize contacts anywhere on the shaft from z and the known motion.

    `run` presses the rod onto the shaft at radial distances from the root and slides it along
    the whisker, recording z, the stage and (on the twin) the true contact; `report` runs the
    shaft localizer over every trial and measures it against the truth (docs/shaft.md).
    """


@command.command("run")
@click.option("--stage", "stage_url", required=True, envvar="WHISKERCAL_STAGE",
              help="Stage port: /dev/ttyUSB0 or sim://NAME/stage [env: WHISKERCAL_STAGE].")
@click.option("--sensor", "sensor_url", required=True, envvar="WHISKERCAL_SENSOR",
              help="Sensor port: /dev/ttyUSB1 or sim://NAME/sensor [env: WHISKERCAL_SENSOR].")
@click.option("--out", "out_path", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="The shaft study file to write (HDF5).")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=Path),
              help="TOML file overriding the defaults (whiskercal/shaftstudy/config.py).")
@click.option("--resume", is_flag=True, help="Continue a partial file; finished trials are kept.")
@click.option("--json", "as_json", is_flag=True, help="Print the run's summary as JSON.")
@click.option("--force", is_flag=True,
              help="Replace a finished shaft study in --out (the new file, written whole, is "
                   "renamed over it); a partial one is continued with --resume, never replaced.")
@pass_app
def run_command(app: App, stage_url: str, sensor_url: str, out_path: Path,
                config_path: Path | None, resume: bool, as_json: bool, force: bool) -> None:
    """Press and slide the rod at each radial distance and approach direction."""
    from whiskercal.shaftstudy.config import load_config
    from whiskercal.shaftstudy.run import run_shaft_study

    refuse_input_as_output(out_path, [config_path], "the shaft study file")
    summary = run_shaft_study(stage_url, sensor_url, out_path, load_config(config_path),
                              resume=resume, force=force)
    if as_json:
        echo_json(summary.__dict__)
        return
    click.echo(f"{out_path}: {len(summary.trials_done)} trials done, "
               f"{len(summary.trials_skipped)} kept from before")


@command.command("report")
@click.argument("study_path", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--artifact", "artifact_path", required=True,
              type=click.Path(dir_okay=False, path_type=Path),
              help="The calibration artifact (CAL.h5) whose surface localizes the contact.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              help="Directory for the figures [default: next to the study file].")
@click.option("--no-figures", is_flag=True, help="Skip drawing the PNG figures.")
@click.option("--json", "as_json", is_flag=True, help="Print the per-trial table as JSON.")
@force_option
def report_command(study_path: Path, artifact_path: Path, out_dir: Path | None, no_figures: bool,
                   as_json: bool, force: bool) -> None:
    """Localize every trial's contact and measure it against the twin's truth."""
    from whiskercal import runtime
    from whiskercal.shaftstudy.figures import figure_paths, write_figures
    from whiskercal.shaftstudy.report import build_report

    out_dir = out_dir or Path(study_path).parent
    if not no_figures:
        for output in figure_paths(out_dir):
            refuse_input_as_output(output, [study_path, artifact_path])
        refuse_existing(figure_paths(out_dir), force)
    report = build_report(study_path, runtime.load(artifact_path))
    if not no_figures:
        report.figures = write_figures(report.series, out_dir)
    if as_json:
        echo_json(report.as_dict())
        return
    click.echo(format_table(report))


def format_table(report) -> str:
    """The per-trial table as text (mm, ms)."""
    lines = [f"{'trial':<18} {'radial':>6} {'median':>7} {'final':>7} {'to<1mm':>7} "
             f"{'kind ok':>7} {'ms/smp':>6}",
             f"{'':<18} {'mm':>6} {'mm':>7} {'mm':>7} {'mm':>7} {'':>7} {'':>6}"]
    for row in report.rows:
        lines.append(f"{row.name:<18} {row.radial_mm:6.1f} {_mm(row.median_error_mm):>7} "
                     f"{_mm(row.final_error_mm):>7} {_mm(row.travel_to_1mm):>7} "
                     f"{row.kind_accuracy:7.1%} {row.ms_per_sample:6.3f}")
    lines += [f"figure: {path}" for path in report.figures]
    return "\n".join(lines)


def _mm(value: float) -> str:
    return "-" if value is None or math.isnan(value) else f"{value:.3f}"


@command.command("plane")
@click.argument("study_path", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--artifact", "artifact_path", required=True,
              type=click.Path(dir_okay=False, path_type=Path),
              help="The calibration artifact (CAL.h5) whose surface localizes the contact.")
@click.option("--json", "as_json", is_flag=True, help="Print the rows as JSON.")
@pass_app
def plane_command(app: App, study_path: Path, artifact_path: Path, as_json: bool) -> None:
    """Run the shaft localizer over a flat-plane study's shaft (tangential) contacts (twin only)."""
    from whiskercal import runtime
    from whiskercal.shaftstudy.plane_phases import plane_phases

    rows = plane_phases(study_path, runtime.load(artifact_path))
    if as_json:
        echo_json({"study": str(study_path), "trials": [row.as_dict() for row in rows]})
        return
    if not rows:
        click.echo(f"{study_path}: no trial has contacts on the shaft")
    for row in rows:
        click.echo(f"depth {row.depth_mm:g} mm: {row.samples_on_shaft} samples on the shaft, "
                   f"called shaft {row.called_shaft:.1%}, tip {row.called_tip:.1%}, localized "
                   f"{row.localized_share:.1%}, median error {_mm(row.median_error_mm)} mm, "
                   f"rough point {_mm(row.rough_median_error_mm)} mm")


@command.command("static")
@click.argument("study_path", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--grid", "grid_path", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="The raw grid (RAW.h5) the calibration was fitted to: both field axes.")
@click.option("--artifact", "artifact_path", required=True,
              type=click.Path(dir_okay=False, path_type=Path),
              help="The calibration artifact (CAL.h5) of the motion-based localizer.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              help="Directory for shaft_static_yz.png [default: no figure].")
@click.option("--json", "as_json", is_flag=True, help="Print the rows as JSON.")
@pass_app
def static_command(app: App, study_path: Path, grid_path: Path, artifact_path: Path,
                   out_dir: Path | None, as_json: bool) -> None:
    """Localize each sample on its own from Y and Z (no motion), against the motion-based one."""
    from whiskercal import runtime
    from whiskercal.shaftstudy.static_yz import static_figure, static_study

    rows = static_study(grid_path, study_path, runtime.load(artifact_path))
    figure = None
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        figure = str(static_figure(rows, out_dir / "shaft_static_yz.png"))
    if as_json:
        echo_json({"study": str(study_path), "trials": [row.as_dict() for row in rows],
                   "figure": figure})
        return
    for row in rows:
        click.echo(f"{row.name:<18} {row.samples:5d} samples: static median "
                   f"{_mm(row.static_median_mm)} mm (p90 {_mm(row.static_p90_mm)}), motion "
                   f"{_mm(row.motion_median_mm)} mm")
