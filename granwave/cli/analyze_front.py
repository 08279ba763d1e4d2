"""``granwave analyze front``: characteristic points of the coherent front (docs/method.md §9)."""

from __future__ import annotations

import click

from ..params import FrontParams
from .common import echo_result, options_from, params_from, stage


@click.command()
@click.argument("signal", type=click.Path(dir_okay=False))
@options_from(FrontParams, json=True)
@click.option("--moduli", "moduli_path", type=click.Path(dir_okay=False), default=None,
              help="Shear signals: `granwave analyze moduli --json` output of the same packing "
                   "(c_t, Phi3*, the shear modulus); the picks' speeds are divided by its c_t.")
@click.option("--pulse", type=click.Choice(["sine", "ricker"]), default="sine", show_default=True,
              help="Shear signals: the source pulse the impulse signal is convolved with.")
@click.option("--response", type=click.Choice(["derivative", "delay"]), default="derivative",
              show_default=True,
              help="Shear signals: the expected impulse response, which sets the matched template "
                   "the picks compare with: derivative (the wall-force detector's delta', template "
                   "w'; docs/method.md section 8) or delay (a pure delay, template w).")
@click.option("--frequency", type=float, default=None,
              help="Shear signals: the pulse's frequency [1/(d/sqrt(E*/rho))]; default c_t / --wavelength.")
@click.option("--wavelength", type=float, default=8.0, show_default=True,
              help="Shear signals: the pulse's wavelength c_t / f in diameters (with --moduli).")
@click.option("--units", type=click.Choice(["reduced", "si"]), default="reduced", show_default=True,
              help="Shear signals: si adds V_s (m/s), G_max (MPa), times (us) for --material.")
@click.option("--material", type=click.Choice(["glass", "quartz", "steel"]), default=None,
              help="Grain material for --units si (granwave.units.MATERIALS) [default: the one the "
                   "packing records (prepare-packing --material), else glass]. Refused where the "
                   "packing's Poisson ratio is not the material's (see --any-poisson).")
@click.option("--any-poisson", is_flag=True,
              help="--units si: convert even where the packing's Poisson ratio is not the "
                   "material's (a warning instead of a refusal; the JSON records the mismatch).")
@click.option("--diameter", type=float, default=1.0, show_default=True,
              help="Mean grain diameter in mm for --units si (times and frequencies scale with it).")
