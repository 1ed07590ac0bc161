"""``whiskercal version``: versions of the toolchain, Python and the numerical libraries."""

from __future__ import annotations

import platform

import click

from whiskercal import __version__
from whiskercal.cli.app import echo_json


@click.command("version")
@click.option("--json", "as_json", is_flag=True, help="Print the versions as JSON.")
def command(as_json: bool) -> None:
    """Show the versions of whiskercal, Python and the numerical libraries."""
    import h5py
    import numpy
    import scipy

    versions = {
        "whiskercal": __version__,
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "h5py": h5py.__version__,
    }
    if as_json:
        echo_json(versions)
        return
    for name, version in versions.items():
        click.echo(f"{name:12s} {version}")
