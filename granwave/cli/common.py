"""Options and error handling shared by every stage of the CLI.

Stage options come from the fields of the stage's parameter dataclass
(:func:`options_from`, :func:`params_from`), so that every default, range,
unit and help text is written once, in :mod:`granwave.params`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import json
import math
import os
import signal
import sys

import click
import numpy as np

from ..errors import ConvergenceError, InputError, OutputError
from ..params import range_text


class FiniteFloat(click.ParamType):
    """A float that refuses NaN and infinities (and optionally a range)."""

    name = "float"

    def __init__(self, *, min: float | None = None, max: float | None = None,
                 min_open: bool = False, max_open: bool = False):
        self.min, self.max, self.min_open, self.max_open = min, max, min_open, max_open

    def convert(self, value, param, ctx):
        if isinstance(value, float):
            x = value
        else:
            try:
                x = float(value)
            except (TypeError, ValueError):
                self.fail(f"{value!r} is not a number", param, ctx)
        if not math.isfinite(x):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        if self.min is not None and (x < self.min or (self.min_open and x == self.min)):
            self.fail(f"{x:g} must be {'>' if self.min_open else '>='} {self.min:g}", param, ctx)
        if self.max is not None and (x > self.max or (self.max_open and x == self.max)):
            self.fail(f"{x:g} must be {'<' if self.max_open else '<='} {self.max:g}", param, ctx)
        return x


FLOAT = FiniteFloat()
POSITIVE = FiniteFloat(min=0.0, min_open=True)

class OutputOption(click.Option):
    """``-o/--output`` with the suffixes its file must end in (``suffixes``; none: a folder).

    The one place of the output-name policy: :func:`stage` refuses, before any work,
    a name without one of ``suffixes`` (a one-line error; nothing is appended, so
    the file written is always the name given) and a name too long for its folder's
    file system once the temporary name is formed from it (docs/architecture.md).
    """

    def __init__(self, *args, suffixes: tuple[str, ...] = (), folder: bool = False, **kwargs):
        super().__init__(*args, **kwargs)
        self.suffixes = tuple(suffixes)
        self.folder = folder


def _either(suffixes) -> str:
    """``.a``, ``.a or .b``, ``.a, .b or .c``."""
    return " or ".join([", ".join(suffixes[:-1]), suffixes[-1]] if len(suffixes) > 1 else list(suffixes))


def output_path_option(suffixes=(), help="", folder: bool = False):
    """A ``-o/--output`` option whose value must end in one of ``suffixes`` (or, with
    ``folder``, names a folder); the accepted suffixes are stated in its help."""
    if suffixes:
        help += f" Must end in {_either(suffixes)} (any other name is refused before any work)."
    return click.option("-o", "--output", "output", required=True, cls=OutputOption,
                        # kinds checked in stage(), so that a folder for a file is one line
                        type=click.Path(), metavar="DIR" if folder else "FILE", suffixes=suffixes,
                        folder=folder, help=help)


#: Suffixes of the HDF5 files the stages write.
H5_SUFFIXES = (".h5", ".hdf5")
output_option = output_path_option(H5_SUFFIXES, help="Output HDF5 file (written atomically).")
QUIET_HELP = "No progress or summary lines on stderr (warnings and errors still show)."
#: ``-q/--quiet`` of every stage that prints progress or a summary on stderr.
quiet_option = click.option("-q", "--quiet", is_flag=True, help=QUIET_HELP)
#: The same option for commands that ask :func:`is_quiet` instead of taking a ``quiet`` argument.
quiet_flag = click.option("-q", "--quiet", is_flag=True, expose_value=False, help=QUIET_HELP,
                          callback=lambda ctx, param, value: ctx.meta.__setitem__("granwave.quiet", value))


def is_quiet() -> bool:
    """Whether the running command was given ``-q`` through :data:`quiet_flag`."""
    ctx = click.get_current_context(silent=True)
    return bool(ctx is not None and ctx.meta.get("granwave.quiet"))
json_option = click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of a table.")


class FloatList(click.ParamType):
    """Comma-separated finite numbers, e.g. ``8,25`` (a tuple)."""

    name = "list"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        try:
            values = tuple(float(x) for x in str(value).split(",") if x.strip())
        except ValueError:
            self.fail(f"{value!r} is not a comma-separated list of numbers", param, ctx)
        if not all(math.isfinite(x) for x in values):
            self.fail(f"{value!r} holds a value that is not a finite number", param, ctx)
        return values


def _option_for(f: dataclasses.Field):
    """The click option of one parameter field (name, type, default, help from the field)."""
    meta = f.metadata
    name = meta.get("cli") or "--" + f.name.replace("_", "-")
    required = f.default is dataclasses.MISSING
    default = None if required else f.default
    help_text = meta.get("help", "")
    extra = [meta["units"]] if meta.get("units") else []
    if range_text(meta):
        extra.append(f"range {range_text(meta)}")
    if extra:
        help_text += f" [{'; '.join(extra)}]"
    kw = dict(help=help_text, required=required)
    if meta.get("metavar"):
        kw["metavar"] = meta["metavar"]
    if f.type in ("bool", "bool | None"):
        if meta.get("negatable"):
            # ``cli`` may name both switches ("--on/--off"); else --x/--no-x
            pair = name if "/" in name else f"--{name.lstrip('-')}/--no-{name.lstrip('-')}"
            return click.option(pair, f.name, default=default,
                                show_default=default is not None, **kw)
        return click.option(name, f.name, is_flag=True, default=bool(default), **kw)
    if meta.get("choices") is not None:
        ptype = click.Choice([str(c) for c in meta["choices"]], case_sensitive=False)
        default = None if default is None else str(default)
    elif f.type.startswith("int"):
        ptype = click.INT
    elif f.type.startswith("float"):
        ptype = FLOAT
    elif f.type.startswith("tuple"):
        ptype = FloatList()
        default = None if default is None else ",".join(f"{x:g}" for x in default)
    else:
        ptype = click.STRING
    if required:
        return click.option(name, f.name, type=ptype, **kw)
    return click.option(name, f.name, type=ptype, default=default, show_default=default is not None,
                        **kw)


def options_from(cls, *, exclude=(), json: bool = False):
    """Decorator adding one click option per field of the parameter class ``cls``.

    Fields whose metadata ``cli`` is "" (internal protocol settings) and those
    in ``exclude`` get no option; the order of the help follows the fields.
    ``json`` adds ``--json`` (the stage prints its result with :func:`echo_result`).
    """
    fields = [f for f in dataclasses.fields(cls)
              if f.name not in exclude and f.metadata.get("cli") != ""]

    def decorate(func):
        if json:
            func = json_option(func)
        for f in reversed(fields):
            func = _option_for(f)(func)
        return func

    return decorate


def params_from(cls, options: dict, **fixed):
    """Build ``cls`` from the click values in ``options`` (its own fields only) and ``fixed``."""
    values = {}
    for f in dataclasses.fields(cls):
        if f.name in options:
            value = options[f.name]
            choices = f.metadata.get("choices")
            if choices is not None and value is not None:
                value = next((c for c in choices if str(c).upper() == str(value).upper()), value)
            values[f.name] = value
    values.update(fixed)
    unused_contact_options(values)
    return cls(**values)


def given(name: str) -> bool:
    """Whether the current command's option ``name`` was given (command line or environment),
    not left at its default; False outside a click command."""
    ctx = click.get_current_context(silent=True)
    if ctx is None:
        return False
    source = ctx.get_parameter_source(name)
    return source is not None and source.name not in ("DEFAULT", "DEFAULT_MAP")


def unused_contact_options(values: dict) -> None:
    """Refuse (one line) a contact sub-model's parameter given on the command line while its
    sub-model is not selected (``--harmonic-stiffness`` under Hertz, ``--rolling-stiffness``
    without ``--rolling sds``): it would be ignored without a word."""
    from ..contact_models import options as CO

    for name, p in CO.PARAMETERS.items():
        option = CO.KINDS[p["kind"]]["option"]
        if name not in values or option not in values or not given(name):
            continue
        chosen = values[option] if values[option] is not None else CO.KINDS[p["kind"]]["default"]
        if str(chosen) != p["submodel"]:
            flag = "--" + name.replace("_", "-")
            raise BadInput(f"{flag} is a parameter of --{option.replace('_', '-')} {p['submodel']}, "
                           f"not of the {chosen} this run uses: it would be ignored (drop it, or "
                           f"give --{option.replace('_', '-')} {p['submodel']})")


def _default_threads():
    from ..threads import available_cores

    return available_cores()


#: ``--allow-long-run`` of the stages that predict their run time before starting
#: (:func:`granwave.resources.check_run_time`); :func:`stage` applies it.
long_run_option = click.option(
    "--allow-long-run", "allow_long_run", is_flag=True,
    help="Start even a run predicted to take longer than a day (the prediction is printed).")

threads_option = click.option(
    "--threads", type=click.IntRange(min=1), default=_default_threads,
    show_default="the cores this process may run on",
    help="Threads of the parallel kernels (results do not depend on it).")


class BadInput(click.ClickException):
    """A one-line error about the user's input: exit status 2, like click's usage errors."""

    exit_code = 2


#: set once a stage is stopping: an interrupt raised during its exit would escape uncaught and
#: end the process by SIGINT (status -2, seen under load when a re-sent SIGTERM came late)
_STOPPING = [False]


def _interrupt(signum, frame):
    if not _STOPPING[0]:
        raise KeyboardInterrupt


def _unraisable(hook_args, _default=sys.unraisablehook):
    """An interrupt raised where Python cannot propagate it (a ctypes callback, e.g. numba's
    compiler writing its object cache) is printed and dropped: the run would go on after
    SIGTERM. Send the signal again a moment later, from a thread (a signal sent from here would
    be handled inside this hook and dropped too); its handler then raises where it propagates."""
    if isinstance(hook_args.exc_value, KeyboardInterrupt):
        import threading

        threading.Timer(0.02, os.kill, (os.getpid(), signal.SIGTERM)).start()
        return
    _default(hook_args)


def _paths(value) -> list[str]:
    """The file paths among a click parameter's value (a path or a tuple of paths)."""
    items = value if isinstance(value, (list, tuple)) else [value]
    return [str(v) for v in items if isinstance(v, (str, os.PathLike)) and os.path.isfile(v)]