@stage
def front(signal, as_json, moduli_path, pulse, response, frequency, wavelength, units, material, any_poisson,
          diameter, **options):
    """Leading edge, first peak, zero crossing and width of a signal's first pulse.

    SIGNAL is a granwave.signal file (from `granwave propagate`). Printed:
    t_lead10 (first time the first pulse reaches 10% of its peak, linear
    interpolation), t_peak and amplitude (|F| at the peak, parabola through
    three samples; polarity = its sign), t_zero (first zero crossing after
    the peak), width = t_zero - t_lead10, and the height (wall-to-wall
    distance, d) from the file. Times in d/sqrt(E*/rho), forces in E* d^2.

    The first pulse is the first lobe (run of one sign) at least
    --peak-fraction of the largest lobe up to and including the next one;
    lobes under --noise-fraction of max|F| are ignored (docs/front.md).
    A signal whose first pulse does not reach its peak or does not cross
    zero inside the record is refused.

    A shear signal (propagate --source shear) gets the bender-element picks
    instead: first deflection, 10% edge, peak-to-peak, cross-correlation and
    band phase velocity of the signal a --pulse of --frequency would give,
    each against the matched template (--response: w' by default) and the
    same pick on it, and the impulse's own edge and peak; speeds L/t and their ratio to the
    --moduli file's c_t; --units si for V_s and G_max (docs/shear.md).
    """
    from .. import api
    from ..io.files import read_signal

    from ..errors import InputError

    params = params_from(FrontParams, options)
    sig = read_signal(signal)
    given = [name for name in SHEAR_OPTIONS if _given(name)]
    if sig.attrs.get("source_kind", "normal") != "shear":
        if given:  # they would be ignored: the compressional front has no pulse, moduli or units
            raise InputError(f"{signal}: a compressional signal (source_kind normal): "
                             f"{', '.join(_flag(g) for g in given)} "
                             f"{'is' if len(given) == 1 else 'are'} only for shear signals "
                             "(propagate --source shear)")
        out = api.front(sig, params)
        echo_result(out, as_json, title=f"front of {signal}")
        return
    from .moduli_files import moduli_mismatch, read_moduli

    if _given("frequency") and _given("wavelength"):
        raise InputError("--frequency and --wavelength: give one (the frequency is c_t / wavelength)")
    if _given("wavelength") and moduli_path is None:
        raise InputError("--wavelength needs --moduli (its c_t sets the frequency c_t / wavelength)")
    for name in ("material", "any_poisson", "diameter"):
        if _given(name) and units != "si":
            raise InputError(f"--{name.replace('_', '-')} is only for --units si")
    moduli = None
    if moduli_path is not None:
        moduli = read_moduli(moduli_path, required="c_t")
        why = moduli_mismatch(moduli, sig, moduli_path, signal)
        if why is not None:
            raise InputError(f"{moduli_path}: the moduli {why}: they are not of {signal}'s packing")
    mismatch = None
    if units == "si":
        material, mismatch = _si_material(sig, signal, material, any_poisson)
    out = api.shear_front(sig, moduli=moduli, frequency=frequency, wavelength=wavelength, pulse=pulse,
                          response=response,
                          units=units, material=material or "glass", diameter=diameter * 1e-3)
    if mismatch:
        out["si"]["poisson_mismatch"] = mismatch
    if as_json:
        echo_result(out, True, title="")
        return
    click.echo(f"shear arrival picks of {signal}: L = {out['height']:.4g} d, {pulse} pulse f = "
               f"{out['frequency']:.4g}, c_t = {out['c_t']:.4g}")
    si = out.get("si")
    head = f"  {'pick':<18} {'time':>10} {'speed':>10} {'speed/c_t':>10}"
    click.echo(head + (f" {'Vs m/s':>9} {'Gmax MPa':>10}" if si else ""))
    for name, pk in out["picks"].items():
        line = f"  {name:<18} {pk['time']:10.4g} {pk['speed']:10.4g} {pk['ratio']:10.4g}"
        if si:
            line += f" {si[name + '_Vs_m_s']:9.4g} {si[name + '_Gmax_MPa']:10.4g}"
        click.echo(line)
    if si:
        click.echo(f"  {material}, d = {diameter:g} mm: c_t = {si['c_t_m_s']:.4g} m/s, G (moduli) = "
                   f"{si['G_moduli_MPa']:.4g} MPa, f = {si['frequency_kHz']:.4g} kHz")
    for name, why in out["errors"].items():
        click.echo(f"  {name}: {why}", err=True)


#: the options of a shear signal's picks (the compressional front takes none of them)
SHEAR_OPTIONS = ("moduli_path", "pulse", "response", "frequency", "wavelength", "units", "material",
                 "any_poisson", "diameter")


def _flag(name: str) -> str:
    return "--moduli" if name == "moduli_path" else "--" + name.replace("_", "-")


def _given(name: str) -> bool:
    """Whether the option ``name`` was given on the command line (not its default)."""
    source = click.get_current_context().get_parameter_source(name)
    return source is not None and source.name not in ("DEFAULT", "DEFAULT_MAP")


def _si_material(sig, path, material, any_poisson):
    """(material, mismatch) for --units si: the material given, else the packing's recorded one,
    else glass; refused (one line) where the packing's Poisson ratio is not the material's,
    unless --any-poisson (then a warning, and the mismatch returned for the JSON)."""
    import json

    from ..errors import InputError
    from ..units import poisson_mismatch

    recorded = sig.attrs.get("material")
    if material is None:
        material = json.loads(recorded)["name"] if isinstance(recorded, str) and recorded.startswith("{") \
            else "glass"
    why = poisson_mismatch(material, float(sig.attrs.get("poisson", 0.0)))
    if why and not any_poisson:
        raise InputError(f"{path}: --units si --material {material}: {why}; or --any-poisson")
    if why:
        click.echo(f"warning: {path}: {why}", err=True)
    return material, why
