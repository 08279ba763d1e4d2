"""LAMMPS data files, dumps and input decks for granwave packings.

Out: :func:`export_lammps` writes ``DIR/packing.data`` (``atom_style sphere``) and
``DIR/in.granwave``, a deck that reads it and sets up granwave's physics in LAMMPS
(``units lj`` with granwave's reduced units: d_bar = rho = E_star = 1):

- grains: type 1, diameter and density (mass = rho pi d^3 / 6, moment of inertia
  m d^2 / 10: LAMMPS' solid spheres, in 2D too);
- contacts: ``pair_style granular`` with ``hertz`` (F_n = k_n sqrt(R12 n) n,
  k_n = (4/3) E*12), ``tangential mindlin_rescale`` (dF_t = k_t sqrt(R12 n) ds,
  k_t = 8 G*12; the same unloading rescale as granwave's preparation) with Coulomb
  friction mu, and ``damping coeff_restitution`` with ``limit_damping`` (never an
  attractive normal force). LAMMPS' coeff_restitution damping is
  c_n = sqrt(5) x(e) sqrt(m_eff F_n / n), x(e) = -ln e / sqrt(pi^2 + ln^2 e); since
  F_n / n = (2/3) k_n for Hertz, the restitution e with x(e) = zeta sqrt(6/5) gives
  granwave's c_n = 2 zeta sqrt(m_eff k_n) exactly (zeta < sqrt(5/6) = 0.913).
  Tangential damping: LAMMPS' xgammat = c_t / c_n = sqrt(k_t / k_n);
- a harmonic packing (``contact_law`` attribute 'harmonic', granwave.contact_models.harmonic):
  ``hooke`` (F_n = k_n n, k_n = k E*12) and ``tangential linear_history`` (constant
  k_t = 4 G*12 k) instead; LAMMPS' coeff_restitution damping of ``hooke`` is
  c_n = 2 x(e) sqrt(m_eff k_n), so x(e) = zeta, e = exp(-pi zeta / sqrt(1 - zeta^2))
  (zeta < 1);
- the bottom wall: ``fix wall/gran`` at 0 along the vertical axis (rigid: k_n and k_t
  of a wall contact, E*12 = E*, G*12 = G*);
- the piston: a flat rigid wall that moves. LAMMPS has no force-controlled granular
  wall, so the deck carries the piston as one extra point atom (type 2,
  diameter 0, mass M, no pair interaction) whose height drives a
  ``fix wall/gran/region`` plane; the wall's reaction on the grains (its per-atom
  ``contacts`` output, summed) plus the constant load -p A act on that atom, which
  ``fix nve`` integrates along the vertical only. So M h'' = F_grains - p A, as in
  granwave's engine;
- rolling resistance (attribute ``rolling`` 'sds', granwave.contact_models.rolling): ``rolling sds
  k_r gamma_r mu_r`` for pairs and walls, LAMMPS' own model (granwave's F_rcrit is mu_r times the
  elastic normal force, LAMMPS' the total one: the same at rest; the stored rolling displacements,
  like F_t, are not carried);
- background damping gamma (preparation only; 0 for lattices and chains):
  ``fix langevin`` at temperature 0, whose drag is -(m / damp) v and -(I / damp) w,
  i.e. damp = 1 / gamma.

What a data file cannot carry: the tangential contact history. LAMMPS starts every
contact with F_t = 0, so a frictional packing re-settles slightly (by about the
tangential compliance, F_t / k_t ~ the overlaps); a frictionless one is continued
exactly. The data file writes the piston atom last, so ``write_data`` output of the
deck comes back with the piston height (:func:`read_lammps`).

In: :func:`read_lammps` reads a data file (``atom_style sphere``) or a text dump
(``dump custom`` with id, x y z or xs ys zs or xu yu zu, and radius or diameter)
into a :class:`LammpsState`; :mod:`granwave.interop.relax` turns it into a packing.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import contact as C
from .. import contact_models as CM
from ..contact_models import options as CO
from ..errors import InputError
from ..geometry import grain_mass, wall_area
from ..io.files import atomic_text
from ..model import Packing

DATA_NAME = "packing.data"
DECK_NAME = "in.granwave"
#: LAMMPS type of the piston's carrier atom (grains are type 1).
PISTON_TYPE = 2


# ---------------------------------------------------------------- contact law
def restitution_for_damping(zeta: float, scale: float | None = None, law: str = "") -> float:
    """The coefficient of restitution e whose LAMMPS coeff_restitution damping equals
    granwave's c_n = 2 zeta sqrt(m_eff k_n) for a contact whose normal law has the restitution
    scale ``scale`` (module docstring: x(e) = zeta x scale, e.g. sqrt(6/5) for Hertz, 1 for a
    linear spring; the law's ``LAMMPS_RESTITUTION_SCALE``; None: the default law's); ``law`` names
    it in the message."""
    if scale is None:
        module, _ = CM.normal_law(CO.defaults())
        scale, law = module.LAMMPS_RESTITUTION_SCALE, law or module.LAMMPS_NORMAL
    try:
        return CM.module(CO.KINDS["damping"]["default"]).lammps_words(dict(damping=zeta), scale, law,
                                                                      1.0)["restitution"]
    except ValueError as e:
        raise InputError(str(e)) from None


def lammps_coefficients(friction: float, poisson: float, damping: float, law: str | None = None,
                        **contact) -> dict:
    """Coefficients of ``pair_coeff ... NORMAL kn e tangential TANGENTIAL kt xt mu`` (the normal
    law's words, e.g. ``hertz ... mindlin_rescale`` or ``hooke ... linear_history``) for grain pairs
    and for walls, in granwave units, and ``fragments``: the words of the other selected
    sub-models (e.g. ``rolling sds k_r gamma_r mu_r``). ``law`` (or ``contact_law``) and the
    sub-models' parameters by name (granwave.contact_models.options); InputError for an unknown
    law or one without a LAMMPS equivalent."""
    if law is not None:
        contact["contact_law"] = law
    values = CO.resolve(contact, "lammps_coefficients")
    try:
        words, fragments, fixed = CM.lammps_words(values, friction, poisson, damping)
    except ValueError as e:
        message = str(e)
        raise InputError(message if "cannot be expressed" in message or message.startswith("no LAMMPS")
                         else f"no LAMMPS equivalent: {message}") from None
    return dict(words, mu=friction, fragments=fragments, fixed=fixed)


def granular_model(friction: float, poisson: float, damping: float, *, wall: bool, law: str | None = None,
                   **contact) -> str:
    """The granular model words of ``pair_coeff * *`` (grain pairs) or of ``fix wall/gran
    granular`` (``wall``): granwave's contact law in LAMMPS (module docstring), the other selected
    sub-models' words after it (the same coefficients for pairs and walls). ``law`` and
    ``contact``: as :func:`lammps_coefficients`."""
    k = lammps_coefficients(friction, poisson, damping, law, **contact)
    return " ".join([k["fixed"]("wall" if wall else "pair"), *k["fragments"]])


def _law(packing: Packing) -> dict:
    """The packing's contact sub-models (its attributes; the defaults where absent) as keyword
    arguments of :func:`granular_model`."""
    return CO.values_of_attrs(packing.attrs)


# ---------------------------------------------------------------- export
def _box(packing: Packing, margin: float) -> list[tuple[float, float]]:
    """LAMMPS box: periodic lengths from 0, the vertical from the wall (0) to above the piston."""
    d = packing.dim
    box = [(0.0, float(packing.box[a])) for a in range(d - 1)]
    box.append((0.0, float(packing.box[-1]) + margin))
    if d == 2:
        box.append((-0.5, 0.5))
    return box


def data_text(packing: Packing, *, piston_mass: float, margin: float) -> str:
    """The LAMMPS data file (atom_style sphere) of a packing, the piston atom last."""
    d, n = packing.dim, packing.n_grains
    box = _box(packing, margin)
    law = str(packing.attrs.get("contact_law", CO.KINDS["normal"]["default"]))
    lines = [f"granwave packing (pressure {packing.pressure:.17g}, dim {d}, contact_law {law}); units lj = "
             "granwave units",
             "", f"{n + 1} atoms", "2 atom types", ""]
    for name, (lo, hi) in zip(("x", "y", "z"), box):
        lines.append(f"{lo:.17g} {hi:.17g} {name}lo {name}hi")
    lines += ["", "Atoms # sphere", ""]
    pos3 = np.zeros((n, 3))
    pos3[:, :d] = packing.position
    diameter = 2.0 * packing.radius
    density = packing.mass / grain_mass(packing.radius)  # 1 for granwave grains
    for k in range(n):
        x, y, z = pos3[k]
        lines.append(f"{k + 1} 1 {diameter[k]:.17g} {density[k]:.17g} {x:.17g} {y:.17g} {z:.17g}")
    piston = [0.0, 0.0, 0.0]
    piston[d - 1] = float(packing.box[-1])
    # a point particle (diameter 0): the density column is its mass
    lines.append(f"{n + 1} {PISTON_TYPE} 0 {piston_mass:.17g} {piston[0]:.17g} {piston[1]:.17g} {piston[2]:.17g}")
    return "\n".join(lines) + "\n"


def _dt(packing: Packing) -> float:
    """Time step: the packing's own when it records one, else 0.1 sqrt(m_min / (2 k_max)),
    k_max the stiffest stored contact (a conservative explicit step)."""
    dt = packing.attrs.get("dt")
    if isinstance(dt, (int, float)) and dt > 0:
        return float(dt)
    c = packing.contacts
    k = float(np.max(c.stiffness_normal, initial=0.0)) or C.normal_stiffness(1e-3, 0.5, 1.0)
    return 0.1 * math.sqrt(float(packing.mass.min()) / (2.0 * k))


def deck_text(packing: Packing, *, piston_mass: float, steps: int, damping: float,
              background_damping_rate: float, dt: float, margin: float) -> str:
    """The LAMMPS input deck (module docstring) for :func:`data_text`'s file."""
    d = packing.dim
    mu = packing.friction
    poisson = float(packing.attrs.get("poisson", 0.0))
    vert = "yz"[d - 2]
    load = packing.pressure * wall_area(packing.box[:-1])
    pair_model = granular_model(mu, poisson, damping, wall=False, **_law(packing))
    wall_model = granular_model(mu, poisson, damping, wall=True, **_law(packing))
    plane = {2: "0 ${h0} 0 0 -1 0", 3: "0 0 ${h0} 0 0 -1"}[d]
    move = {2: "NULL v_dh NULL", 3: "NULL NULL v_dh"}[d]
    force_col = d + 1  # contacts output: column 1 a contact flag, then fx fy fz (force on the grain)
    free = {2: "0.0 NULL 0.0", 3: "0.0 0.0 NULL"}[d]
    lines = [
        "# granwave packing continued in LAMMPS (granwave export lammps).",
        "# Units lj = granwave's reduced units: mean diameter, grain density and E* = E/(1-nu^2) are 1.",
        f"# pressure {packing.pressure:.17g}  friction {mu:g}  poisson {poisson:g}  damping (zeta) {damping:g}",
        "# Contact law, walls and piston: see granwave.interop.lammps (docstring).",
        "units           lj",
        "atom_style      sphere",
        "atom_modify     map array",
        f"dimension       {d}",
        "boundary        p f p" if d == 2 else "boundary        p p f",
        "comm_modify     vel yes",
        "newton          off",
        f"read_data       {DATA_NAME}",
        "group           grains type 1",
        f"group           piston type {PISTON_TYPE}",
        f"variable        pid equal {packing.n_grains + 1}",
        f"variable        h0 equal {float(packing.box[-1]):.17g}",
        f"variable        load equal {load:.17g}",
        "",
        "pair_style      granular",
        f"pair_coeff      * * {pair_model}",
        f"neigh_modify    exclude type 1 {PISTON_TYPE} exclude type {PISTON_TYPE} {PISTON_TYPE}",
        f"neighbor        {0.25 * 2 * float(packing.radius.max()):.6g} bin",
        "",
        "# bottom wall (rigid, flat) at 0",
        f"fix             bottom grains wall/gran granular {wall_model} {vert}plane 0.0 NULL",
        "# piston: a plane moving with the piston atom",
        f"variable        dh equal {vert}[${{pid}}]-${{h0}}",
        f"region          lid plane {plane} move {move} units box",
        f"fix             top grains wall/gran/region granular {wall_model} region lid contacts",
        f"compute         lidforce grains reduce sum f_top[{force_col}]",
        "variable        fpiston equal -c_lidforce-${load}",
        "fix             push piston addforce " + {2: "0.0 v_fpiston 0.0", 3: "0.0 0.0 v_fpiston"}[d],
        f"fix             guide piston setforce {free}",
        "",
        "fix             move_grains grains nve/sphere",
        "fix             move_piston piston nve",
    ]
    if d == 2:
        lines.append("fix             plane grains enforce2d")
    if background_damping_rate > 0:
        damp = 1.0 / background_damping_rate
        lines += [f"fix             drag grains langevin 0.0 0.0 {damp:.17g} 1 omega yes",
                  f"fix             drag_piston piston langevin 0.0 0.0 {damp:.17g} 1"]
    lines += [
        "",
        f"timestep        {dt:.17g}",
        "thermo_style    custom step ke v_dh c_lidforce",
        "thermo_modify   norm no",
        "thermo          1000",
        f"run             {steps}",
        "write_data      continued.data",
        "",
    ]
    return "\n".join(lines)


def export_lammps(packing: Packing, folder, *, steps: int = 0, damping: float | None = None,
                  background_damping: float | None = None) -> dict:
    """Write ``folder/packing.data`` and ``folder/in.granwave`` (atomically, each; the
    folder is made when missing, its parent must exist).

    ``steps``: the deck's ``run`` length (0: set up, evaluate the forces, write the
    continued data file). ``damping`` (zeta) and ``background_damping`` (the rate gamma,
    1/time) default to the packing's recorded protocol values, else 0. Returns the
    paths and the LAMMPS coefficients used.
    """
    folder = Path(folder)
    if not folder.parent.is_dir():
        raise InputError(f"cannot write {folder}: folder {folder.parent} does not exist")
    if folder.exists() and not folder.is_dir():
        raise InputError(f"cannot write into {folder}: it is a file")
    if packing.n_grains == 0:
        raise InputError("the packing has no grains")
    if packing.dim not in (2, 3):
        raise InputError(f"LAMMPS runs 2D and 3D systems; this packing has dim {packing.dim}")
    attrs = packing.attrs
    zeta = float(attrs.get("damping", 0.0)) if damping is None else float(damping)
    gamma = (float(attrs.get("background_damping_rate", 0.0)) if background_damping is None
             else float(background_damping))
    pm = attrs.get("piston_mass")
    piston_mass = float(pm) if isinstance(pm, (int, float)) and math.isfinite(pm) and pm > 0 else \
        float(packing.mass.mean()) * float(np.prod(packing.box[:-1]))
    margin = 2.0 * float(packing.radius.max())
    contact = _law(packing)
    coefficients = lammps_coefficients(packing.friction, float(attrs.get("poisson", 0.0)), zeta, **contact)
    coefficients.pop("fragments")
    coefficients.pop("fixed")
    data = data_text(packing, piston_mass=piston_mass, margin=margin)
    deck = deck_text(packing, piston_mass=piston_mass, steps=int(steps), damping=zeta,
                     background_damping_rate=gamma, dt=_dt(packing), margin=margin)
    folder.mkdir(exist_ok=True)  # only now: bad input leaves nothing behind
    atomic_text(folder / DATA_NAME, data)
    atomic_text(folder / DECK_NAME, deck)
    return dict(data=folder / DATA_NAME, deck=folder / DECK_NAME, piston_mass=piston_mass,
                grains=packing.n_grains, **coefficients, **CO.attrs_of(contact, recorded=False))


# ---------------------------------------------------------------- import
@dataclass
class LammpsState:
    """Grains read from a LAMMPS file, in the file's own coordinates (3 columns)."""

    position: np.ndarray  # (N, 3)
    radius: np.ndarray  # (N,)
    box_lo: np.ndarray  # (3,)
    box_hi: np.ndarray  # (3,)
    velocity: np.ndarray | None = None  # (N, 3)
    angular_velocity: np.ndarray | None = None  # (N, 3)
    piston: np.ndarray | None = None  # the piston atom's position (3,), when present
    piston_mass: float | None = None  # its mass (data files from export_lammps)
    source: dict = field(default_factory=dict)


def _fail(path, message: str):
    raise InputError(f"{path}: {message}")


def _floats(path, tokens, what: str) -> list[float]:
    try:
        return [float(t) for t in tokens]
    except ValueError:
        _fail(path, f"{what}: not a number in {' '.join(tokens)!r}")


def _default_law_only(path, title: str) -> None:
    """Refuse the data file of a packing made with another normal law than Hertz: the import
    relaxes with Hertz-Mindlin (a harmonic packing's file was relaxed as Hertz without a word).
    The law is read from the title :func:`data_text` writes, else from the ``pair_coeff`` of the
    deck written beside it (``in.granwave``, files exported before the title named the law)."""
    import re

    m = re.search(r"contact_law (\w+)", title)
    law = m.group(1) if m else None
    if law is None:
        deck = Path(path).with_name(DECK_NAME)
        try:
            text = deck.read_text(encoding="utf-8", errors="replace") if deck.is_file() else ""
        except OSError:
            text = ""
        m = re.search(r"^pair_coeff\s+\*\s+\*\s+(\w+)", text, flags=re.M)
        default = CO.KINDS["normal"]["default"]  # Hertz: LAMMPS's word for it is the same
        law = None if m is None else (default if m.group(1) == default else f"LAMMPS {m.group(1)} ({deck.name})")
    if law is not None and law != CO.KINDS["normal"]["default"]:
        _fail(path, f"the packing's contact law is {law}: import lammps relaxes with Hertz-Mindlin "
                    "only, which would make it another packing")


def read_data(path) -> LammpsState:
    """A LAMMPS data file with ``atom_style sphere`` atoms (id type diameter density x y z
    [ix iy iz]); type-2 atoms of diameter 0 (the piston atom of :func:`export_lammps`) give
    the piston height. A Velocities section (id vx vy vz wx wy wz) is read when present."""
    try:
        lines = Path(path).read_text(encoding="utf-8", errors="strict").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        _fail(path, f"cannot read ({getattr(exc, 'strerror', None) or 'not a text file'})")
    title, lines = (lines[0] if lines else ""), lines[1:]  # the first line is a title
    _default_law_only(path, title)
    header: dict[str, list[str]] = {}
    sections: dict[str, tuple[str, list[list[str]]]] = {}
    k = 0
    while k < len(lines):
        text = lines[k].split("#", 1)[0].strip()
        comment = lines[k].split("#", 1)[1].strip() if "#" in lines[k] else ""
        k += 1
        if not text:
            continue
        words = text.split()
        if words[0][0].isalpha():  # a section: its rows follow after a blank line
            name = words[0]
            rows = []
            while k < len(lines) and not lines[k].strip():
                k += 1
            while k < len(lines) and lines[k].strip() and not lines[k].strip()[0].isalpha():
                rows.append(lines[k].split("#", 1)[0].split())
                k += 1
            sections[name] = (comment, rows)
            continue
        for key in ("xlo xhi", "ylo yhi", "zlo zhi", "xy xz yz", "atom types", "atoms"):
            if text.endswith(key):
                header[key] = words[: len(words) - len(key.split())]
                break
    if "atoms" not in header or "Atoms" not in sections:
        _fail(path, "not a LAMMPS data file (no 'atoms' count or no Atoms section)")
    if "xy xz yz" in header and any(float(v) != 0.0 for v in header["xy xz yz"]):
        _fail(path, "triclinic boxes are not supported (granwave's box is orthogonal)")
    style, rows = sections["Atoms"]
    if style and style.split()[0] != "sphere":
        _fail(path, f"unknown atom style {style.split()[0]!r}: granwave reads atom_style sphere "
                    "(id type diameter density x y z)")
    n = int(_floats(path, header["atoms"][:1], "atoms count")[0]) if header["atoms"] else -1
    if len(rows) != n:
        _fail(path, f"the Atoms section has {len(rows)} rows, the header says {n} atoms")
    if n == 0:
        _fail(path, "no atoms (the header says 0 atoms): no grains to import")
    short = [r for r in rows if len(r) < 7]
    if short:
        _fail(path, f"Atoms rows need 7 columns for atom_style sphere (id type diameter density x y z), "
                    f"found {len(short[0])} in {' '.join(short[0])!r}")
    table = np.array([_floats(path, r[:7], "Atoms") for r in rows])
    lo = np.zeros(3)
    hi = np.zeros(3)
    for a, key in enumerate(("xlo xhi", "ylo yhi", "zlo zhi")):
        if key not in header:
            _fail(path, f"missing box line '{key}'")
        lo[a], hi[a] = _floats(path, header[key][:2], key)
    order = np.argsort(table[:, 0], kind="stable")
    table = table[order]
    ids = table[:, 0].astype(np.int64)
    twice = np.flatnonzero(ids[1:] == ids[:-1])  # sorted: a repeated id sits next to itself
    if twice.size:
        _fail(path, f"atom id {ids[twice[0]]} appears more than once in the Atoms section "
                    "(every atom needs its own id)")
    piston_rows = (table[:, 1] == PISTON_TYPE) & (table[:, 2] == 0.0)
    grains = ~piston_rows
    state = LammpsState(position=table[grains, 4:7], radius=0.5 * table[grains, 2], box_lo=lo, box_hi=hi,
                        source=dict(source_format="lammps data (atom_style sphere)"))
    if piston_rows.sum() == 1:
        state.piston = table[piston_rows, 4:7][0]
        state.piston_mass = float(table[piston_rows, 3][0])  # diameter 0: the density column is the mass
    if "Velocities" in sections:
        vrows = sections["Velocities"][1]
        if len(vrows) != n or any(len(r) < 7 for r in vrows):
            _fail(path, "the Velocities section needs one row 'id vx vy vz wx wy wz' per atom")
        v = np.array([_floats(path, r[:7], "Velocities") for r in vrows])
        v = v[np.argsort(v[:, 0], kind="stable")]
        if not np.array_equal(v[:, 0].astype(np.int64), ids):
            _fail(path, "the Velocities section lists other atom ids than the Atoms section")
        state.velocity, state.angular_velocity = v[grains, 1:4], v[grains, 4:7]
    return state


def read_dump(path) -> LammpsState:
    """The last snapshot of a LAMMPS text dump (``dump custom``): columns id, positions
    (x y z, xu yu zu, or scaled xs ys zs) and radius or diameter; vx vy vz and
    omegax omegay omegaz when present."""
    try:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        _fail(path, f"cannot read ({getattr(exc, 'strerror', None) or 'not a text file'})")
    starts = [k for k, line in enumerate(lines) if line.startswith("ITEM: TIMESTEP")]
    if not starts:
        _fail(path, "not a LAMMPS text dump (no 'ITEM: TIMESTEP')")
    block = lines[starts[-1]:]
    try:
        timestep = int(block[1])
        n = int(block[3])
        bounds = block[4].split()
        if bounds[:3] != ["ITEM:", "BOX", "BOUNDS"]:
            raise ValueError
        if len(bounds) > 6:
            _fail(path, "triclinic boxes are not supported (granwave's box is orthogonal)")
        box = np.array([_floats(path, block[5 + a].split()[:2], "BOX BOUNDS") for a in range(3)])
        cols = block[8].split()[2:]
        if not block[8].startswith("ITEM: ATOMS"):
            raise ValueError
    except InputError:
        raise
    except (IndexError, ValueError):
        _fail(path, "malformed dump header (expected TIMESTEP, NUMBER OF ATOMS, BOX BOUNDS, ATOMS)")
    rows = [r.split() for r in block[9: 9 + n]]
    if len(rows) != n or any(len(r) != len(cols) for r in rows):
        _fail(path, f"the last snapshot (timestep {timestep}) has fewer than {n} complete atom rows")
    table = np.array([_floats(path, r, "ATOMS") for r in rows]).reshape(n, len(cols))
    col = {name: k for k, name in enumerate(cols)}
    if "radius" in col:
        radius = table[:, col["radius"]]
    elif "diameter" in col:
        radius = 0.5 * table[:, col["diameter"]]
    else:
        _fail(path, f"the dump has no radius or diameter column (columns: {' '.join(cols)}); "
                    "dump with 'dump ID all custom N file id type radius x y z'")
    lo, hi = box[:, 0], box[:, 1]
    for names, scaled in ((("x", "y", "z"), False), (("xu", "yu", "zu"), False), (("xs", "ys", "zs"), True)):
        if all(c in col for c in names):
            pos = table[:, [col[c] for c in names]]
            if scaled:
                pos = lo + pos * (hi - lo)
            break
    else:
        _fail(path, f"the dump has no positions (x y z, xu yu zu or xs ys zs; columns: {' '.join(cols)})")
    order = np.argsort(table[:, col["id"]], kind="stable") if "id" in col else np.arange(n)
    keep = radius[order] > 0.0
    state = LammpsState(position=pos[order][keep], radius=radius[order][keep], box_lo=lo, box_hi=hi,
                        source=dict(source_format="lammps text dump", source_timestep=timestep))
    if "type" in col:
        pist = (table[order, col["type"]] == PISTON_TYPE) & ~keep
        if pist.sum() == 1:
            state.piston = pos[order][pist][0]
    if all(c in col for c in ("vx", "vy", "vz")):
        state.velocity = table[:, [col[c] for c in ("vx", "vy", "vz")]][order][keep]
    if all(c in col for c in ("omegax", "omegay", "omegaz")):
        state.angular_velocity = table[:, [col[c] for c in ("omegax", "omegay", "omegaz")]][order][keep]
    return state


def read_lammps(path) -> LammpsState:
    """A LAMMPS data file or text dump (told apart by the first line)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    with open(path, encoding="utf-8", errors="replace") as fh:
        first = fh.readline()
    state = read_dump(path) if first.startswith("ITEM: TIMESTEP") else read_data(path)
    if len(state.radius) == 0:
        _fail(path, "no grains (atoms with a positive diameter)")
    for name in ("position", "radius"):
        if not np.all(np.isfinite(getattr(state, name))):
            _fail(path, f"{name}s contain NaN or infinite values")
    if np.any(state.radius <= 0):
        _fail(path, "every grain needs a positive radius")
    state.source.update(source_file=os.path.abspath(path))
    return state


def grains_of_state(state: LammpsState, dim: int | None = None, *, length_scale: float = 1.0) -> dict:
    """granwave's view of a LAMMPS state: positions (N, dim) with the bottom wall at the
    box's lower bound along the vertical (y in 2D, z in 3D), the periodic lengths, the
    piston height (the piston atom's, when the file has one), and velocities.

    ``dim``: 2, 3 or None (2 when every z is equal, as in a LAMMPS 2D run). Lengths are
    multiplied by ``length_scale`` (granwave's unit is the mean diameter); velocities
    are kept only when it is 1 (a file in other units has another time unit too).
    """
    z = state.position[:, 2]
    if dim is None:
        dim = 2 if np.ptp(z) == 0.0 else 3
    if dim not in (2, 3):
        raise InputError(f"dim must be 2 or 3, got {dim}")
    s = float(length_scale)
    if not (math.isfinite(s) and s > 0):
        raise InputError(f"length scale must be a positive number, got {length_scale!r}")
    v = dim - 1
    lo, hi = state.box_lo * s, state.box_hi * s
    position = state.position[:, :dim] * s - lo[:dim]
    radius = state.radius * s
    mean_d = float(2.0 * radius.mean())
    if not 0.5 <= mean_d <= 2.0:
        raise InputError(f"mean grain diameter {mean_d:.4g} is far from granwave's unit (1): give "
                         f"--length-scale {1.0 / mean_d:.6g} to measure lengths in mean diameters")
    out = dict(dim=dim, position=position, radius=radius, lateral=(hi - lo)[: dim - 1],
               piston_height=None if state.piston is None else float(state.piston[v] * s - lo[v]),
               velocity=None, angular_velocity=None)
    if s == 1.0 and state.velocity is not None:
        out["velocity"] = state.velocity[:, :dim].copy()
        if state.angular_velocity is not None:
            out["angular_velocity"] = (state.angular_velocity[:, 2:3] if dim == 2
                                       else state.angular_velocity).copy()
    return out


def lammps_module():
    """The ``lammps`` Python module (PyPI ``lammps``), or None when it is not installed.

    The PyPI wheel links libmpi.so.12, which the ``mpich`` wheel installs into the
    environment's lib/ folder; when the loader does not find it there
    (LD_LIBRARY_PATH unset), it is loaded from there first.
    """
    import ctypes
    import importlib
    import sys

    try:
        lmp = importlib.import_module("lammps")
        lmp.lammps  # noqa: B018  (the import itself succeeds; loading the library may not)
    except ImportError:
        return None
    try:
        lmp.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"]).close()
        return lmp
    except OSError:
        lib = Path(sys.prefix) / "lib" / "libmpi.so.12"
        if not lib.is_file():
            return None
        ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)
    try:
        lmp.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"]).close()
    except OSError:
        return None
    return lmp


def run_deck(folder, lammps=None) -> Path:
    """Run ``folder/in.granwave`` with the LAMMPS Python module (serial) inside ``folder``;
    returns the path of the continued data file it writes."""
    lmp = lammps or lammps_module()
    if lmp is None:
        raise InputError("the lammps Python module is not available (pip install lammps mpich)")
    folder = Path(folder).resolve()
    here = os.getcwd()
    os.chdir(folder)
    try:
        L = lmp.lammps(cmdargs=["-log", "log.lammps", "-screen", "none", "-nocite"])
        try:
            L.file(DECK_NAME)
        finally:
            L.close()
    finally:
        os.chdir(here)
    return folder / "continued.data"
