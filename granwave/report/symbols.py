"""Every symbol the report and the figures use: one symbol per quantity, with its unit.

:data:`SYMBOLS` is the one list; the report's symbol table is made from it
(:func:`symbol_table`), and :func:`undefined_symbols` finds the symbols a text uses that the
list does not define (tests/test_report.py runs it on the generated report, tests/figure_rules.py on every
figure's labels). The choices (κ for pressure exponents, χ for the width exponent, ν for the
grains' Poisson ratio only, ...) and why: docs/decisions/0038-one-symbol-per-quantity.md.

A symbol is matched as the page writes it; ``forms`` are other spellings of the same symbol
(a Unicode subscript, the figures' mathtext after :func:`plain_text`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass


@dataclass(frozen=True)
class Symbol:
    symbol: str              # as the report writes it
    quantity: str            # what it is
    unit: str = "—"          # "—": dimensionless
    forms: tuple = ()        # other spellings of the same symbol
    key: str = ""            # the JSON key of the inputs, where one holds it


#: Units (docs/method.md §1) in the table's unit column.
LEN, PRES, SPEED, TIME, FORCE, FREQ = "d̄", "E*", "√(E*/ρ)", "d̄/√(E*/ρ)", "E* d̄²", "√(E*/ρ)/d̄"

SYMBOLS: tuple[Symbol, ...] = (
    # ------------------------------------------------------------- units and material
    Symbol("d̄", "mean grain diameter: the unit of length", "—"),
    Symbol("ρ", "density of the grain material: the unit of density", "—"),
    Symbol("E*", "E/(1 − ν²) of the grain material: the unit of pressure and moduli", "—"),
    Symbol("E", "Young's modulus of the grain material", "Pa (SI tables)"),
    Symbol("ν", "Poisson ratio of the grain material (`--poisson`, `poisson`)", key="poisson"),
    Symbol("η", "k_t/k_n = 2(1 − ν)/(2 − ν), the contact's stiffness ratio"),
    Symbol("μ", "friction coefficient (`friction`)", key="friction"),
    Symbol("ζ", "contact damping, a fraction of the critical (`damping`)", key="damping"),
    Symbol("k_n", "normal contact stiffness", "E* d̄"),
    Symbol("k_t", "tangential contact stiffness", "E* d̄"),
    Symbol("F_n", "normal force of a contact", FORCE),
    # ------------------------------------------------------------- the system
    Symbol("p", "pressure on the piston (2D: per wall length × d̄)", PRES, key="pressure"),
    Symbol("L", "source–detector distance, bottom wall to top wall (container height)", LEN,
           key="height"),
    Symbol("L1", "periodic width of the cell", LEN),
    Symbol("N", "number of grains, or of balls in a chain"),
    Symbol("n", "a count: packings, signals or pressures, as each table says"),
    Symbol("l", "thickness of the wall layers left out of bulk statistics", LEN, key="layer"),
    Symbol("x", "horizontal coordinate", LEN),
    Symbol("y", "vertical coordinate (height above the source); z in 3D", LEN, forms=("z",)),
    Symbol("t", "time", TIME),
    Symbol("h", "sampling step of a signal", TIME),
    Symbol("π", "the number π"),
    Symbol("σ", "one standard error (in verdicts: agrees within 1σ)"),
    # ------------------------------------------------------------- statics (docs/method.md §4)
    Symbol("Φ2", "area fraction of the discs", key="phi2", forms=("Φ_2",)),
    Symbol("Φ3", "solid fraction of the spheres in a layer one d̄ thick", key="phi3", forms=("Φ_3",)),
    Symbol("Φ3*", "Φ3 without rattlers: the density in the sound speeds", key="phi3_star",
           forms=("Φ_3*",)),
    Symbol("z*", "force-carrying contacts per non-rattler grain", key="z_star"),
    Symbol("f0", "fraction of rattlers (grains that carry no force)", key="rattler_fraction"),
    Symbol("⟨F_n⟩/p", "mean normal force over the pressure", "d̄²", key="mean_force_over_p"),
    Symbol("Z(2)", "⟨F_n²⟩/⟨F_n⟩², reduced second moment of the normal forces", key="Z2"),
    Symbol("Z(3)", "⟨F_n³⟩/⟨F_n⟩³, reduced third moment", key="Z3"),
    Symbol("F2", "fabric ⟨n_y²⟩ over contacts (1/2 isotropic in 2D)", key="F2",
           forms=("⟨n_y²⟩", "⟨n_y^2⟩")),
    Symbol("F2^S", "F2 over the strong contacts (F_n > ⟨F_n⟩)", key="F2_strong"),
    Symbol("n_y", "vertical component of a contact's unit normal"),
    Symbol("σ1/σ2", "ratio of the principal stresses, horizontal over vertical", key="stress_ratio",
           forms=("σ1", "σ2")),
    # ------------------------------------------------------------- moduli (§6)
    Symbol("C11", "elastic modulus, horizontal normal stress over horizontal strain", PRES,
           forms=("C12", "C22", "C33", "C44", "C55", "C66", "C13", "C23", "C45", "Cij")),
    Symbol("G", "shear modulus of the moduli (2D C33, 3D (C44 + C55)/2)", PRES),
    Symbol("c_ℓ", "longitudinal continuum speed √(C22/Φ3*)", SPEED, key="c_l", forms=("c_l",)),
    Symbol("c_t", "transverse continuum speed √(C33/Φ3*)", SPEED, key="c_t"),
    Symbol("c_ℓ∞", "c_ℓ of a column extrapolated to infinite height (walls out)", SPEED,
           key="c_l_inf", forms=("c_l∞",)),
    # ------------------------------------------------------------- the signal and its front (§8–§9)
    Symbol("F_sig", "the signal: extra vertical force on the top wall", FORCE),
    Symbol("F_top", "total normal force of the top-wall contacts (the nonlinear DEM's signal)", FORCE),
    Symbol("s", "scale of the nonlinear kick (the DEM signal is divided by it)"),
    Symbol("A", "amplitude of the first peak of the signal", FORCE, key="amplitude"),
    Symbol("W", "width of the first pulse, t_zero − t_10", TIME, key="width"),
    Symbol("t_10", "time the first pulse reaches 10 % of its peak", TIME, key="t_lead10",
           forms=("t₁₀",)),
    Symbol("t_peak", "time of the first peak", TIME, key="t_peak"),
    Symbol("t_zero", "first zero crossing after the peak", TIME, key="t_zero"),
    Symbol("t_i", "intercept of an arrival-time fit t = t_i + L/c", TIME),
    Symbol("c", "a speed (which one: its subscript); the chain's ℓ√(K/m)", SPEED),
    Symbol("c_tof", "time-of-flight speed of the 10 % edge: 1/slope of t_10 against L", SPEED,
           key="c_tof"),
    Symbol("c_peak", "speed of the first peak", SPEED, key="c_peak"),
    Symbol("c_zero", "speed of the zero crossing", SPEED, key="c_zero"),
    Symbol("c_theory", "triangular-lattice speed of docs/method.md §12", SPEED),
    Symbol("γ", "amplitude exponent, A ∝ L^−γ", key="gamma"),
    Symbol("χ", "width exponent, W ∝ L^χ (`chi`; `alpha` before the rename)", key="chi"),
    Symbol("γ_eff", "local γ between neighbouring heights", key="gamma_eff"),
    Symbol("χ_eff", "local χ between neighbouring heights", key="chi_eff"),
    Symbol("κ", "pressure exponent: c ∝ p^κ, G ∝ p^κ (`kappa_*`; `alpha_*` before)",
           forms=("κ_tof", "κ_peak", "κ_zero", "κ_ℓ", "κ_t", "κ_s", "κ_p", "κ_G")),
    Symbol("p*", "crossover pressure: c ∝ p^{1/4} below it, p^{1/6} above (`p_star_*` of "
           "`pressure-sweep --crossover`)", PRES, key="p_star_tof"),
    Symbol("a_n b_n", "weight of mode n in the signal (a_n its projection, b_n its coupling)",
           FORCE, forms=("a_n", "b_n")),
    Symbol("ω", "angular frequency", FREQ, key="omega", forms=("ω_max", "ω_c")),
    Symbol("g(ω)", "density of states", TIME),
    Symbol("φ", "a mode shape (translational part)", LEN),
    Symbol("u", "displacement", LEN, forms=("ū_y", "u_y")),
    Symbol("E(y, t)", "row-averaged energy per unit height over the total", "1/d̄"),
    # ------------------------------------------------------------- the chain (§12)
    Symbol("K", "spring stiffness of the chain", "E* d̄"),
    Symbol("ℓ", "spacing of the chain's balls", LEN),
    Symbol("m", "mass of a chain ball", "ρ d̄³"),
    Symbol("t_0", "the chain's wall-to-wall travel time (N + 1)ℓ/c", TIME),
    Symbol("τ", "time after t_0", TIME),
    Symbol("Ai", "the Airy function"),
    # ------------------------------------------------------------- continuum (§14)
    Symbol("r", "c_tof/c_ℓ, local", forms=("r∞",)),
    Symbol("β", "approach exponent, c_tof/c_ℓ − 1 = a L^−β", key="beta"),
    Symbol("a", "approach prefactor of c_tof/c_ℓ − 1 = a L^−β", key="a"),
    Symbol("L*", "shortest L with c_tof/c_ℓ within the tolerance of 1", LEN, key="L_star"),
    Symbol("α", "attenuation of the coherent signal, |S| ∝ e^−αL", "1/d̄", key="alpha"),
    Symbol("S", "Fourier transform of the ensemble-mean signal at one height", FORCE + " " + TIME,
           forms=("|S|",)),
    Symbol("Q", "quality factor ω/(2 α c_g)", key="Q"),
    Symbol("c(ω)", "phase velocity of the coherent signal", SPEED, key="c"),
    Symbol("c_g", "group velocity dω/dk", SPEED, key="c_group"),
    Symbol("k", "wavenumber", "1/d̄"),
    Symbol("c_0", "low-frequency limit of c(ω)", SPEED, key="c0", forms=("c0",)),
    Symbol("c_2", "curvature of the fit c(ω) = c_0 + c_2 ω²", "√(E*/ρ) d̄²", key="c2", forms=("c2",)),
    Symbol("b", "wall term of the fit 1/c_ℓ² = 1/c_ℓ∞² + b/L", "d̄/(E*/ρ)", key="b"),
    Symbol("λ*", "continuum wavelength: above it c and Q⁻¹ stay within their thresholds", LEN,
           key="lambda_star"),
    Symbol("ω*", "angular frequency of λ*", FREQ, key="omega_star"),
    Symbol("L_λ", "distance where the pulse's spectral centroid falls to ω*", LEN, key="L_lambda"),
    # ------------------------------------------------------------- shear (docs/shear.md)
    Symbol("λ", "wavelength of the source pulse", LEN),
    Symbol("f", "frequency of the source pulse", "√(E*/ρ)/d̄ (kHz in SI)"),
    Symbol("V_s", "shear speed from the arrival pick, L/T", SPEED),
    Symbol("V_p", "compressional speed from the arrival pick", SPEED),
    Symbol("V", "a pick's speed L/T (V/c_t: over the moduli's c_t)", SPEED),
    Symbol("T", "travel time of a pick", TIME),
    Symbol("G_max", "small-strain shear modulus Φ3* V_s² (grain density 1)", PRES),
    Symbol("ν_eff", "effective Poisson ratio of a packing (from waves, moduli or the tensor)"),
    # ------------------------------------------------------------- shocks (docs/shocks.md)
    Symbol("v_p", "piston velocity of a push", SPEED, key="piston_velocity"),
    Symbol("ε", "strain behind the front, v_p/V", key="strain"),
    Symbol("δ0", "static strain: mean overlap of the force-carrying contacts over d̄", forms=("δ_0", "δ₀"),
           key="static_strain"),
    Symbol("V_0", "linear front speed of a packing: its front speed at its weakest push", SPEED, key="c0"),
    Symbol("ε×", "crossover strain: where the front speed first reaches 1.1 V_0", key="crossover"),
    Symbol("x×", "the mean-field column's crossover ε×/δ0", key="crossover_mean_field"),
    Symbol("ψ", "strongly nonlinear exponent: V ∝ ε^ψ at ε/δ0 ≥ the window's start", key="tail_exponent"),
    Symbol("α_c", "contact-law exponent: contact force ∝ overlap^(α_c − 1) (Hertz 5/2, harmonic 2)",
           key="alpha"),
)

#: Constants and function names that are not symbols of a quantity.
NOT_SYMBOLS = {"e", "ln", "log", "max", "min", "arg", "d", "Δ", "√", "i", "j"}


def by_symbol() -> dict[str, Symbol]:
    """{spelling: Symbol} over every symbol and its forms."""
    out = {}
    for s in SYMBOLS:
        for form in (s.symbol, *s.forms):
            out[form] = s
    return out


def duplicates() -> list[str]:
    """Spellings defined by two entries of :data:`SYMBOLS` (there must be none)."""
    seen, dup = set(), []
    for s in SYMBOLS:
        for form in {s.symbol, *s.forms}:
            if form in seen:
                dup.append(form)
            seen.add(form)
    return dup


def symbol_table() -> list[str]:
    """The report's symbol table as Markdown lines."""
    def cell(text):
        return text.replace("|", "\\|")

    lines = ["| symbol | quantity | unit |", "|---|---|---|"]
    for s in SYMBOLS:
        sym = s.symbol + ("".join(f", {f}" for f in s.forms[:6]) if s.forms else "")
        lines.append(f"| {cell(sym)} | {cell(s.quantity)} | {cell(s.unit)} |")
    return lines + [""]


