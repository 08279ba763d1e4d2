"""Parameters of every stage: frozen, keyword-only dataclasses (one per stage).

Each class is the one home of its stage's defaults, ranges and units: the
library (:mod:`granwave.api`) takes it, the CLI builds its click options from
its fields (:func:`granwave.cli.common.options_from`), and the output files
record it (:meth:`Params.as_attrs`). Ranges are checked in ``__post_init__``
and raise :class:`granwave.errors.InputError`; the same physical parameter has
the same range on every stage (ν in [0, 0.5), μ >= 0, 1e-12 <= p <= 0.1 E*, ...).

Units are those of ``docs/method.md §1``: lengths in mean grain diameters d,
masses in ρ d³, pressures and stiffnesses in E* (times d for a stiffness),
times in d/sqrt(E*/ρ). Field metadata: ``help`` (one sentence), ``units``,
and the range (``lo``/``hi``, ``lo_open``/``hi_open``) or ``choices``.

This module imports nothing heavy (no numpy), so that building the CLI stays
instant.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import MISSING, dataclass

from .contact_models import options as CO
from .errors import InputError

#: Names of the normal contact laws, in code order (granwave.contact_models' registry).
CONTACT_LAWS = CO.names("normal")

#: Thickness l (d) of the layers next to the bottom wall and the piston left out of bulk
#: measurements (docs/method.md §4); statics and moduli use the same slab.
BULK_LAYER = 3.0

#: Largest accepted DEM time-step safety: 0.6 of the estimated stability limit
#: (granwave.dem.kernels.stable_dt), whose true limit is 0.7-1.0 of the estimate
#: (docs/decisions/0009-time-step-rule.md).
MAX_SAFETY = 0.06

#: Initial solid fraction of the granular gas when none is given, by dimension
#: (area fraction in 2D, volume fraction in 3D; docs/dem.md).
GAS_DENSITY = {2: 0.50, 3: 0.30}

#: Largest pressure (E*) accepted anywhere: beyond it the overlaps leave the Hertz regime.
MAX_PRESSURE = 0.1

#: Smallest pressure (E*) accepted anywhere: the Hertz overlaps (~ p^(2/3) d) are then 1e-8 d,
#: still far above the rounding of positions of order 1-1000 d; far below it (a denormal p, say)
#: the forces underflow and a preparation runs its whole step budget to no end.
MIN_PRESSURE = 1e-12

#: Largest seed: seeds are stored as 64-bit signed integers in every output file.
MAX_SEED = 2**63 - 1


def default_gas_density(dim: int) -> float:
    """Initial solid fraction of the gas used when ``gas_density`` is None."""
    return GAS_DENSITY[int(dim)]


# ----------------------------------------------------------------- field helpers
def param(default=MISSING, *, help: str, units: str | None = None, lo=None, hi=None,
          lo_open: bool = False, hi_open: bool = False, choices=None, cli: str | None = None,
          negatable: bool = False, metavar: str | None = None, why: str | None = None):
    """A dataclass field with its help text, units and accepted range in ``metadata``.

    ``cli`` overrides the option name (default ``--field-name``); ``negatable``
    makes a boolean an ``--x/--no-x`` switch instead of a flag; ``why`` is added to
    the message that refuses a value out of range.
    """
    meta = dict(help=help, units=units, lo=lo, hi=hi, lo_open=lo_open, hi_open=hi_open,
                choices=None if choices is None else tuple(choices), cli=cli, negatable=negatable,
                metavar=metavar, why=why)
    return dataclasses.field(default=default, metadata=meta)


def _num(x) -> str:
    """A bound or value as text: integers exactly, floats in %g."""
    return str(x) if isinstance(x, int) else f"{x:g}"


def range_text(meta) -> str:
    """The accepted range of a field as text, e.g. ``[0, 0.5)`` or ``> 0``."""
    lo, hi = meta.get("lo"), meta.get("hi")
    if lo is not None and hi is not None:
        return f"{'(' if meta['lo_open'] else '['}{_num(lo)}, {_num(hi)}{')' if meta['hi_open'] else ']'}"
    if lo is not None:
        return f"{'>' if meta['lo_open'] else '>='} {_num(lo)}"
    if hi is not None:
        return f"{'<' if meta['hi_open'] else '<='} {_num(hi)}"
    return ""


def _check_field(name: str, value, meta) -> None:
    if value is None:
        return
    choices = meta.get("choices")
    if choices is not None:
        if value not in choices:
            raise InputError(f"{name} must be one of {', '.join(map(str, choices))}, got {value!r}")
        return
    if isinstance(value, bool) or isinstance(value, (str, tuple, list)):
        return
    if not isinstance(value, (int, float)):
        raise InputError(f"{name} must be a number, got {value!r}")
    if isinstance(value, float) and not math.isfinite(value):
        raise InputError(f"{name} must be a finite number, got {value!r}")
    lo, hi = meta.get("lo"), meta.get("hi")
    bad = ((lo is not None and (value < lo or (meta["lo_open"] and value == lo)))
           or (hi is not None and (value > hi or (meta["hi_open"] and value == hi))))
    if bad:
        units = f" {meta['units']}" if meta.get("units") else ""
        why = f": {meta['why']}" if meta.get("why") else ""
        where = "in " if lo is not None and hi is not None else ""
        raise InputError(f"{name} must be {where}{range_text(meta)}{units}, got {_num(value)}{why}")


#: The numpy scalar kinds (dtype.kind) taken as Python numbers, per field type.
_NUMPY_KINDS = {"int": "iu", "int | None": "iu", "float": "iuf", "float | None": "iuf",
                "bool": "b", "bool | None": "b"}


def _python_scalar(value, ftype: str):
    """A numpy scalar (np.int64(10), np.float32(1e-3), np.bool_(True), or a 0-d array) as the
    Python number it holds, where the field takes that kind of number; anything else unchanged
    (so np.float64(2.5) for an integer field is still refused, and np.bool_ is no number).
    Duck-typed: this module imports no numpy."""
    dtype = getattr(value, "dtype", None)
    if dtype is None or getattr(value, "shape", None) != () or not hasattr(value, "item"):
        return value
    if getattr(dtype, "kind", "") not in _NUMPY_KINDS.get(ftype, ""):
        return value
    return value.item()


class Params:
    """Base of the stage parameters: range checks from the field metadata, attribute export."""

    #: Name of the root attribute (JSON text) under which an output records these parameters.
    ATTR = "params"

    def __post_init__(self):
        for f in dataclasses.fields(self):
            value = _python_scalar(getattr(self, f.name), f.type)
            if value is not getattr(self, f.name):
                object.__setattr__(self, f.name, value)
            if value is None and f.type in ("int", "float"):
                raise InputError(f"{f.name} must be a number, got None")
            if f.type in ("int", "int | None") and value is not None:
                if isinstance(value, bool) or not isinstance(value, int):
                    if isinstance(value, float) and value.is_integer():
                        object.__setattr__(self, f.name, int(value))
                        value = int(value)
                    else:
                        raise InputError(f"{f.name} must be an integer, got {value!r}")
            if f.type in ("float", "float | None") and value is not None:
                if isinstance(value, bool) or not isinstance(value, (int, float)):
                    # True would pass as 1.0 and "1e-4" would fail deep inside a kernel
                    raise InputError(f"{f.name} must be a number, got {value!r}")
                if isinstance(value, int):
                    object.__setattr__(self, f.name, float(value))
                    value = float(value)
            _check_field(f.name, value, f.metadata)
        self._cross_check()

    def _cross_check(self) -> None:
        """Checks that involve several fields (subclasses)."""

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)

    def as_attrs(self) -> dict:
        """The parameters as HDF5-storable attributes (None becomes "none")."""
        return {k: ("none" if v is None else list(v) if isinstance(v, tuple) else v)
                for k, v in self.as_dict().items()}

    def record(self, attrs: dict) -> dict:
        """Write these parameters into ``attrs`` under ``self.ATTR`` (JSON text); returns attrs."""
        attrs[self.ATTR] = json.dumps(self.as_dict(), sort_keys=True)
        return attrs


# Shared fields: one definition (range, units, help) per physical parameter.
def _pressure(default=MISSING, what="Pressure p"):
    return param(default, help=f"{what}.", units="E*", lo=MIN_PRESSURE, hi=MAX_PRESSURE,
                 why="outside it the overlaps leave the Hertz regime or the forces underflow")


def _contact_parameter(name, default=None):
    """A field of the contact parameter ``name``, declared once by its sub-model or kind
    (granwave.contact_models), with its default there unless ``default`` is given."""
    p = CO.ALL_PARAMETERS[name]
    return param(p["default"] if default is None else default,
                 **{k: p[k] for k in ("help", "units", "lo", "lo_open", "hi", "hi_open")})


def _friction(default):
    return _contact_parameter("friction", default)


def _poisson(default=None):
    return _contact_parameter("poisson", default)


def _polydispersity(default):
    return param(default, help="W: diameters uniform in [1-W, 1+W]; 0 = monodisperse.", units="d",
                 lo=0.0, hi=1.0, hi_open=True)


def _seed():
    return param(0, help="Random seed; the same seed gives the same result bit for bit.", lo=0,
                 hi=MAX_SEED, why="files store seeds as 64-bit signed integers")


def _peak_fraction(default):
    return param(default, help="The first pulse is the first lobe at least this fraction of the "
                 "largest lobe up to and including the next one (skips precursors).",
                 lo=0.0, lo_open=True, hi=1.0)


# ----------------------------------------------------------------- packings
def _contact_fields() -> list:
    """The contact sub-models' fields (granwave.contact_models.options.prepare_fields)."""
    return [(name, kind, param(default, **meta)) for name, kind, default, meta in CO.prepare_fields()]


