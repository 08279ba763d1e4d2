"""Errors a user can cause (bad input), as opposed to bugs.

Every stage raises :class:`InputError` for problems with its input files or
parameters; the CLI turns it into a one-line message and a non-zero exit.
"""


class InputError(ValueError):
    """Bad input: a parameter out of range, a foreign file, an unconverged packing..."""


class ConvergenceError(RuntimeError):
    """An iterative procedure did not reach its tolerance within its budget."""
