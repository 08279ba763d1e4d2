"""The ``granwave`` command: a click group whose stages load lazily.

Each stage lives in its own small module under ``granwave.cli``; it is only
imported when the stage runs, so ``granwave --help`` stays instant (no numba).
"""

from __future__ import annotations

import importlib

import click

from .. import __version__


class LazyGroup(click.Group):
    """A click group whose subcommands are imported on first use."""

    def __init__(self, *args, lazy_commands: dict[str, str] | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        self.lazy_commands = dict(lazy_commands or {})

    def list_commands(self, ctx):
        return sorted(set(super().list_commands(ctx)) | set(self.lazy_commands))

    def get_command(self, ctx, name):
        if name in self.lazy_commands:
            module_name, attr = self.lazy_commands[name].split(":")
            return getattr(importlib.import_module(module_name), attr)
        return super().get_command(ctx, name)

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        """As click's, but a usage error (an invalid choice, a number that is not one, a missing
        argument) is one line, ``Error: ... (see 'granwave CMD --help')``, exit 2, like every
        other refusal (click prints the usage and a hint above it)."""
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode, **extra)
        import sys

        try:
            rc = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click.UsageError as exc:
            if isinstance(exc, getattr(click.exceptions, "NoArgsIsHelpError", ())):
                exc.show()  # `granwave` alone, `granwave analyze` alone: the help, as click shows it
                sys.exit(exc.exit_code)
            where = exc.ctx.command_path if exc.ctx is not None else "granwave"
            click.echo(f"Error: {exc.format_message()} (see '{where} --help')", err=True)
            sys.exit(exc.exit_code)
        except click.ClickException as exc:
            exc.show()
            sys.exit(exc.exit_code)
        except click.exceptions.Abort:
            click.echo("Aborted!", err=True)
            sys.exit(1)
        sys.exit(rc if isinstance(rc, int) else 0)

    def format_commands(self, ctx, formatter):
        # Short help without importing every stage: the first docstring line of each.
        rows = []
        for name in self.list_commands(ctx):
            try:
                cmd = self.get_command(ctx, name)
            except ImportError as exc:  # a stage whose module is missing: say so, keep --help usable
                rows.append((name, f"(unavailable: {exc})"))
                continue
            if cmd is not None and not cmd.hidden:
                rows.append((name, cmd.get_short_help_str(limit=70)))
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


STAGES = {
    "prepare-packing": "granwave.cli.prepare:prepare_packing",
    "lattice": "granwave.cli.systems:lattice",
    "chain": "granwave.cli.systems:chain",
    "linearize": "granwave.cli.linear:linearize",
    "eigensolve": "granwave.cli.linear:eigensolve",
    "propagate": "granwave.cli.propagate:propagate",
    "analyze": "granwave.cli.analyze:analyze",
    "pressure-sweep": "granwave.cli.sweep:pressure_sweep",
    "plot": "granwave.cli.plot:plot",
    "report": "granwave.cli.report:report",
    "export": "granwave.cli.export:export",
    "import": "granwave.cli.import_:import_group",
}


@click.group(cls=LazyGroup, lazy_commands=STAGES,
             context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="granwave")
def main():
    """granwave: sound in granular packings, from DEM packings to coherent fronts.

    Stages exchange HDF5 files: prepare-packing (or lattice / chain) ->
    linearize -> eigensolve -> propagate -> analyze. Units: mean grain
    diameter, grain density and E* = E/(1-nu^2) are 1 (see docs/units.md).
    An output name (-o) must end in the suffix its stage writes (.h5 for the
    HDF5 stages; each -o help says which): any other name, or one too long for
    the file system, is refused with one line before any work.
    """
    _one_line_warnings()


def _one_line_warnings() -> None:
    """An OlderFileWarning (a check skipped for an older file) prints as one line on stderr,
    ``warning: ...``, like the stages' own warnings, once the command has ended well (a refusal
    stays one line); other warnings as Python prints them."""
    import warnings

    from ..errors import OlderFileWarning

    _OLDER.clear()
    warnings.simplefilter("always", OlderFileWarning)  # each command says it, not only the first
    if getattr(warnings.showwarning, "granwave", False):
        return
    previous = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, OlderFileWarning):
            _OLDER.append(str(message))
        else:
            previous(message, category, filename, lineno, file, line)

    show.granwave = True
    warnings.showwarning = show


#: OlderFileWarnings of the running command, printed when it ends well (a refusal stays one line).
_OLDER = []


@main.result_callback()
def _print_older_warnings(*_args, **_kwargs):
    while _OLDER:
        click.echo(f"warning: {_OLDER.pop(0)}", err=True)
