"""``whiskercal bench``: speed against accuracy, Pareto charts and the stability map."""

from __future__ import annotations

import click

from whiskercal.bench.runner import COMPARISONS
from whiskercal.cli.app import App, echo_json, force_option, pass_app
from whiskercal.errors import WhiskercalError


class BenchFailed(WhiskercalError):
    """One or more comparisons raised; their errors are in bench.json."""


def _row_label(row: dict) -> str:
    return " ".join(str(row[k]) for k in ("method", "engine", "kind", "label", "probe",
                                           "degree", "samples_per_point") if k in row)


def _print(bench: dict, out: str) -> None:
    click.echo(f"wrote {out}/bench.json")
    for name, entry in bench["comparisons"].items():
        if entry["status"] != "ok":
            click.echo(f"{name:15s} FAILED  {entry['error']}")
            continue
        charts = ", ".join(entry["charts"]) or "-"
        click.echo(f"{name:15s} {entry['elapsed_s']:7.1f} s  charts: {charts}")
        for key, value in (entry.get("supports") or {}).items():
            if key not in ("rule", "silent_failures") and not isinstance(value, (dict, list)):
                click.echo(f"{'':17s}{key} = {value}")


@click.command("bench")
@click.option("--only", multiple=True, type=click.Choice(list(COMPARISONS)),
              help="Run only this comparison (repeatable) [default: all].")
@click.option("--quick", is_flag=True,
              help="A reduced run (fewer settings and samples): seconds, for tests and smoke checks.")
@click.option("--out", "out_dir", required=True, type=click.Path(file_okay=False),
              help="Directory for bench.json, one JSON per comparison and the PNG charts.")
@click.option("--json", "as_json", is_flag=True, help="Print bench.json's content as JSON.")
@force_option
@pass_app
def command(app: App, only: tuple[str, ...], quick: bool, out_dir: str, as_json: bool,
            force: bool) -> None:
    """Measure speed against accuracy and chart one against the other.

    Runs each comparison in one process (tip extraction, surface degree, collection settings,
    the twin's engines and speed, the stability map) and writes DIR/bench.json with the
    machine, each comparison's results and the defaults they support, plus Pareto charts (time
    per call on a log axis against error; the non-dominated front dashed; the default starred).
    Exits non-zero when a comparison failed (its error is in bench.json).
    """
    from whiskercal.bench.runner import run_bench, select
    from whiskercal.cli.progress import progress_bar

    with progress_bar(app, "comparisons", total=len(select(only)), as_json=as_json) as bar:
        current = {"name": ""}

        def on_start(name: str) -> None:
            current["name"] = name
            bar.step(name)

        def on_row(row: dict) -> None:
            bar.step(current["name"], f"{current['name']}: {_row_label(row)}")

        bench = run_bench(out_dir, only, quick, on_start if bar else None, on_row if bar else None,
                          force=force)
        if bar:
            bar.finish()
    if as_json:
        echo_json(bench)
    else:
        _print(bench, out_dir)
    failed = [name for name, entry in bench["comparisons"].items() if entry["status"] != "ok"]
    if failed:
        raise BenchFailed(f"comparison(s) failed: {', '.join(failed)} (see {out_dir}/bench.json)")
