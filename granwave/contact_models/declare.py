"""The records a contact sub-model declares itself with (plain Python, no numba).

A sub-model module (:mod:`.hertz`, :mod:`.damping_critical`, :mod:`.mindlin`, ...) sets ``KIND`` (a
:class:`Kind` of :mod:`.kinds`), ``NAME``, ``PARAMETERS`` (a tuple of :class:`Parameter`) and
the formulas of its kind (docs/dem.md, "How to add a contact model"). Everything else about its
parameters (the fields of ``PrepareParams`` and so the options of ``prepare-packing``, the
file attributes, the engine's ``fpar`` fields, the range checks and their messages) is derived
from these records by generic code.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Parameter:
    """One parameter of a sub-model: its field name (also its option ``--name-with-dashes`` and
    its file attribute), default, units (None: dimensionless), one-sentence help and accepted
    range (``lo``/``hi``, open or closed), in the units of docs/method.md §1."""

    name: str
    default: float
    units: str | None
    help: str
    lo: float | None = None
    lo_open: bool = False
    hi: float | None = None
    hi_open: bool = False

    def meta(self) -> dict:
        """The range and help as ``granwave.params.param`` keywords."""
        return dict(help=self.help, units=self.units, lo=self.lo, lo_open=self.lo_open, hi=self.hi,
                    hi_open=self.hi_open)


@dataclass(frozen=True)
class Kind:
    """A kind of sub-model (LAMMPS: normal, damping, tangential, rolling, twisting).

    ``option``: the ``PrepareParams`` field (and file attribute) that selects the sub-model by
    name; ``off``: the name meaning "no sub-model of this kind" (None: one is always on);
    ``default``: the name selected by default; ``recorded``: whether a file records the
    selection when it is the default too; ``history``: name of the per-contact history it keeps
    in the tangential history's arrays after their ``dim`` columns, and the file dataset
    ``contacts/<history>`` that stores it (None: no history); ``reader``: the generated kernel
    that reads its model from the engine's ``fpar``; ``functions``: its formulas and their
    dispatchers (granwave.contact_models.kinds); ``python``: the Python hooks and constants each
    of its sub-models defines besides ``kernel_constants``; ``parameters``: parameters every
    sub-model of the kind takes (declared once, here; ``friction`` and ``poisson`` of the
    tangential kind); ``leading``: the names every sub-model's ``CONSTANTS`` start with (the
    tangential kind's ``friction``); ``fields``: the ``fpar`` fields of its first constants c0,
    c1, ... (the damping and tangential kinds name theirs after their parameters, ``damping``
    and ``friction``: one name from the option to the kernels; the others, and the constants
    after these, are the generated ``<kind>_c<i>``). How many
    constants a kind carries is not declared here: the generator takes the largest
    ``len(CONSTANTS)`` of its sub-models.
    """

    name: str
    option: str
    help: str
    default: str
    off: str | None = None
    recorded: bool = False
    history: str | None = None
    history_help: str = ""
    reader: str = ""
    functions: tuple = field(default=())
    python: tuple = field(default=())
    parameters: tuple = field(default=())
    leading: tuple = field(default=())
    fields: tuple = field(default=())

    def field_names(self, slots: int) -> tuple:
        """The ``fpar`` fields of the kind's constants c0 ... c{slots-1}."""
        return tuple(self.fields[i] if i < len(self.fields) else f"{self.name}_c{i}" for i in range(slots))