@dataclass(frozen=True, kw_only=True)
@CO.with_fields(_contact_fields(), after="pressure")
class PrepareParams(Params):
    """Preparation of a disordered packing by piston compression of a granular gas (docs/method.md §3).

    dim 2 or 3; grains N; pressure p (piston force / (L1 x 1 d) in 2D, / (L1 L2)
    in 3D, in E*); the contact sub-models, one option per kind (contact_law: the normal law;
    damping_law: the contact damping, its damping zeta a fraction of critical; tangential: the
    tangential law, with the kind's friction mu and poisson nu; rolling: rolling resistance)
    and each sub-model's parameters (fields generated from granwave.contact_models' registry,
    after pressure; their help says what they mean); polydispersity W; aspect (final
    height / width); background_damping b,
    the viscous rate gamma = b / t_i with t_i = sqrt(m_mean / (p d)) (force
    -gamma m v on grains and piston; it sets the compaction speed, hence density
    and coordination: keep it fixed within a study); compaction ('fixed': b at
    every height; 'height-scaled': b divided by L_e / reference_height where the
    expected final height L_e exceeds reference_height (d), so that the
    compaction is the same in units of L at every height and the steps grow as L;
    tall columns then differ from 'fixed' ones, docs/dem.md; 'mean-flow': the
    per-slab mean vertical flow and the piston damped at b min(1, reference_height /
    L_e), the fluctuations about it at b; any thread count, or the GPU);
    reference_height (d); mean_flow_slab (d, thickness of the horizontal slabs whose
    mass-weighted mean vertical velocity is the mean flow); mean_flow_settling
    ('late', the default: once the plug has arrived and the kinetic energy has fallen
    1000-fold, the mean vertical and lateral flow damped near critically for the column's
    breathing; 'compaction': the mean flow at the compaction rate to the end; 'critical':
    that damping from the plug's arrival on); end_game ('none'; 'adaptive': once every
    acceleration is below 100 tol, the background damping matched to the slowest mode or lowered
    in a creep); piston_mass (rho d^3, None:
    one layer of grains); gas_density (initial solid fraction, None: 0.50 in 2D,
    0.30 in 3D); tol (E*/(rho d) on every acceleration); max_steps (None: 2e6 per 100 d of
    the expected height, at least 2e6); seed; safety
    (dt = (safety/0.1) x the estimated stability limit, at most MAX_SAFETY;
    docs/dem.md); skin and skin_min (d; the neighbour list's skin adapts between them, the
    same packing for any skin); check_every (steps between convergence checks).
    """

    ATTR = "prepare_params"

    dim: int = param(2, help="2: sphere centres in a plane (x periodic, y vertical); 3: x, y "
                     "periodic, z vertical.", choices=(2, 3))
    grains: int = param(600, help="Number of grains N.", lo=1)
    pressure: float = _pressure(1e-4, "Piston pressure p (2D: force / (L1 x 1 d); 3D: force / (L1 L2))")
    polydispersity: float = _polydispersity(0.2)
    aspect: float = param(1.0, help="Expected final height / periodic width.", lo=0.0, lo_open=True)
    background_damping: float = param(
        0.3, help="Background viscous damping rate in units of 1/t_i, t_i = sqrt(m/(p d)) (sets the "
        "compaction speed; keep it fixed within a study).", lo=0.0)
    compaction: str = param("fixed", help="How the background damping rate follows the column height: "
                            "'fixed' keeps b at every height (steps grow about as L^1.7); "
                            "'height-scaled' divides b by L/reference_height in columns expected "
                            "taller than reference_height (steps grow as L, but tall columns come "
                            "out denser than with 'fixed'; docs/dem.md); 'mean-flow' divides it "
                            "only for the mean vertical flow of horizontal slabs and the piston "
                            "(any thread count, or --device gpu).",
                            choices=("fixed", "height-scaled", "mean-flow"))
    reference_height: float = param(25.0, help="Height up to which b applies unscaled "
                                    "(compaction 'height-scaled' and 'mean-flow').", units="d", lo=0.0,
                                    lo_open=True)
    mean_flow_slab: float = param(4.0, help="Thickness of the horizontal slabs whose mean vertical "
                                  "velocity is the mean flow (compaction 'mean-flow').", units="d",
                                  lo=0.0, lo_open=True)
    mean_flow_settling: str = param("late", help="Compaction 'mean-flow' in a column taller than "
                                    "reference_height: how the column settles once the plug has arrived. "
                                    "'late' keeps the compaction rate until the kinetic energy has fallen "
                                    "1000-fold, then damps the mean vertical and lateral flow near "
                                    "critically for the column's breathing (read from the piston's "
                                    "first upward swing): the statistics of 'compaction' in fewer steps "
                                    "(docs/dem.md 'Late settling'); 'compaction' keeps "
                                    "the compaction rate to the end; 'critical' "
                                    "switches at the end of the swing: fewer steps still, but "
                                    "other stresses (docs/dem.md 'Critical settling').",
                                    choices=("late", "compaction", "critical"))
    end_game: str = param("none", help="The background damping once every acceleration is below "
                          "100 tol (after the mean flow's settling, where that rule is on): 'none' keeps "
                          "it; 'adaptive' matches it to the slowest mode, read from the decay of the largest "
                          "speed (between 0.05 and 1 times b / t_i; 0.05 while the speeds creep, b / t_i again "
                          "at a rearrangement): large 3D packings converge where 'none' creeps for hours, with the "
                          "same statistics (docs/dem.md 'End game').", choices=("none", "adaptive"))
    piston_mass: float | None = param(None, help="Piston mass [default: one layer of grains, mean "
                                      "mass x L1 (2D) or L1 L2 (3D)].", units="rho d^3",
                                      lo=0.0, lo_open=True)
    gas_density: float | None = param(None, help="Initial solid fraction of the granular gas "
                                      "[default: 0.5 in 2D, 0.3 in 3D].", lo=0.01,
                                      hi=0.6, hi_open=True,
                                      why="a sparser gas starts over 50 times taller than the packing "
                                          "(a denormal one infinitely tall)")
    tol: float = param(1e-10, help="Convergence threshold on every acceleration; velocities are "
                       "tested too.", units="E*/(rho d)", lo=0.0, lo_open=True)
    max_steps: int | None = param(None, help="Step budget [default: 2e6 per 100 d of the column's "
                                  "expected height, at least 2e6]; not converged by then: error, no output.",
                                  lo=1)
    seed: int = _seed()
    safety: float = param(0.05, help="Time-step factor: dt = (safety/0.1) x the stability limit of "
                          "the stiffest contact (normal and rotational modes, contact damping "
                          "included; docs/dem.md).", lo=0.0, lo_open=True, hi=MAX_SAFETY,
                          why="dt is safety/0.1 of the estimated stability limit of the explicit "
                          "step, and the true limit is as low as 0.8 of the estimate (docs/dem.md)")
    skin: float = param(0.25, help="Verlet skin of the neighbour list (the largest, with an "
                        "adaptive skin).", units="d", lo=0.0, lo_open=True, hi=1.0, cli="")
    skin_min: float = param(0.02, help="Smallest Verlet skin: the skin adapts between skin_min "
                            "and skin to the grains' speed (a list lasts ~200 steps); equal to "
                            "skin: fixed. Changes the run time, never the packing.", units="d",
                            lo=0.0, lo_open=True, hi=1.0, cli="")
    check_every: int = param(20, help="Steps between convergence checks.", lo=1, cli="")

    def __post_init__(self):
        super().__post_init__()
        try:
            CO.check(CO.values_of(self), friction=self.friction)
        except ValueError as e:
            raise InputError(str(e)) from None