# ---------------------------------------------------------------------- reading text
_SUB = str.maketrans("₀₁₂₃₄₅₆₇₈₉", "0123456789")
_MATH = [(r"\\gamma", "γ"), (r"\\chi", "χ"), (r"\\kappa", "κ"), (r"\\alpha", "α"), (r"\\beta", "β"),
         (r"\\delta", "δ"), (r"\\nu", "ν"), (r"\\mu", "μ"), (r"\\zeta", "ζ"), (r"\\eta", "η"),
         (r"\\lambda", "λ"), (r"\\omega", "ω"), (r"\\phi", "φ"), (r"\\Phi", "Φ"), (r"\\rho", "ρ"),
         (r"\\sigma", "σ"), (r"\\tau", "τ"), (r"\\pi", "π"), (r"\\ell", "ℓ"), (r"\\infty", "∞"),
         (r"\\langle", "⟨"), (r"\\rangle", "⟩"), (r"\\propto", "∝"), (r"\\sqrt", "√"),
         (r"\\bar\s*d", "d̄"), (r"\\bar\s*u", "ū"), (r"\\leq", "≤"), (r"\\geq", "≥"), (r"\\Delta", "Δ"),
         (r"\\max", "max"), (r"\\times", "×"), (r"\\rm\s*", ""), (r"\\mathrm", ""), (r"\\,", " "),
         (r"\\;", " "), (r"\\ ", " "), (r"\\!", "")]


