"""granwave's reduced units, defined once for the ``pint`` units library.

granwave computes in the units of docs/method.md §1: the mean grain diameter
``d_bar``, the grain density ``rho`` and the grain modulus ``E_star`` =
E/(1-nu^2) are 1; time follows as ``t_bar = d_bar (rho/E_star)^(1/2)``. Every
dataset of every granwave HDF5 file carries a ``units`` attribute written in
these names with pint's grammar (``*``, ``/``, ``**``), for example
``"E_star * d_bar**2"`` (a force) or ``"d_bar * (rho / E_star)**0.5"`` (a time).

Load them into pint::

    from granwave.units import registry
    ureg = registry()                          # granwave units as their own dimensions
    ureg.parse_units(ds.attrs["units"])

or give the material to convert to SI (or any unit pint knows)::

    ureg = registry(diameter="2 mm", density="2500 kg/m^3", modulus="70 GPa")
    (3.0 * ureg.parse_units("d_bar * (rho / E_star)**0.5")).to("microsecond")

Without a material the three are new base dimensions ([granwave_length],
[granwave_density], [granwave_modulus]), so quantities of different kinds can
never be mixed up. The same definitions as text: :data:`DEFINITIONS` (pass each
line to ``ureg.define`` to extend a registry of your own).
"""

from __future__ import annotations

#: Reduced units in pint's definition syntax (one per line).
DEFINITIONS = """\
# granwave reduced units (docs/method.md §1)
d_bar = [granwave_length] = dbar  # mean grain diameter
rho = [granwave_density]  # grain material density
E_star = [granwave_modulus] = Estar  # grain modulus E/(1 - nu^2)
t_bar = d_bar * (rho / E_star) ** 0.5 = tbar  # time: d_bar / sqrt(E_star / rho)
"""

#: The three base units, with what they stand for.
BASE_UNITS = {"d_bar": "mean grain diameter", "rho": "grain density",
              "E_star": "grain modulus E/(1-nu^2)"}

# pint units of the quantities granwave stores (the schema's units strings use these).
LENGTH = "d_bar"
MASS = "rho * d_bar**3"
INERTIA = "rho * d_bar**5"
FORCE = "E_star * d_bar**2"
TORQUE = "E_star * d_bar**3"
STIFFNESS = "E_star * d_bar"
PRESSURE = "E_star"
SPEED = "(E_star / rho)**0.5"
TIME = "d_bar * (rho / E_star)**0.5"
ANGULAR_SPEED = "(E_star / rho)**0.5 / d_bar"
OMEGA2 = "E_star / (rho * d_bar**2)"
DIMENSIONLESS = "1"


def registry(*, diameter: str | None = None, density: str | None = None, modulus: str | None = None):
    """A pint ``UnitRegistry`` (pint's defaults plus granwave's units).

    ``diameter``, ``density``, ``modulus``: the material, as quantities pint parses
    ("2 mm", "2500 kg/m^3", "70 GPa"); all three or none. With them, d_bar, rho and
    E_star are defined as those quantities, so every granwave unit converts to SI.
    """
    import pint

    given = [diameter, density, modulus]
    if any(v is not None for v in given) and not all(v is not None for v in given):
        raise ValueError("give diameter, density and modulus together, or none")
    ureg = pint.UnitRegistry()
    if diameter is None:
        for line in DEFINITIONS.splitlines():
            if line and not line.startswith("#"):
                ureg.define(line)
        return ureg
    ureg.define(f"d_bar = {diameter} = dbar")
    ureg.define(f"rho = {density}")
    ureg.define(f"E_star = {modulus} = Estar")
    ureg.define("t_bar = d_bar * (rho / E_star) ** 0.5 = tbar")
    return ureg


#: Grain materials for ``analyze front --units si`` (docs/units.md): Young's modulus, Poisson
#: ratio, density. Glass and steel as docs/units.md's table; quartz (alpha-quartz sand grains,
#: isotropic average) E = 95 GPa, nu = 0.08, rho = 2650 kg/m^3 (suppliers and sands vary:
#: recompute with your own).
MATERIALS = {
    "glass": {"E": 63e9, "nu": 0.23, "rho": 2500.0},
    "quartz": {"E": 95e9, "nu": 0.08, "rho": 2650.0},
    "steel": {"E": 210e9, "nu": 0.29, "rho": 7850.0},
}


def material_scales(material: str, diameter_m: float) -> dict:
    """SI values of granwave's units for a material of :data:`MATERIALS` and a mean grain
    diameter (m): modulus E* = E/(1 - nu^2) (Pa), speed sqrt(E*/rho) (m/s), time
    d/sqrt(E*/rho) (s), density rho (kg/m^3)."""
    from .errors import InputError

    if material not in MATERIALS:
        raise InputError(f"material must be one of {', '.join(MATERIALS)} (got {material!r})")
    if not (diameter_m > 0):
        raise InputError(f"grain diameter must be positive (got {diameter_m} m)")
    m = MATERIALS[material]
    e_star = m["E"] / (1.0 - m["nu"] ** 2)
    speed = (e_star / m["rho"]) ** 0.5
    return {"material": material, **m, "E_star": e_star, "speed": speed, "time": diameter_m / speed,
            "diameter": diameter_m}


def material_record(material: str) -> dict:
    """The material a packing records (attribute ``material``, JSON): its name, Young's modulus
    E (Pa), Poisson ratio nu and density rho (kg/m^3) from :data:`MATERIALS`."""
    from .errors import InputError

    if material not in MATERIALS:
        raise InputError(f"material must be one of {', '.join(MATERIALS)} (got {material!r})")
    return {"name": material, **MATERIALS[material]}


def poisson_mismatch(material: str, poisson: float, *, tolerance: float = 1e-9) -> str | None:
    """Why an SI conversion for ``material`` does not describe a run made with Poisson ratio
    ``poisson`` (the ratio sets eta = k_t/k_n, hence the speeds; docs/units.md), or None when
    they agree. One line, naming both ratios and their eta."""
    from .contact import stiffness_ratio

    nu = MATERIALS[material]["nu"]
    if abs(float(poisson) - nu) <= tolerance:
        return None
    return (f"the packing ran with Poisson ratio {float(poisson):g} (eta = {stiffness_ratio(float(poisson)):.3f}) "
            f"but {material} has {nu:g} (eta = {stiffness_ratio(nu):.3f}): its speeds and moduli "
            f"are not those of {material} grains (prepare with --material {material})")