@dataclass(frozen=True, kw_only=True)
@CO.with_fields([(n, k, param(d, **m)) for n, k, d, m in CO.kind_fields(("normal", "tangential"), own=False)],
                after="poisson")
class LatticeParams(Params):
    """Perfect triangular lattice of unit balls under vertical stress p (docs/method.md §3, §12).

    rows >= 2 (first on the bottom wall, last on the top wall), width >= 3 balls
    per row (periodic); pressure p in E* (force per wall length x one diameter);
    friction mu and Poisson ratio nu (recorded; they set k_t); the normal contact law
    (contact_law) and the tangential law with their sub-models' parameters (fields generated from
    granwave.contact_models' registry, after poisson; their help says what they mean).
    """

    ATTR = "lattice_params"

    rows: int = param(help="Number of rows; the first touches the bottom wall, the last the top "
                      "wall.", lo=2)
    width: int = param(help="Balls per row; periodic in x, box length = width x spacing.", lo=3)
    pressure: float = _pressure(what="Vertical stress p (force per wall length x one diameter)")
    friction: float = _friction(0.0)
    poisson: float = _poisson()

    def __post_init__(self):
        super().__post_init__()
        try:
            CO.check(CO.values_of(self))
        except ValueError as e:
            raise InputError(str(e)) from None


