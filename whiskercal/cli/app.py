"""What every command shares: the application object, JSON output and the one abort path."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from typing import Any, NoReturn

import click
import numpy as np


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


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serializable: {type(value).__name__}")


def echo_json(payload: Any) -> None:
    """Print one JSON document on stdout (numpy values converted)."""
    click.echo(json.dumps(payload, default=_jsonable, indent=2, sort_keys=False))


pass_app = click.make_pass_decorator(App, ensure=True)
