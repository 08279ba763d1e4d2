"""Options and error handling shared by every stage of the CLI."""

from __future__ import annotations

import functools
import json
import math
import os
import signal
import sys

import click
import numpy as np

from ..errors import ConvergenceError, InputError, OutputError


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
NON_NEGATIVE = FiniteFloat(min=0.0)

output_option = click.option(
    "-o", "--output", "output", required=True, type=click.Path(dir_okay=False),
    help="Output HDF5 file (written atomically).")
json_option = click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of a table.")
seed_option = click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
                           help="Random seed; the same seed gives the same result bit for bit.")


def _interrupt(signum, frame):
    raise KeyboardInterrupt


class Refusal(click.ClickException):
    """Bad input, refused before any output is written: one line, exit status 2."""

    exit_code = 2


def _paths(value) -> list[str]:
    """The file paths among a click parameter's value (a path or a tuple of paths)."""
    items = value if isinstance(value, (list, tuple)) else [value]
    return [str(v) for v in items if isinstance(v, (str, os.PathLike)) and os.path.isfile(v)]


def _check_outputs(kwargs: dict) -> None:
    """Refuse, before computing, an output that is '-', not a regular file, or an input."""
    outputs = [v for k, v in kwargs.items()
               if (k == "output" or k.endswith("_output")) and isinstance(v, (str, os.PathLike)) and v]
    if not outputs:
        return
    from ..io.files import check_target

    inputs = [p for k, v in kwargs.items() if k != "output" and not k.endswith("_output")
              for p in _paths(v)]
    for out in outputs:
        check_target(out, inputs)


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
        signal.signal(signal.SIGTERM, _interrupt)
        try:
            _check_outputs(kwargs)
            return func(*args, **kwargs)
        except InputError as exc:
            raise Refusal(str(exc)) from None
        except OutputError as exc:
            raise click.ClickException(str(exc)) from None
        except ConvergenceError as exc:
            raise click.ClickException(f"not converged: {exc}") from None
        except MemoryError:
            from ..resources import available_memory, format_bytes

            raise Refusal(f"out of memory: the request does not fit ({format_bytes(available_memory())} "
                          "available); reduce it") from None
        except KeyboardInterrupt:
            click.echo("\ninterrupted; no output written", err=True)
            sys.exit(130)

    return wrapper


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def echo_json(obj) -> None:
    """Print one JSON object (NaN becomes null, arrays become lists)."""
    click.echo(json.dumps(_jsonable(obj), indent=1))


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


def progress_printer(enabled: bool = True):
    """A callback that prints progress lines to stderr (for iterative stages)."""

    def report(message: str) -> None:
        if enabled:
            click.echo(message, err=True)

    return report