@dataclass(frozen=True, kw_only=True)
@CO.with_fields([(n, k, param(d, **(dict(m, help="Give each contact the k_n of this normal contact law at "
                                          "force p instead of one K: " + m["help"].split(": ", 1)[1])
                                     if k == "str | None" else m)))
                 for n, k, d, m in CO.kind_fields(("normal",), default={"contact_law": None})], after="stiffness")
class ChainParams(Params):
    """1D chain of balls between two walls (docs/method.md §3, §12).

    balls N; pressure: the force on every contact in E* d^2; polydispersity W
    (diameters uniform in [1-W, 1+W], masses pi d^3/6 follow); seed; stiffness K
    (E* d) of every spring, walls included (None: the Hertz k_n of two unit
    balls at force p); contact_law (None: the springs K) and its parameters (fields generated
    from granwave.contact_models' registry, after stiffness): every contact its own k_n of that
    normal law at force p (radius dependent) instead; hertz: the same as contact_law 'hertz'.
    """

    ATTR = "chain_params"

    balls: int = param(help="Number of balls N.", lo=1)
    pressure: float = _pressure(what="Force on every contact (1D pressure: force per mean "
                                "diameter squared), in E* d^2")
    polydispersity: float = _polydispersity(0.0)
    seed: int = _seed()
    stiffness: float | None = param(None, help="Spring stiffness K of every contact, walls included "
                                    "[default: Hertz k_n of two unit balls at force p].",
                                    units="E* d", lo=0.0, lo_open=True)
    hertz: bool = param(False, help="Give each contact its own Hertz k_n (radius dependent) "
                        "instead of one K.")

    def _cross_check(self):
        if self.hertz and self.stiffness is not None:
            raise InputError("give either --stiffness K or --hertz, not both")
        if self.contact_law is not None and self.stiffness is not None:
            raise InputError("give either --stiffness K or --contact-law, not both")
        if self.hertz and self.contact_law not in (None, CO.KINDS["normal"]["default"]):
            raise InputError(f"give either --hertz or --contact-law {self.contact_law}, not both")
        if self.contact_law is not None:
            try:
                CO.check(CO.values_of(self))
            except ValueError as e:
                raise InputError(str(e)) from None

    def law(self) -> str | None:
        """The normal law every contact takes its k_n from (None: the springs K)."""
        return CO.KINDS["normal"]["default"] if self.hertz and self.contact_law is None else self.contact_law