def _output_params() -> dict:
    """The :class:`OutputOption` parameters of the running command, by name."""
    ctx = click.get_current_context(silent=True)
    if ctx is None:
        return {}
    return {p.name: p for p in ctx.command.params if isinstance(p, OutputOption)}


def check_suffix(path, suffixes, what: str = "this output") -> None:
    """Refuse (one line) a file name that does not end in one of ``suffixes``."""
    if suffixes and not str(path).lower().endswith(tuple(s.lower() for s in suffixes)):
        stem = os.path.basename(str(path)) or str(path)
        raise InputError(f"cannot write {path}: {what} must end in {_either(suffixes)} "
                         f"(e.g. {os.path.splitext(stem)[0]}{suffixes[0]})")


def _check_outputs(kwargs: dict) -> None:
    """Refuse, before computing, an output that is '-', not a regular file, an input,
    without its suffix, or with a name too long for the file system."""
    outputs = [(k, v) for k, v in kwargs.items()
               if (k == "output" or k.endswith("_output")) and isinstance(v, (str, os.PathLike)) and v]
    if not outputs:
        return
    from ..io.files import check_name_length, check_target

    declared = _output_params()
    inputs = [p for k, v in kwargs.items() if k != "output" and not k.endswith("_output")
              for p in _paths(v)]
    for name, out in outputs:
        opt = declared.get(name)
        if opt is not None and opt.folder:
            if os.path.exists(out) and not os.path.isdir(out):
                raise InputError(f"cannot write into {out}: it is a file, not a folder")
            check_name_length(out, temporary=False)
            continue
        check_target(out, inputs)
        if opt is not None:
            check_suffix(out, opt.suffixes, "the output")
        check_name_length(out)


