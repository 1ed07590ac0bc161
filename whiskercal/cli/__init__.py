"""The ``whiskercal`` command line.

Each subcommand lives in its own module under ``whiskercal/cli/commands/`` and is imported only
when it runs, so ``--help`` and simple commands start fast. A module ``optimal_depth.py`` that
defines a click command or group named ``command`` becomes ``whiskercal optimal-depth``.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys

import click

from whiskercal import __version__
from whiskercal.cli.app import App, abort
from whiskercal.errors import WhiskercalError

from whiskercal.cli import commands as _commands_package


def _command_modules() -> dict[str, str]:
    """Command name -> module name, from the files in whiskercal/cli/commands/."""
    found = pkgutil.iter_modules(_commands_package.__path__)
    return {info.name.replace("_", "-"): f"{_commands_package.__name__}.{info.name}"
            for info in found if not info.name.startswith("_")}


class LazyGroup(click.Group):
    """A group whose subcommands are imported on first use."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(_command_modules())

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        module_name = _command_modules().get(name)
        if module_name is None:
            return None
        return importlib.import_module(module_name).command

    def make_context(self, info_name, args, parent=None, **extra) -> click.Context:
        try:
            return super().make_context(info_name, args, parent, **extra)
        except click.UsageError as error:
            _usage_error(error)

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except click.UsageError as error:
            _usage_error(error)
        except WhiskercalError as error:
            if ctx.obj is not None and ctx.obj.debug:
                raise
            abort(str(error), error.exit_code)
        except KeyboardInterrupt:
            abort("interrupted", 130)


def _usage_error(error: click.UsageError) -> None:
    """click's usage error as the project's one line, naming the ``--help`` that explains it
    (its usage and "Try" lines would make three); a group called bare still shows its help."""
    if isinstance(error, click.exceptions.NoArgsIsHelpError):
        raise error
    words = error.ctx.command_path.split()[1:] if error.ctx is not None else []
    path = " ".join(["whiskercal", *words])  # the program's name, however it was started
    abort(f"{error.format_message().rstrip('.')}; see '{path} --help'", error.exit_code)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="whiskercal")
@click.option("--debug", is_flag=True, envvar="WHISKERCAL_DEBUG",
              help="Show full tracebacks for errors [env: WHISKERCAL_DEBUG].")
@click.option("-q", "--quiet", is_flag=True, help="No progress output on stderr.")
@click.pass_context
def cli(ctx: click.Context, debug: bool, quiet: bool) -> None:
    """Calibrate and characterize magnetically transduced whisker sensors.

    The calibration pipeline: `collect` a raw grid dataset from the stage and
    sensor, `fit` it into a calibration artifact, run the `optimal-depth` study
    to choose the deflection target, and load the artifact on the robot with
    `whiskercal.runtime`. Every device URL may be a real serial port
    (/dev/ttyUSB0) or the digital twin (sim://NAME/stage, sim://NAME/sensor).

    Units everywhere: mm, s, µT, rad, N.
    """
    ctx.obj = App(debug=debug, quiet=quiet)


def main() -> None:
    """Console-script entry point."""
    cli(prog_name="whiskercal")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
