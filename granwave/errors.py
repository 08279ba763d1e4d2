"""Errors a user can cause (bad input), as opposed to bugs.

Every stage raises :class:`InputError` for problems with its input files or
parameters; the CLI turns it into a one-line message and exit status 2.
"""


class InputError(ValueError):
    """Bad input: a parameter out of range, a foreign file, an unconverged packing..."""


class ResourceError(InputError):
    """A request that cannot fit: its memory or disk estimate exceeds what is available."""


class OlderFileWarning(UserWarning):
    """An input written by an older granwave lacks what a check of belonging needs (a packing
    digest, a lateral width): the check is skipped for it, in one warning line that says how to
    remake the file (docs/decisions/0048-older-files-checked-as-far-as-they-record.md)."""


class OutputError(Exception):
    """An output could not be written (disk full, I/O error); no partial file is left."""


class ConvergenceError(RuntimeError):
    """An iterative procedure did not reach its tolerance within its budget."""


class StepBudgetExceeded(ConvergenceError):
    """A run used its whole step budget (``max_steps``, recorded as ``steps``) without
    converging, as opposed to blowing up: a caller that set a short budget on purpose can
    tell the two apart without reading the message."""

    def __init__(self, message: str, steps: int):
        super().__init__(message)
        self.steps = steps

    def __reduce__(self):  # keep ``steps`` when the error crosses a process boundary
        return type(self), (str(self), self.steps)