def _printing(exc: OSError) -> bool:
    """Whether ``exc`` was raised by printing (click.echo, a flush of standard output): a
    full device or a closed pipe behind stdout, after the outputs were written."""
    tb = exc.__traceback__
    while tb is not None:
        code = tb.tb_frame.f_code
        if code.co_name in ("echo", "flush") and "click" in code.co_filename:
            return True
        tb = tb.tb_next
    return False


def _silence_stdout() -> None:
    """Point standard output at /dev/null, so that the interpreter's last flush at exit cannot
    fail a second time (the recipe of Python's documentation for SIGPIPE)."""
    with contextlib.suppress(OSError, ValueError, AttributeError):
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, sys.stdout.fileno())
        os.close(null)


def stage(func):
    """Turn user errors into a one-line message and a non-zero exit (no traceback).

    Exit status 2: bad input (InputError, an output that would replace an input or
    a device, a request too large for the machine, MemoryError); 1: a stage that
    did not converge or an output that could not be written (disk full).
    SIGTERM (a scheduler's time limit, Snakemake stopping its jobs) is handled like
    Ctrl-C, so that an interrupted atomic write removes its temporary file.
    """

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        from ..resources import allow_long_run

        _STOPPING[0] = False
        for sig in (signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, _interrupt)
        sys.unraisablehook = _unraisable
        limit = allow_long_run() if kwargs.pop("allow_long_run", False) else contextlib.nullcontext()
        try:
            _check_outputs(kwargs)
            from ..io.files import outputs_together

            with limit, outputs_together(keep=_printing):  # all of a command's outputs, or none
                return func(*args, **kwargs)
        except InputError as exc:
            raise BadInput(str(exc)) from None
        except OutputError as exc:
            raise click.ClickException(str(exc)) from None
        except ConvergenceError as exc:
            raise click.ClickException(f"not converged: {exc}") from None
        except MemoryError:
            from ..resources import available_memory, format_bytes

            raise BadInput(f"out of memory: the request does not fit ({format_bytes(available_memory())} "
                          "available); reduce it") from None
        except KeyboardInterrupt:
            _STOPPING[0] = True  # a later SIGTERM (_unraisable's re-send) must not cut the exit
            click.echo("\ninterrupted; no output written", err=True)
            sys.exit(130)
        except OSError as exc:
            if not _printing(exc):
                raise
            _silence_stdout()
            raise click.ClickException(
                f"cannot print on standard output ({exc.strerror or exc}); the files this command "
                "wrote are complete") from None

    return wrapper


