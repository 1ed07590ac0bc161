"""Every command has help; --version and error paths behave."""

import json

import click
import pytest
from click.testing import CliRunner

from whiskercal import __version__
from whiskercal.cli import cli


def _all_commands(group: click.Group, ctx: click.Context, prefix=()):
    for name in group.list_commands(ctx):
        command = group.get_command(ctx, name)
        yield prefix + (name,), command
        if isinstance(command, click.Group):
            yield from _all_commands(command, ctx, prefix + (name,))


def test_version_option():
    result = CliRunner().invoke(cli, ["--version"], catch_exceptions=False)
    assert result.exit_code == 0
    assert __version__ in result.output


def test_version_json():
    result = CliRunner().invoke(cli, ["version", "--json"], catch_exceptions=False)
    assert json.loads(result.output)["whiskercal"] == __version__


@pytest.mark.parametrize("path", [p for p, _ in _all_commands(cli, click.Context(cli))],
                         ids=lambda p: " ".join(p))
def test_every_command_has_help(path):
    command = dict(_all_commands(cli, click.Context(cli)))[path]
    assert command.help and command.help.strip(), f"{' '.join(path)} has no help text"
    result = CliRunner().invoke(cli, [*path, "--help"], catch_exceptions=False)
    assert result.exit_code == 0
    assert "Usage:" in result.output


def test_unknown_command_fails():
    result = CliRunner().invoke(cli, ["no-such-command"])
    assert result.exit_code != 0


def test_an_output_directory_that_cannot_be_made_is_one_line(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    result = CliRunner().invoke(cli, ["bench", "--only", "field-speed", "--out", str(blocker / "out")])
    assert result.exit_code == 2
    assert result.output.strip() == (f"error: cannot create the directory {blocker / 'out'}: "
                                     "Not a directory")