# ----------------------------------------------------------------- linear model
@dataclass(frozen=True, kw_only=True)
class LinearizeParams(Params):
    """Linearization around equilibrium (docs/method.md §5)."""

    ATTR = "linearize_params"

    prestress: bool = param(False, help="Add the geometric (prestress) terms: D becomes the "
                            "Jacobian of the frozen-history contact forces (off by default).")
    force: bool = param(False, help="Linearize even a packing whose preparation did not converge.")
    check: bool = param(True, help="Check symmetry and positive semi-definiteness and count zero "
                        "modes (dense eigenvalues up to 3000 dofs, else the few lowest by LOBPCG "
                        "with an algebraic-multigrid preconditioner).", negatable=True)
    keep_spins: bool = param(True, help="3D frictional packings: keep the free spins of grains "
                             "with two contacts (zero modes, seen by neither wall: the dynamics "
                             "the DEM integrates), or remove them by the constraint theta.e = 0, "
                             "which also stops those grains rolling (docs/linear.md).",
                             cli="--keep-spins/--remove-spins", negatable=True)


@dataclass(frozen=True, kw_only=True)
class EigenParams(Params):
    """Eigenmodes of D phi = omega^2 M phi (docs/method.md §7)."""

    ATTR = "eigensolve_params"

    vectors: bool = param(False, help="Also store the M-orthonormal eigenvectors (n x n doubles; "
                          "needed only for mode shapes and modal snapshots).")
    lowest: int | None = param(None, help="Compute only the K lowest modes (sparse shift-invert "
                               "Lanczos) instead of the full dense spectrum; the modal signal is "
                               "then a low-pass truncation.", lo=1)


#: Propagation methods; "auto" picks "modal" or "time" by predicted cost (granwave.api).
METHODS = ("modal", "time", "dem", "auto")