def plain_text(label: str) -> str:
    """A matplotlib label (mathtext between $...$) as the plain text the checker reads:
    Greek letters as characters, ``\\rm``, braces and dollars removed (``$c_{\\rm tof}$`` →
    ``c_tof``, ``$L^*$`` → ``L*``)."""
    s = label
    for pat, rep in _MATH:
        s = re.sub(pat, rep, s)
    s = s.replace("$", "").replace("{", "").replace("}", "")
    s = s.replace("^*", "*").replace("^S", "^S")
    return s


_GREEK = "α-ωΑ-Ωϕ"
_MOD = r"(?:_[\wℓ∞]+|\*|∞|\d\*?)*"
_PATTERNS = [
    rf"(?<![\w])[{_GREEK}]{_MOD}",                # κ_tof, Φ3*, γ_eff, ω*, σ1
    r"(?<![\w./-])[A-Za-z]_[\wℓ∞]+",              # c_tof, V_s, G_max, k_n, t_10, L_λ
    r"(?<![\w./-])[A-Za-z]\*",                    # L*, z*, E*
    r"(?<![\w./-])C\d\d\b",                       # C11 ... C66
    r"(?<![\w./-])(?:F2\^S|F2|Z\(\d\)|L\d)\b",    # fabric, force moments, widths
]
_FORMULA = re.compile(r"(?<![\w./\-`*])([A-Za-z])(?=\s?(?:=|∝|≤|≥|<|>|\^|/\S))")
_CODE = re.compile(r"`[^`]*`")
_LINK = re.compile(r"\]\([^)]*\)|https?://\S+|<[^>]+>")
_PATH = re.compile(r"\b[\w./-]+\.(?:md|py|h5|json|png|pdf|yaml|smk|tsv)\b")


def symbols_in(text: str) -> set[str]:
    """The symbol tokens of ``text`` (Markdown or plain): Greek letters with their subscripts,
    letters with a subscript or a star, moduli C11 …, and single letters used in a formula
    (before =, ∝, ≤, <, ^). Code spans, links and file names are skipped."""
    t = _PATH.sub(" ", _LINK.sub(" ", _CODE.sub(" ", text))).translate(_SUB)
    t = t.replace("₁₀", "_10")
    found = set()
    for pat in _PATTERNS:  # a power (², ³, ⁻¹) is not part of the symbol
        found.update(m.group(0).rstrip("_²³⁻¹") for m in re.finditer(pat, t))
    found.update(m.group(1) for m in _FORMULA.finditer(t))
    return found


def undefined_symbols(text: str) -> set[str]:
    """The tokens of :func:`symbols_in` that :data:`SYMBOLS` does not define (``κ_ℓ`` is
    defined when ``κ`` lists it; ``c_ℓ(L2)`` reads as ``c_ℓ``)."""
    known = by_symbol()
    return {s for s in symbols_in(text) if s not in known and s not in NOT_SYMBOLS}
