"""``whiskercal twin``: inspect and validate the digital twin.

More subcommands join the group from modules ``whiskercal/cli/commands/_twin_<name>.py`` that
define a click command named ``command`` (the leading underscore keeps them off the top level).
"""

from __future__ import annotations

import importlib
import pkgutil

import click

from whiskercal.cli.app import abort, echo_json

_PREFIX = "_twin_"


def _extra_modules() -> dict[str, str]:
    from whiskercal.cli import commands

    return {info.name[len(_PREFIX):].replace("_", "-"): f"{commands.__name__}.{info.name}"
            for info in pkgutil.iter_modules(commands.__path__)
            if info.name.startswith(_PREFIX)}


class TwinGroup(click.Group):
    """The built-in subcommands plus those found in ``_twin_<name>.py`` modules."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(set(super().list_commands(ctx)) | set(_extra_modules()))

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        found = super().get_command(ctx, name)
        if found is not None:
            return found
        module = _extra_modules().get(name)
        return importlib.import_module(module).command if module else None


@click.group("twin", cls=TwinGroup)
def command() -> None:
    """Inspect and validate the digital twin (whisker mechanics, contacts, scenes)."""


@command.command("cantilever")
@click.option("--alpha", type=float, required=True,
              help="Load parameter P·L²/EI of the tip load, in [0, 50].")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def cantilever(alpha: float, as_json: bool) -> None:
    """Tip of a rigid-root cantilever under a tip load perpendicular to its axis.

    Prints x (along the undeformed axis) and y (in the load's direction) as fractions of the
    length L, from the twin's elastica solver.
    """
    from whiskercal.twin.cantilever import cantilever_tip

    x, y = cantilever_tip(alpha)
    if as_json:
        echo_json({"alpha": alpha, "x": x, "y": y})
        return
    click.echo(f"alpha = {alpha:g}: tip x/L = {x:.8f}, y/L = {y:.8f}")


@command.command("validate")
@click.option("--json", "as_json", is_flag=True, help="Print the checks as JSON.")
def validate(as_json: bool) -> None:
    """Check the mechanics against independent references; exit non-zero on any failure.

    Cantilever tips against Bisshopp & Drucker's closed form, the rigid-root limit, equilibrium
    residuals of rod, plane and polygon solves re-integrated by an independent ODE solver, and
    the friction cone along a slide.
    """
    from whiskercal.twin.validation import run_all

    checks = run_all()
    if as_json:
        echo_json({"ok": all(c.ok for c in checks),
                   "checks": [{"name": c.name, "value": c.value, "limit": c.limit,
                               "ok": c.ok, "detail": c.detail} for c in checks]})
    else:
        width = max(len(c.name) for c in checks)
        click.echo(f"{'check':{width}s}  {'value':>11s}  {'limit':>9s}  result")
        for c in checks:
            click.echo(f"{c.name:{width}s}  {c.value:11.3e}  {c.limit:9.1e}  "
                       f"{'ok' if c.ok else 'FAIL'}  {c.detail}")
    failed = [c for c in checks if not c.ok]
    if failed:
        abort(f"{len(failed)} of {len(checks)} mechanics checks failed.")