@dataclass(frozen=True, kw_only=True)
class PropagateParams(Params):
    """A kick at the bottom wall and the signal on the top wall (docs/method.md §8).

    ic "A" (impulse) or "B" (displacement); t_max (d/sqrt(E*/rho)) and samples,
    the output grid; method (None: by the input, see granwave.api.propagate);
    dt and safety, the time step of the time domain (dt = safety x 2/omega_max)
    or of the DEM; snapshots, times of stored displacement fields; amplitude and
    damping, the kick size and contact damping of the DEM method.
    """

    ATTR = "propagate_params"

    ic: str = param("A", help="Initial condition: A = impulse on the grains touching the bottom "
                    "wall, B = their displacement (docs/conventions.md).", choices=("A", "B"))
    source_kind: str = param("normal", help="The kick: normal = bottom wall moved along the "
                             "vertical, signal = the top wall's vertical force; shear = bottom wall "
                             "moved along x (needs friction; initial condition A), signal = the top "
                             "wall's force along x (docs/shear.md).", choices=("normal", "shear"),
                             cli="--source")
    t_max: float | None = param(None, help="Length of the signal (the crossing time is height / c). "
                                "Needed by modal and time; with dem, default: a few crossings at an upper "
                                "estimate of the kick's front speed (the linear and the solitary wave's "
                                "closed forms at the kick's size; docs/shocks.md).",
                                units="d/sqrt(E*/rho)", lo=0.0, lo_open=True, cli="--t-max")
    method: str | None = param(None, help="modal (needs a modes file, or eigensolves a linear file "
                               "on the fly), time (velocity Verlet on a linear file), auto (modal "
                               "or time, whichever is predicted cheaper at the accuracy of "
                               "docs/tradeoffs.md; the choice is printed and recorded) or dem "
                               "(nonlinear DEM with the packing's contact law on a packing file). "
                               "Default: modal for a modes file, time for a linear file, dem for a "
                               "packing file.",
                               choices=METHODS)
    dt: float | None = param(None, help="Time step of the time-domain method (default: safety x "
                             "2/omega_max, shortened to fit an integer number of steps per "
                             "sample); with dem, default 0.01 x the shortest contact period "
                             "2 pi sqrt(m_min/k_max).", units="d/sqrt(E*/rho)", lo=0.0,
                             lo_open=True)
    safety: float = param(0.1, help="Default time step as a fraction of the stability limit "
                          "2/omega_max.", lo=0.0, lo_open=True, hi=1.0, hi_open=True)
    tolerance: float = param(0.01, help="time only: the largest departure of the signal from the "
                             "exact linear solution allowed over the record, as a fraction of "
                             "max|F| (each run estimates its own, to leading order in dt^2); a run "
                             "above it is repeated with a shorter step, dt or safety giving the "
                             "first. 0: the first step, unchecked (docs/linear.md).", lo=0.0, hi=1.0,
                             hi_open=True)
    samples: int = param(2001, help="Number of equally spaced output times from 0 to t_max.", lo=2)
    snapshots: tuple | None = param(None, help="Store the displacement field at these times (modal "
                                    "needs a modes file made with --vectors).",
                                    units="d/sqrt(E*/rho)", metavar="T1,T2,...")
    amplitude: float | None = param(None, help="dem only: EPS, kick size such that the largest "
                                    "single-contact displacement estimate of a kicked grain is EPS "
                                    "x the mean overlap of the packing's contacts (A: v_i "
                                    "sqrt(m_i/k_wall,i); B: the imposed displacement). Default "
                                    "1e-3 (linear regime). The signal is divided by the kick's "
                                    "scale (docs/damping.md).", lo=0.0, lo_open=True)
    damping: float | None = param(None, help="dem only: contact damping zeta, fraction of "
                                  "critical, normal and tangential (docs/method.md §2). Default 0.",
                                  lo=0.0, hi=1.0)
    strain: float | None = param(None, help="dem only: the kick's size as a strain, EPS x the mean "
                                 "overlap / the mean diameter (instead of --amplitude; docs/shocks.md).",
                                 lo=0.0, lo_open=True)
    velocity: float | None = param(None, help="dem only: the kick's size as the largest source velocity: "
                                   "of a kicked grain (impulse, initial condition A), or the piston's "
                                   "v_p (instead of --amplitude; docs/shocks.md).",
                                   units="(E*/rho)^1/2", lo=0.0, lo_open=True)
    drive: str | None = param(None, help="dem only: impulse (default: the kick of --ic) or piston (the "
                              "grains touching the bottom wall pushed at the constant velocity v_p for "
                              "the whole record, initial condition A; docs/shocks.md).",
                              choices=("impulse", "piston"))
    bin_width: float | None = param(None, help="dem only: height bin of the stored pulse field (mean "
                                    "velocity and largest contact force per bin, the front's arrival). "
                                    "Default 1.", units="d", lo=0.0, lo_open=True, cli="--bin")

    def __post_init__(self):
        object.__setattr__(self, "ic", str(self.ic).upper())
        object.__setattr__(self, "source_kind", str(self.source_kind).lower())
        if self.snapshots is not None:
            try:
                if isinstance(self.snapshots, (str, bytes)) or any(isinstance(t, bool) for t in self.snapshots):
                    raise TypeError  # "15" would be read as the times 1 and 5
                st = tuple(float(t) for t in self.snapshots)
            except (TypeError, ValueError):
                raise InputError(f"snapshots must be a list of times, got {self.snapshots!r}") from None
            object.__setattr__(self, "snapshots", st)
        super().__post_init__()

    def _cross_check(self):
        self.check_method(self.method)
        if self.source_kind == "shear" and self.ic != "A":
            raise InputError("--source shear has initial condition A only (an impulse: the wall's "
                             "displacement has no unique shape once rotations take part); use --ic A")
        if self.snapshots is not None and self.t_max is not None and not all(math.isfinite(t) and 0 <= t <= self.t_max
                                                  for t in self.snapshots):
            raise InputError(f"snapshot times must lie in [0, t_max = {self.t_max:g}]")


    def check_method(self, method: str | None) -> None:
        """Refuse options that do not apply to ``method`` (None: not known yet)."""
        dem_only = ("amplitude", "damping", "strain", "velocity", "drive", "bin_width")
        given = [k for k in dem_only if getattr(self, k) is not None]
        if method not in (None, "dem") and given:
            names = {"bin_width": "bin"}
            raise InputError(f"{' and '.join('--' + names.get(k, k) for k in given)} apply to --method dem only")
        if method not in (None, "dem") and self.t_max is None:
            raise InputError(f"--method {method} needs --t-max (the record's length)")
        sizes = [k for k in ("amplitude", "strain", "velocity") if getattr(self, k) is not None]
        if len(sizes) > 1:
            raise InputError(f"give one kick size, not {' and '.join('--' + k for k in sizes)}")
        if method == "dem" and self.snapshots is not None:
            raise InputError("--snapshots is not available with --method dem")


# ----------------------------------------------------------------- analyses
@dataclass(frozen=True, kw_only=True)
class StaticsParams(Params):
    """Static characterization of a packing (docs/method.md §4)."""

    ATTR = "statics_params"

    layer: float = param(BULK_LAYER, help="Thickness l excluded next to the bottom wall and the "
                         "piston from the bulk measurements.", units="d", lo=0.0)
    min_contacts: int = param(2, help="Rattler rule: grains with fewer force-carrying contacts are "
                              "rattlers (applied iteratively; 1 = literally no force-carrying "
                              "contact).", lo=1)


