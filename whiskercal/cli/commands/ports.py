"""``whiskercal ports``: list serial ports and recognize Arduino boards by their USB ids."""

from __future__ import annotations

import click

from whiskercal.cli.app import echo_json


@click.command("ports")
@click.option("--json", "as_json", is_flag=True, help="Print the ports as a JSON list.")
def command(as_json: bool) -> None:
    """List serial ports; name Arduino, CH340, FTDI and CP210x USB bridges.

    The twin's boards are not listed: open them as sim://NAME/stage and sim://NAME/sensor, or
    start `whiskercal sim serve` for pseudo-terminals.
    """
    from whiskercal.rig.ports import list_ports

    ports = list_ports()
    if as_json:
        echo_json([p.as_dict() for p in ports])
        return
    if not ports:
        click.echo("no serial ports found (for the twin use sim://NAME/stage and sim://NAME/sensor)")
        return
    for port in ports:
        ids = f"{port.vid:04X}:{port.pid:04X}" if port.vid is not None else "-"
        click.echo(f"{port.device:20s} {ids:10s} {port.recognized or port.description}")
