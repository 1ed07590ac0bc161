"""What every command shares: the application object, JSON output and the one abort path."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from typing import Any, NoReturn

import click

from whiskercal.jsontools import jsonable


@dataclass
class App:
    """Shared state handed to every command through ``@click.pass_obj``."""

    debug: bool = False
    quiet: bool = False

    @property
    def interactive(self) -> bool:
        """True when progress may be drawn: a terminal on stderr, not CI, not --quiet."""
        import os

        return not self.quiet and sys.stderr.isatty() and not os.environ.get("CI")


def abort(message: str, code: int = 1) -> NoReturn:
    """End the command with one line on stderr and a non-zero exit code."""
    click.echo(f"error: {message}", err=True)
    sys.exit(code)


def echo_json(payload: Any) -> None:
    """Print one JSON document on stdout (numpy values converted)."""
    click.echo(json.dumps(payload, default=jsonable, indent=2, sort_keys=False))


pass_app = click.make_pass_decorator(App, ensure=True)

# The one rule for outputs: an existing one is refused; --force replaces it atomically.
force_option = click.option("--force", is_flag=True,
                            help="Replace outputs that exist already (each written whole, then "
                            "renamed over the old one).")


def given_options(names) -> list[str]:
    """The long names (``--mount``) of the current command's parameters among ``names`` that the
    user gave, on the command line or through the environment: click's parameter source, so an
    option given at its default value counts as given."""
    context = click.get_current_context()
    given = []
    for param in context.command.params:
        source = context.get_parameter_source(param.name)
        if param.name in names and source not in (None, click.core.ParameterSource.DEFAULT):
            given.append(max(param.opts, key=len))
    return given