@dataclass(frozen=True, kw_only=True)
class ModuliParams(Params):
    """Elastic moduli by imposed strain and linear relaxation (docs/method.md §6)."""

    ATTR = "moduli_params"

    local: bool = param(False, help="Also the body-force (n = 1, 2) and line (n = 1, 3) moduli, as "
                        "ratios to the global ones.")
    prestress: bool = param(False, help="Include the prestress (geometric) terms (a linear file "
                            "brings its own).")
    amplitude: float = param(1e-6, help="Strain amplitude (the linear model makes the result "
                             "independent of it).", lo=0.0, lo_open=True)
    grip: bool | None = param(None, help="Hold the lateral motion of wall-touching grains in the "
                              "shear loadings [default: only for frictionless packings, whose "
                              "walls cannot drag].", negatable=True)
    layer: float = param(BULK_LAYER, help="Layer next to each wall left out of the bulk phi3_star "
                         "and of the bulk slab (docs/method.md §4, docs/moduli.md).", units="d", lo=0.0)
    force: bool = param(False, help="Accept a packing marked as not converged.")


@dataclass(frozen=True, kw_only=True)
class FrontParams(Params):
    """The first-pulse rule of the coherent-front analysis (docs/method.md §9, docs/front.md)."""

    ATTR = "front_params"

    peak_fraction: float = _peak_fraction(0.3)
    lead_fraction: float = param(0.1, help="Leading-edge level, fraction of the first peak.",
                                 lo=0.0, lo_open=True, hi=1.0, hi_open=True)
    noise_fraction: float = param(1e-3, help="Lobes below this fraction of max |F| are ripples and "
                                  "skipped.", lo=0.0, hi=1.0, hi_open=True)


def _front_override():
    """--peak-fraction of the analyses built on the front rule; None: FrontParams' default."""
    return param(None, help="First-pulse rule parameter of `granwave analyze front` (default: its "
                 f"default, {FrontParams.peak_fraction:g}), the same for every signal.",
                 lo=0.0, lo_open=True, hi=1.0)


@dataclass(frozen=True, kw_only=True)
class HeightsParams(Params):
    """Speeds and scaling of the front over container heights (docs/method.md §9)."""

    ATTR = "heights_params"

    edge_heights: tuple = param((8.0, 25.0), help="c_tof, c_peak, c_zero are taken between the "
                                "two nominal heights nearest to these; the fit over all heights "
                                "is reported as *_all.", units="d", metavar="L1,L2")
    group_tolerance: float = param(0.05, help="Heights within this relative gap of each other form "
                                   "one nominal height.", lo=0.0, hi=1.0, hi_open=True)
    peak_fraction: float | None = _front_override()

    def __post_init__(self):
        try:
            pair = tuple(float(h) for h in self.edge_heights)
        except (TypeError, ValueError):
            pair = ()
        if len(pair) != 2 or not all(math.isfinite(h) and h > 0 for h in pair) or pair[0] == pair[1]:
            raise InputError(f"edge heights {self.edge_heights!r} must be two different positive "
                             "heights, e.g. 8,25")
        object.__setattr__(self, "edge_heights", pair)
        super().__post_init__()

    def front_kw(self) -> dict:
        return {} if self.peak_fraction is None else {"peak_fraction": self.peak_fraction}


@dataclass(frozen=True, kw_only=True)
class EnsembleParams(Params):
    """Average signal and rms deviation over packings (docs/method.md §9)."""

    ATTR = "ensemble_params"

    peak_fraction: float | None = _front_override()

    def front_kw(self) -> dict:
        return {} if self.peak_fraction is None else {"peak_fraction": self.peak_fraction}


@dataclass(frozen=True, kw_only=True)
class SpectrumParams(Params):
    """Spectrum statistics and each mode's part in the signal (docs/method.md §7)."""

    ATTR = "spectrum_params"

    ic: str = param("A", help="Initial condition whose weights a_n b_n are analysed.",
                    choices=("A", "B"))
    arrays: bool = param(False, help="With --json, also print omega^2, a_n b_n and PR of every "
                         "mode.", negatable=True)

    def __post_init__(self):
        object.__setattr__(self, "ic", str(self.ic).upper())
        super().__post_init__()


@dataclass(frozen=True, kw_only=True)
class DampingParams(Params):
    """Damping series from DEM signals of one packing (docs/method.md §11)."""

    ATTR = "damping_params"

    tail_start: float | None = param(None, help="Start of the tail window; default: the least "
                                     "damped signal's first zero crossing plus one pulse width.",
                                     units="d/sqrt(E*/rho)", lo=0.0)


@dataclass(frozen=True, kw_only=True)
class SweepParams(Params):
    """Pressure dependence of the speeds and statics (docs/method.md §10)."""

    ATTR = "sweep_params"

    poisson: float = _poisson()
    crossover: bool = param(False, help="Also fit the crossover pressure p* of c_tof, c_l and c_t between "
                            "c ~ p^low below and p^high above (the asperity and Hertz laws; docs/method.md "
                            "§10), with its 95 % interval.")
    crossover_low: float = param(0.25, help="Exponent of the speeds below p* (--crossover).", lo=0.0, lo_open=True)
    crossover_high: float = param(1.0 / 6.0, help="Exponent of the speeds above p* (--crossover).", lo=0.0,
                                  lo_open=True)

    def _cross_check(self):
        if self.crossover_low == self.crossover_high:
            raise InputError("crossover_low and crossover_high must differ (two power laws meet at p*)")


