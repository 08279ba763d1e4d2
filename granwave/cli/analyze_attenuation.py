"""``granwave analyze attenuation``: alpha(omega), Q(omega) and c(omega) of the coherent signal."""

from __future__ import annotations

import click

from ..params import AttenuationParams
from .common import echo_json, echo_table, options_from, params_from, stage


@click.command()
@click.argument("signals", nargs=-1, type=click.Path(dir_okay=False))
@click.option("--moduli", "moduli_paths", multiple=True, type=click.Path(dir_okay=False),
              help="`granwave analyze moduli --json` output of the packings: one per signal, in "
                   "the order of SIGNALS (then the bulk-slab c_l of the packings of the heights "
                   "that enter the fits is the reference of c0 and lambda*), or any number (their "
                   "mean c_l); with --lateral-period their mean c_t gives the lateral cutoff. "
                   "--c-l overrides the reference.")
@options_from(AttenuationParams, json=True)
@stage
def attenuation(signals, moduli_paths, as_json, **options):
    """Attenuation and phase velocity against frequency from signals at several heights.

    SIGNALS are signal files (from `granwave propagate`, or any granwave.signal file) of
    containers of two or more heights L (attribute `height`, in d), one or more packings
    per height (each packing once), one pressure, one initial condition and one kind of column
    (dimension, friction, law, width; compressional signals). Per nominal height the signals are
    averaged (the coherent signal), windowed from t = 0 to the front's zero crossing plus
    --window-widths front widths (cosine taper over the last width) and Fourier
    transformed. At every frequency omega: ln|S(omega, L)| = const - alpha L and the
    unwrapped phase = const - k L are straight lines over the heights, weighted by each
    height's variance of ln|S| and of the phase over its packings, |S| debiased for the
    incoherent remainder (|S|^2 - noise^2); alpha(omega) in 1/d, c(omega) = omega/k in
    sqrt(E*/rho), group velocity c_g = d omega/dk, Q = omega / (2 alpha c_g). Error bars: the
    larger of the fit's standard error and the bootstrap over packings (--bootstrap). Fewer
    than 10 packings at a height: a warning, the result is not quotable; a height with one
    packing takes the variance pooled over the others. --omega-cutoff marks the column's
    first lateral shear cutoff 2 pi c_t/W (the waveguide's, not the medium's, above it); with
    --moduli and --lateral-period W it is computed from the packings' mean c_t. At each omega
    a height is used only where the window after its front's arrival holds --min-periods
    periods and its coherent amplitude is --min-snr times its noise floor (the standard
    error of the mean spectrum over its packings). Reliable band: around the tallest
    height's spectral peak, where at least --min-heights heights are usable, the ln|S| fit's
    chi-square p-value against the noise floor is at least --min-fit-p, every usable
    height's |S| is at least --threshold of its maximum and c is known to --max-error
    (relative). c0: c = c0 + c2 omega^2 over the band's lowest octave (its error includes the
    spread over fit spans and forms; c0_lower_bound: c at the band's bottom, what the band
    itself says; with --moduli or --c-l also c0_over_c_l and its bound
    c0_over_c_l_lower_bound). lambda*: the wavelength above which |c/c_ref - 1| <=
    --continuum-c-tolerance and 1/Q <= --continuum-q-inverse, c_ref the c_l of the
    contributing heights' packings (--moduli, one per signal), else --c-l, else c0; which
    threshold sets it and whether it lies above the lateral cutoff are printed. See
    docs/continuum.md.
    """
    from ..analysis.attenuation import attenuation as run
    from ..errors import InputError
    from ..io.files import read_signal

    params = params_from(AttenuationParams, options)
    if not signals:
        raise InputError("no signal files given")
    from .analyze_continuum import distinct_files
    from .moduli_files import check_moduli_of

    distinct_files(signals, "signal")
    sigs = [read_signal(p) for p in signals]
    if len(moduli_paths) == len(signals):  # one per signal, in their order: each of its packing
        distinct_files(moduli_paths, "--moduli")
        check_moduli_of(moduli_paths, sigs, signals)
    c_l, omega_cutoff = reference_speeds(params, moduli_paths, len(signals))
    res = run(sigs, labels=list(signals),
              group_rtol=params.group_tolerance, window_widths=params.window_widths,
              threshold=params.threshold, max_error=params.max_error,
              min_periods=params.min_periods, min_snr=params.min_snr, min_heights=params.min_heights,
              min_fit_p=params.min_fit_p, bootstrap=params.bootstrap, seed=params.seed,
              c_l=c_l, omega_cutoff=omega_cutoff, c_tol=params.continuum_c_tolerance,
              q_tol=params.continuum_q_inverse, **params.front_kw())
    res["params"] = params.as_dict()
    if as_json:  # the JSON carries the rule's verdict (packings.warning) for the report
        echo_json(res)
        return
    if res["packings"]["warning"]:  # the rule of granwave.analysis.packings, said every time
        click.echo(f"warning: {res['packings']['warning']}")
    scalars = {k: v for k, v in res.items() if not hasattr(v, "__len__") or isinstance(v, str)}
    scalars["band"] = res["band"]
    echo_table(scalars, title=f"attenuation: {res['n_signals']} signals, {len(res['heights'])} heights")
    m = res["reliable"]
    cl = res["continuum_length"]
    above = cl.get("omega_star_above_cutoff")
    click.echo(f"  continuum length: |c/c_ref - 1| <= {cl['c_tolerance']:g} and 1/Q <= "
               f"{cl['q_inverse_tolerance']:g}, c_ref = {cl.get('reference')} = {cl.get('c_ref', float('nan')):.4g}: "
               f"{cl['status']}, lambda* = {cl['lambda_star']:.4g} d "
               f"(95 % {cl.get('lambda_star_ci')}; bootstrap {cl.get('lambda_star_boot_ci')}), "
               f"omega* = {cl['omega_star']:.4g}, set by {cl.get('binding')}"
               + ("" if above is None else (", above the lateral cutoff" if above else ", below the lateral cutoff"))
               + f"; the pulse's spectral centroid reaches omega* at L = {cl['L_lambda']:.4g} d "
               f"({cl['L_lambda_status']})")
    cut = res.get("omega_cutoff")
    click.echo(f"  {'omega':>10} {'alpha':>12} {'err':>10} {'c':>10} {'err':>10} {'c_group':>10} "
               f"{'Q':>10}")
    idx = [i for i in range(len(m)) if m[i]]
    for i in idx[:: max(1, len(idx) // 12)]:
        mark = "  above the lateral cutoff" if cut is not None and res["omega"][i] > cut else ""
        click.echo(f"  {res['omega'][i]:10.4g} {res['alpha'][i]:12.4g} {res['alpha_err'][i]:10.2g} "
                   f"{res['c'][i]:10.4g} {res['c_err'][i]:10.2g} {res['c_group'][i]:10.4g} "
                   f"{res['Q'][i]:10.4g}{mark}")


def reference_speeds(params: AttenuationParams, moduli_paths, n_signals: int | None = None):
    """(c_l, omega_cutoff) of the analysis: the options' values, else from the moduli files
    (bulk-slab c_l: one per signal when there is one file per signal, in the order of the
    signals — the analysis then takes the packings of the heights that enter its fits — else
    their mean; 2 pi mean c_t / --lateral-period). InputError for --lateral-period without
    --moduli, or moduli files without a finite speed."""
    import math

    import numpy as np

    from ..analysis.attenuation import lateral_cutoff
    from ..errors import InputError
    from .moduli_files import moduli_speeds

    if params.lateral_period is not None and not moduli_paths and params.omega_cutoff is None:
        raise InputError("--lateral-period needs --moduli (the packings' c_t), or give --omega-cutoff")
    c_l, cutoff = params.c_l, params.omega_cutoff
    if not moduli_paths:
        return c_l, cutoff
    speeds = moduli_speeds(moduli_paths, "slab")["slab"]
    mean_l, mean_t = (float(np.nanmean(v)) if np.isfinite(v).any() else math.nan
                      for v in (np.asarray(s, float) for s in speeds))
    if not (math.isfinite(mean_l) and math.isfinite(mean_t)):
        raise InputError("the --moduli files give no finite c_l_slab / c_t_slab")
    if c_l is None:
        per_signal = np.asarray(speeds[0], float)
        c_l = per_signal if n_signals == len(moduli_paths) else mean_l
    if cutoff is None and params.lateral_period is not None:
        cutoff = lateral_cutoff(mean_t, params.lateral_period)
    return c_l, cutoff
