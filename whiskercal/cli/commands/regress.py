"""``whiskercal regress``: every stage recomputed on the recorded datasets, against golden results."""

from __future__ import annotations

from pathlib import Path

import click

from whiskercal.cli.app import App, abort, echo_json, pass_app


@click.command("regress")
@click.argument("data_dir", type=click.Path(path_type=Path))
@click.option("--update", is_flag=True,
              help="Rewrite each dataset's golden.json with the recomputed results (on purpose: "
              "after a deliberate change of method) and list what changed.")
@click.option("--json", "as_json", is_flag=True, help="Print the results as JSON.")
@pass_app
def command(app: App, data_dir: Path, update: bool, as_json: bool) -> None:
    """Recompute fit, lookup and study report on recorded data; compare with golden results.

    DATA_DIR holds dataset directories (raw_grid.h5, plane_study.h5, golden.json), or is one.
    Each quantity must stay within the tolerance its golden file states; the command exits
    non-zero naming every quantity that moved and by how much.
    """
    from whiskercal.cli.progress import progress_bar
    from whiskercal.regress import find_datasets, regress

    with progress_bar(app, "datasets", total=len(find_datasets(data_dir)), as_json=as_json) as bar:
        # the steps are named "<dataset>: <stage>": a new dataset means the previous one is done
        say = (lambda message: bar.step(message.split(":")[0], message)) if bar else None
        results = regress(data_dir, update=update, say=say)
        if bar:
            bar.finish()
    moved = [(r.name, c) for r in results for c in r.changes]
    if as_json:
        echo_json({"data_dir": str(data_dir), "update": update, "ok": update or not moved,
                   "datasets": [r.as_dict() for r in results]})
    else:
        click.echo("\n".join(_text_lines(results, update)))
    if moved and not update:
        names = ", ".join(f"{dataset}:{change.name}" for dataset, change in moved[:5])
        more = f" and {len(moved) - 5} more" if len(moved) > 5 else ""
        abort(f"{len(moved)} quantit{'y' if len(moved) == 1 else 'ies'} moved beyond tolerance: "
              f"{names}{more}")


def _text_lines(results, update: bool) -> list[str]:
    lines = []
    for result in results:
        head = f"{result.name}: {result.quantities} quantities, {result.elapsed_s:.1f} s"
        if result.created:
            lines.append(f"{head}: golden.json created")
            continue
        if update:
            state = (f"golden.json rewritten, {len(result.changes)} changed" if result.updated
                     else "golden.json unchanged")
        else:
            state = (f"{len(result.changes)} moved" if result.changes
                     else "all within tolerance")
        lines.append(f"{head}: {state}")
        lines += [f"  {change.describe()}" for change in result.changes]
        if result.inputs_changed:
            lines.append(f"  note: recorded file(s) differ from the ones the golden results "
                         f"came from: {', '.join(result.inputs_changed)}")
    return lines