def echo_json(obj) -> None:
    """Print one JSON object (NaN becomes null, arrays become lists)."""
    from ..io.files import jsonable

    click.echo(json.dumps(jsonable(obj), indent=1))


def echo_result(rows: dict, as_json: bool, title: str | None = None) -> None:
    """One JSON object (``--json``) or the ``name  value`` table under ``title``."""
    echo_json(rows) if as_json else echo_table(rows, title=title)


def echo_table(rows: dict, title: str | None = None) -> None:
    """Print ``name  value`` rows, numbers with 6 significant digits."""
    if title:
        click.echo(title)
    width = max((len(k) for k in rows), default=0)
    for key, value in rows.items():
        if isinstance(value, float):
            value = f"{value:.6g}"
        elif isinstance(value, np.ndarray):
            value = np.array2string(value, precision=5)
        click.echo(f"  {key:<{width}}  {value}")


def echo_warnings(caught) -> None:
    """Print warnings recorded by ``warnings.catch_warnings(record=True)`` as one line each."""
    for w in caught:
        click.echo(f"warning: {w.message}", err=True)


def progress_printer(enabled: bool = True):
    """A callback that prints progress lines to stderr (for iterative stages)."""

    def report(message: str) -> None:
        if enabled:
            click.echo(message, err=True)

    return report