@dataclass(frozen=True, kw_only=True)
class AttenuationParams(Params):
    """Attenuation alpha(omega) and phase velocity c(omega) of the coherent signal over heights."""

    ATTR = "attenuation_params"

    window_widths: float = param(5.0, help="Each height's ensemble-mean signal is kept from t = 0 to "
                                 "its front's zero crossing plus this many front widths "
                                 "(t_zero - t_lead10), or to the end of its shortest record, with a cosine taper over the "
                                 "last width.",
                                 lo=0.0, lo_open=True)
    threshold: float = param(0.05, help="Reliable band: the frequencies, around the spectral peak of "
                             "the tallest height, where every height's spectral amplitude is at least "
                             "this fraction of its own maximum.", lo=0.0, lo_open=True, hi=1.0,
                             hi_open=True)
    max_error: float = param(0.1, help="Reliable band: also the relative error of c(omega) at most "
                             "this.", lo=0.0, lo_open=True)
    min_periods: float = param(1.0, help="A height enters the fits at omega only where the window "
                               "after its front's arrival (t_end - t_lead10) holds at least this many "
                               "periods 2 pi/omega (half a period let alpha come out +70 % high where "
                               "a short column enters).", lo=0.0)
    min_snr: float = param(2.0, help="A height enters the fits at omega only where its coherent amplitude is at least this many times "
                           "the noise floor (standard error of the mean spectrum over its packings).",
                           lo=0.0)
    min_heights: int = param(3, help="Reliable band: at least this many usable heights at omega (fewer "
                             "when fewer heights are given, at least 2).", lo=2)
    min_fit_p: float = param(0.01, help="Reliable band: the chi-square p-value of the ln|S| fit against "
                             "the noise floor at least this (with three or more heights).", lo=0.0,
                             hi=1.0, hi_open=True)
    bootstrap: int = param(200, help="Bootstrap resamplings of the packings at each height for the "
                           "error bars (0: fit errors only).", lo=0)
    seed: int = param(0, help="Seed of the bootstrap resampling.", lo=0, hi=MAX_SEED,
                      why="files store seeds as 64-bit signed integers")
    group_tolerance: float = param(0.05, help="Heights within this relative gap of each other form "
                                   "one nominal height.", lo=0.0, hi=1.0, hi_open=True)
    c_l: float | None = param(None, help="Effective-medium longitudinal speed to compare the "
                              "low-frequency phase velocity with.", units="sqrt(E*/rho)", lo=0.0,
                              lo_open=True)
    omega_cutoff: float | None = param(None, help="The column's first lateral shear cutoff, "
                                       "2 pi c_t / W (W the lateral period): marked on the output and "
                                       "the figure; above it alpha and c are the waveguide's, not the "
                                       "medium's.", units="sqrt(E*/rho)/d", lo=0.0, lo_open=True)
    lateral_period: float | None = param(None, help="The columns' lateral period W: with --moduli "
                                         "the cutoff is 2 pi c_t / W from the packings' mean c_t "
                                         "(unless --omega-cutoff is given).", units="d", lo=0.0,
                                         lo_open=True)
    continuum_c_tolerance: float = param(0.02, help="Continuum length lambda*: the wavelength beyond "
                                         "which |c(omega)/c0 - 1| stays at most this ...",
                                         lo=0.0, lo_open=True, hi=1.0)
    continuum_q_inverse: float = param(0.05, help="... and 1/Q = 2 alpha c_g/omega at most this.",
                                       lo=0.0, lo_open=True)
    peak_fraction: float | None = _front_override()

    def front_kw(self) -> dict:
        return {} if self.peak_fraction is None else {"peak_fraction": self.peak_fraction}


@dataclass(frozen=True, kw_only=True)
class ContinuumParams(Params):
    """Front speeds, amplitude and width against distance, and their approach to c_l."""

    ATTR = "continuum_params"

    tolerance: float = param(0.05, help="L* is the distance beyond which c_tof is within this "
                             "fraction of c_l.", lo=0.0, lo_open=True, hi=1.0, hi_open=True)
    group_tolerance: float = param(0.05, help="Heights within this relative gap of each other form "
                                   "one nominal height.", lo=0.0, hi=1.0, hi_open=True)
    bootstrap: int = param(200, help="Resamplings of the packings within each height, through the "
                           "chain (arrival times, local speeds, ratios, the approach fit and L*), "
                           "for the error bars (0: propagated errors only).", lo=0)
    seed: int = param(0, help="Seed of the bootstrap resampling.", lo=0, hi=MAX_SEED,
                      why="files store seeds as 64-bit signed integers")
    c_l_kind: str = param("slab", cli="--c-l", choices=("slab", "cell"),
                          help="Which c_l of the --moduli files the ratios use: 'slab' "
                          "(c_l_slab, c_t_slab: the bulk slab's moduli over the same slab's "
                          "density) or 'cell' (c_l, c_t: whole-cell moduli over the bulk "
                          "density; docs/continuum.md).")
    peak_fraction: float | None = _front_override()

    def front_kw(self) -> dict:
        return {} if self.peak_fraction is None else {"peak_fraction": self.peak_fraction}
