"""Exact reference states (docs/method.md §3): the perfect triangular lattice and the 1D chain.

No preparation run is needed: contact forces follow from the pressure and the
geometry, overlaps from inverting the normal contact law (Hertz by default,
:mod:`granwave.contact`; any registered one, :mod:`granwave.contact_models`),
and positions from the overlaps, so the state is an exact equilibrium (the
recorded ``max_acceleration`` is the computed residual, round-off only).

Triangular lattice
------------------
Identical balls of diameter 1 (R = 1/2, mass π/6, inertia m/10), ``width``
balls per row, periodic in x with box length ``width × a`` (a = centre
spacing), ``rows`` rows; odd rows are shifted by a/2. Every ball has two
in-row neighbours and, except in the first and last row, two neighbours in
the row above and two below (at ±60°), all at distance a. The row spacing is
h = a √3/2.

Contact forces: in the perfect (isotropic) lattice all six contacts of a
ball are equally compressed, so the geometry stays exactly equilateral.
Vertical stress p (docs/method.md §1: force per wall length × one diameter) through a
horizontal line crosses two inclined contacts per ball, i.e. per length a:
2 f sin60° = p a, hence **f = p a/√3** (a = 1 − δ, δ the normal law's overlap at
force f: solved self-consistently, so σ22 = p holds exactly and not only to
leading order in p). The bulk lateral stress is then σ11 = p too. A ball of
the first row rests on the bottom wall by one contact that carries the
vertical push of its two upper neighbours, **f_wall = √3 f = p a**, so the
wall force per length is p; the last row presses on the top wall the same
way. Balls of the first and last row have 5 contacts (4 grains + wall).

Stiffnesses: the normal law's k_n and the tangential law's k_t (Hertz and Mindlin
by default) for every contact, also when ``friction = 0`` (the linearization ignores
k_t then). The tangential forces are zero.

1D chain
--------
N balls on the vertical axis between the bottom wall (0) and the top wall
(``box[0]``). "Pressure" in 1D is a force per d̄² (d̄ = 1): every contact,
walls included, carries the force p. Springs are linear with the same
stiffness K on every contact (walls included), docs/method.md §3;
default K = the Hertz k_n of two unit balls at contact force p. With
``stiffness_model="hertz"`` each contact instead gets its own Hertz k_n
(radii-dependent; wall contacts use the wall law) — not the default of docs/method.md §3;
``"law"`` does the same with any registered normal law (``contact_law=...``).
Overlaps are consistent with the spring law: δ = p/K for linear springs,
the Hertz overlap at force p for ``"hertz"``. Polydisperse chains have
diameters uniform in [1 − W, 1 + W] (seeded); masses ρπd³/6 vary with them.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from . import contact
from .errors import InputError
from .geometry import grain_inertia, grain_mass
from .model import BOTTOM_WALL, TOP_WALL
from .model import Contacts, Packing
from .resources import check_chain, check_lattice

SQRT3 = math.sqrt(3.0)


def hertz_overlap(force: float, r12: float, e12: float) -> float:
    """Overlap at which :func:`granwave.contact.normal_force` equals ``force`` (exact inverse)."""
    return float((force / contact.normal_force(1.0, r12, e12)) ** (2.0 / 3.0))


def _net_force(n: int, contacts: Contacts) -> np.ndarray:
    """Net contact force (n, dim) on every grain (tangential forces are zero here: no torques)."""
    f_on_i = -contacts.force_normal[:, None] * contacts.normal + contacts.force_tangential
    force = np.zeros((n, contacts.normal.shape[1]))
    np.add.at(force, contacts.i, f_on_i)
    pair = contacts.j >= 0
    np.add.at(force, contacts.j[pair], -f_on_i[pair])
    return force


def _check_common(pressure, friction, poisson):
    if not (np.isfinite(pressure) and pressure > 0):
        raise InputError(f"pressure must be positive and finite (E* units), got {pressure}")
    if not (np.isfinite(friction) and friction >= 0):
        raise InputError(f"friction must be >= 0, got {friction}")
    if not (0.0 <= poisson < 0.5):  # the range of every stage (granwave.params)
        raise InputError(f"poisson must be in [0, 0.5), got {poisson}")


def triangular_lattice(*, rows: int, width: int, pressure: float, friction: float = 0.0,
                       poisson: float = 0.0, **submodels) -> Packing:
    """Perfect triangular lattice of unit balls under vertical stress ``pressure`` (module docstring).

    rows >= 2 rows of width >= 3 balls; pressure in E* (force per wall length
    × one diameter); friction μ and Poisson ratio ν recorded and used for k_t;
    ``submodels``: the normal law and its parameters by the names of ``PrepareParams``' fields
    (``contact_law``, ...; granwave.contact_models.options; recorded in the attributes when not
    the default); sub-models of the other kinds are refused (a lattice has no history).
    """
    from . import contact_models as CM
    from .contact_models import options as CO

    values = CO.resolve(submodels, "triangular_lattice")
    try:
        module, law = CM.normal_law(values)
    except ValueError as e:
        raise InputError(str(e)) from None
    for option, name in CO.off_kinds_on(values):
        raise InputError(f"a lattice has no {CO.SUBMODELS[name]['description']} (--{option.replace('_', '-')} "
                         f"{name})")
    if int(rows) != rows or rows < 2:
        raise InputError(f"rows must be an integer >= 2, got {rows}")
    if int(width) != width or width < 3:
        raise InputError(f"width must be an integer >= 3 (periodic neighbours must differ), got {width}")
    rows, width = int(rows), int(width)
    check_lattice(rows, width)  # refuse a request that cannot fit, before allocating
    _check_common(pressure, friction, poisson)
    radius = 0.5
    r12_g, e12_g = contact.effective_radius(1 / radius, 1 / radius), contact.effective_young(False)
    r12_w, e12_w = contact.effective_radius(1 / radius, 0.0), contact.effective_young(True)

    # f = p a / sqrt(3) with a = 1 - delta(f): F_hertz(delta) - p (1 - delta)/sqrt(3) is increasing.
    def excess(delta):
        return CM.law_force(law, delta, math.sqrt(r12_g), e12_g) - pressure * (1.0 - delta) / SQRT3

    delta_g = optimize.brentq(excess, 0.0, 1.0, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=200)
    a = 1.0 - delta_g
    f_g = pressure * a / SQRT3
    f_w = pressure * a  # wall force per ball: p times the wall length per ball (a) times 1 d
    delta_w = CM.overlap_at_force(values, f_w, r12_w, e12_w)
    h = a * SQRT3 / 2.0
    y0 = radius - delta_w
    if not (y0 > 0.0 and a > 0.0):
        raise InputError(f"pressure {pressure:g} is too large: the wall overlap {delta_w:.3g} leaves "
                         f"no positive spacing between the first row and the wall (radius {radius})")

    tangential = CM.model_of("tangential", {**values, "friction": float(friction), "poisson": float(poisson)})

    def kt_of(delta, r12, e12, wall):
        """The tangential law's k_t (Mindlin: the normal law's own)."""
        kt_law = CM.law_tangential_stiffness(law, delta, r12, contact.effective_shear(poisson, wall))
        return CM.tangential_spring(tangential, kt_law, delta, e12)

    row = np.repeat(np.arange(rows), width)
    col = np.tile(np.arange(width), rows)
    position = np.stack([(col + 0.5 * (row % 2)) * a, y0 + row * h], axis=1)
    box = np.array([width * a, 2.0 * y0 + (rows - 1) * h])

    def idx(r, k):
        return r * width + np.mod(k, width)

    ci, cj = [], []
    for r in range(rows):
        k = np.arange(width)
        ci.append(idx(r, k)); cj.append(idx(r, k + 1))  # right neighbour
        if r + 1 < rows:
            left = k - 1 if r % 2 == 0 else k  # upper-left neighbour's column
            ci += [idx(r, k), idx(r, k)]; cj += [idx(r + 1, left), idx(r + 1, left + 1)]
    i = np.concatenate(ci).astype(np.int64)
    j = np.concatenate(cj).astype(np.int64)
    # normals from the positions (nearest periodic image), as every analysis computes them
    d = position[j] - position[i]
    d[:, 0] -= box[0] * np.round(d[:, 0] / box[0])
    normal = d / np.linalg.norm(d, axis=1)[:, None]
    bottom = np.arange(width)
    top = (rows - 1) * width + np.arange(width)
    i = np.concatenate([i, bottom, top]).astype(np.int64)
    j = np.concatenate([j, np.full(width, BOTTOM_WALL), np.full(width, TOP_WALL)]).astype(np.int64)
    normal = np.concatenate([normal, np.tile([0.0, -1.0], (width, 1)), np.tile([0.0, 1.0], (width, 1))])
    wall = j < 0
    m = len(i)
    contacts = Contacts(
        i=i, j=j, normal=normal,
        overlap=np.where(wall, delta_w, delta_g),
        force_normal=np.where(wall, f_w, f_g),
        force_tangential=np.zeros((m, 2)),
        stiffness_normal=np.where(wall, CM.law_stiffness(law, delta_w, math.sqrt(r12_w), e12_w),
                                  CM.law_stiffness(law, delta_g, math.sqrt(r12_g), e12_g)),
        stiffness_tangential=np.where(wall, kt_of(delta_w, r12_w, e12_w, True), kt_of(delta_g, r12_g, e12_g, False)),
    )
    n = rows * width
    mass = grain_mass(np.full(n, radius))
    force = _net_force(n, contacts)
    residual = float(np.max(np.linalg.norm(force, axis=1) / mass))
    attrs = dict(kind="lattice", pressure=float(pressure), friction=float(friction),
                 poisson=float(poisson), seed=0, converged=True, max_acceleration=residual,
                 rows=rows, width=width, spacing=a, row_spacing=h, contact_force=f_g,
                 wall_force=f_w)
    attrs.update(CO.attrs_of(values, recorded=False))  # files without it: the default law
    return Packing(position=position, radius=np.full(n, radius), mass=mass,
                   inertia=grain_inertia(np.full(n, radius)), box=box, contacts=contacts, attrs=attrs)


def default_chain_stiffness(pressure: float) -> float:
    """Hertz k_n (E* d) of two unit balls pressed together by the force ``pressure`` × 1 d²."""
    r12, e12 = contact.effective_radius(2.0, 2.0), contact.effective_young(False)
    return float(contact.normal_stiffness(hertz_overlap(pressure, r12, e12), r12, e12))


def chain(*, n_balls: int, pressure: float, polydispersity: float = 0.0, seed: int = 0,
          stiffness: float | None = None, stiffness_model: str = "equal", **submodels) -> Packing:
    """1D chain of ``n_balls`` balls between two walls under force ``pressure`` × 1 d² (module docstring).

    polydispersity W: diameters uniform in [1 − W, 1 + W] (0 <= W < 1, drawn
    with ``numpy.random.default_rng(seed)``). ``stiffness`` K (E* d) of every
    spring, walls included; None = :func:`default_chain_stiffness`.
    ``stiffness_model="law"`` gives every contact its own k_n of the normal law of ``submodels``
    (``contact_law`` and its parameters by the names of ``PrepareParams``' fields; Hertz by
    default) at force p instead; ``"hertz"``: the same with Hertz.
    """
    if int(n_balls) != n_balls or n_balls < 1:
        raise InputError(f"n_balls must be a positive integer, got {n_balls}")
    n = int(n_balls)
    check_chain(n)  # refuse a request that cannot fit, before allocating
    _check_common(pressure, 0.0, 0.0)
    if not (np.isfinite(polydispersity) and 0.0 <= polydispersity < 1.0):
        raise InputError(f"polydispersity must be in [0, 1), got {polydispersity}")
    if stiffness_model not in ("equal", "hertz", "law"):
        raise InputError(f"stiffness_model must be 'equal', 'hertz' or 'law', got {stiffness_model!r}")
    if stiffness_model != "equal" and stiffness is not None:
        raise InputError(f"give either a stiffness K or stiffness_model={stiffness_model!r}, not both")
    from . import contact_models as CM
    from .contact_models import options as CO

    values = CO.resolve(submodels, "chain")
    if stiffness_model == "hertz":
        values[CO.KINDS["normal"]["option"]] = CO.KINDS["normal"]["default"]
    try:
        _, law = CM.normal_law(values)
    except ValueError as e:
        raise InputError(str(e)) from None
    for option, name in CO.off_kinds_on(values):
        raise InputError(f"a chain has no {CO.SUBMODELS[name]['description']} (--{option.replace('_', '-')} {name})")
    if stiffness_model == "law" and CO.selected(values)["normal"] == CO.KINDS["normal"]["default"]:
        stiffness_model = "hertz"  # the default law: the files of stiffness_model 'hertz', bit for bit
    if stiffness is not None and not (np.isfinite(stiffness) and stiffness > 0):
        raise InputError(f"stiffness must be positive and finite, got {stiffness}")
    if int(seed) != seed or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed}")

    if polydispersity > 0:
        diameter = np.random.default_rng(int(seed)).uniform(1 - polydispersity, 1 + polydispersity, n)
    else:
        diameter = np.ones(n)
    radius = diameter / 2.0
    # contacts: bottom wall, pairs (k, k+1), top wall — in order along the chain
    i = np.concatenate([[0], np.arange(n - 1), [n - 1]]).astype(np.int64)
    j = np.concatenate([[BOTTOM_WALL], np.arange(1, n), [TOP_WALL]]).astype(np.int64)
    normal = np.concatenate([[-1.0], np.ones(n - 1), [1.0]])[:, None]
    wall = j < 0
    inv_rj = np.where(wall, 0.0, 1.0 / radius[np.maximum(j, 0)])
    r12 = np.array([contact.effective_radius(1.0 / radius[a], b) for a, b in zip(i, inv_rj)])
    e12 = np.array([contact.effective_young(bool(w)) for w in wall])
    if stiffness_model == "hertz":
        overlap = np.array([hertz_overlap(pressure, r, e) for r, e in zip(r12, e12)])
        k = np.array([contact.normal_stiffness(d, r, e) for d, r, e in zip(overlap, r12, e12)])
        k_record = None  # each contact its own (stiffness_model): no one K (a file's "none")
    elif stiffness_model == "law":
        overlap = np.array([CM.overlap_at_force(values, pressure, r, e) for r, e in zip(r12, e12)])
        k = np.array([CM.law_stiffness(law, d, math.sqrt(r), e) for d, r, e in zip(overlap, r12, e12)])
        k_record = None
    else:
        K = default_chain_stiffness(pressure) if stiffness is None else float(stiffness)
        k = np.full(n + 1, K)
        overlap = np.full(n + 1, pressure / K)  # linear spring: F = K delta
        k_record = K
    # positions from the overlaps: centre distance R_i + R_j - delta
    gaps = np.concatenate([[radius[0] - overlap[0]], radius[:-1] + radius[1:] - overlap[1:-1]])
    x = np.cumsum(gaps)
    height = x[-1] + radius[-1] - overlap[-1]
    if np.any(gaps <= 0) or height <= 0:
        raise InputError("pressure too large for this stiffness: overlaps exceed the radii and "
                         "leave no positive spacing")
    contacts = Contacts(i=i, j=j, normal=normal, overlap=overlap, force_normal=np.full(n + 1, float(pressure)),
                        force_tangential=np.zeros((n + 1, 1)), stiffness_normal=k,
                        stiffness_tangential=np.zeros(n + 1))
    position = x[:, None]
    box = np.array([height])
    mass = grain_mass(radius)
    force = _net_force(n, contacts)
    residual = float(np.max(np.abs(force[:, 0]) / mass))
    attrs = dict(kind="chain", pressure=float(pressure), friction=0.0, poisson=0.0, seed=int(seed),
                 converged=True, max_acceleration=residual, n_balls=n,
                 polydispersity=float(polydispersity), stiffness=k_record,
                 stiffness_model=stiffness_model, pressure_meaning="force per mean diameter squared")
    if stiffness_model == "law":
        attrs.update(CO.attrs_of(values, recorded=False))
    return Packing(position=position, radius=radius, mass=mass, inertia=grain_inertia(radius),
                   box=box, contacts=contacts, attrs=attrs)


#: Lateral period (d) of the 2D column a chain is run in by the DEM engine: wide enough that a ball
#: never touches its own periodic image (diameters < 2) and the neighbour cells fit.
COLUMN_WIDTH = 3.0


def chain_column(packing: Packing, width: float = COLUMN_WIDTH) -> Packing:
    """The 1D chain ``packing`` as a 2D packing: the balls on the vertical line x = width / 2 of a
    box periodic in x with period ``width``, every contact along the vertical, the same overlaps,
    forces and stiffnesses. The DEM engine (2D and 3D only) runs the chain this way: with every
    force along z and no lateral contact, no grain ever moves sideways, so the motion is the
    chain's (docs/shocks.md). A chain of equal linear springs (``stiffness_model`` "equal") is
    refused: its overlaps are p / K, not those of a contact law the engine runs."""
    if packing.dim != 1 or packing.attrs.get("kind") != "chain":
        raise InputError("chain_column takes a 1D chain (granwave chain)")
    if packing.attrs.get("stiffness_model", "equal") == "equal":
        raise InputError("the DEM runs a chain made with a contact law (granwave chain --stiffness-model "
                         "hertz or law); a chain of equal springs (stiffness_model equal) has none")
    if not float(np.max(packing.radius)) * 2.0 < width:
        raise InputError(f"column width {width:g} must exceed the largest diameter")
    c = packing.contacts
    n = packing.n_grains
    zeros = np.zeros(len(c))
    contacts = Contacts(i=c.i, j=c.j, normal=np.column_stack([zeros, c.normal[:, 0]]), overlap=c.overlap,
                        force_normal=c.force_normal, force_tangential=np.zeros((len(c), 2)),
                        stiffness_normal=c.stiffness_normal, stiffness_tangential=c.stiffness_tangential)
    position = np.column_stack([np.full(n, 0.5 * width), packing.position[:, 0]])
    attrs = dict(packing.attrs, dim=2, column_width=float(width))
    return Packing(position=position, radius=packing.radius, mass=packing.mass, inertia=packing.inertia,
                   box=np.array([float(width), float(packing.box[0])]), contacts=contacts, attrs=attrs)
