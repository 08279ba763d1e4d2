"""``granwave analyze continuum``: the front against distance and its approach to c_l."""

from __future__ import annotations

import click

from ..params import ContinuumParams
from .common import echo_json, echo_table, options_from, params_from, stage
from .moduli_files import check_moduli_of, moduli_speeds


@click.command()
@click.argument("signals", nargs=-1, type=click.Path(dir_okay=False))
@click.option("--moduli", "moduli_paths", multiple=True, type=click.Path(dir_okay=False),
              help="`granwave analyze moduli --json` output of each signal's packing, in the "
                   "order of SIGNALS (gives each packing's own c_l and c_t).")
@options_from(ContinuumParams, json=True)
@stage
def continuum(signals, moduli_paths, as_json, **options):
    """Speeds, amplitude and width of the front against distance L, and c_tof/c_l.

    SIGNALS are compressional signal files of containers of several heights L (one pressure,
    one initial condition, one kind of column: dimension, friction, law, width; each packing
    once), one --moduli file per signal in the same order (each of its signal's packing). Per nominal height: means
    and standard errors of the front features (granwave analyze front), of c_l and c_t and
    of the apparent speeds L/t. Between consecutive heights: the local speeds c_tof (10%
    edge), c_peak, c_zero = dL/dt of the means, c_tof/c_l, and the local exponents
    gamma_eff = -dln|A|/dlnL, chi_eff = dlnW/dlnL, all with error bars from the standard
    errors and a bootstrap over the packings within each height through the whole chain
    (--bootstrap). The approach c_tof/c_l = 1 + a L^-beta is fitted (95% intervals, from the
    fit's covariance and from the bootstrap) and L*, where c_tof is within --tolerance of
    c_l, is given, or a lower bound when the tallest height is still outside it. Fewer than
    5 packings at a height (10 for the fits): a warning, not quotable. Units: d, sqrt(E*/rho). See docs/continuum.md.
    """
    from ..analysis.continuum import continuum as run
    from ..errors import InputError
    from ..io.files import read_signal

    params = params_from(ContinuumParams, options)
    if not signals:
        raise InputError("no signal files given")
    if len(moduli_paths) != len(signals):
        raise InputError(f"one --moduli file per signal is needed ({len(signals)} signals, "
                         f"{len(moduli_paths)} moduli files)")
    distinct_files(signals, "signal")
    distinct_files(moduli_paths, "--moduli")
    speeds = moduli_speeds(moduli_paths, params.c_l_kind)
    c_l, c_t = speeds[params.c_l_kind]
    sigs = [read_signal(p) for p in signals]
    check_moduli_of(moduli_paths, sigs, signals)
    res = run(sigs, c_l, c_t, labels=list(signals),
              c_l_kind=params.c_l_kind, c_l_by_kind={k: v[0] for k, v in speeds.items()},
              tolerance=params.tolerance, group_rtol=params.group_tolerance,
              bootstrap=params.bootstrap, seed=params.seed, **params.front_kw())
    res["params"] = params.as_dict()
    if as_json:  # the JSON carries the packing rule's verdict (packings.warning)
        echo_json(res)
        return
    for key in ("packings_per_height", "packings"):  # granwave.analysis.packings, said every time
        if res[key]["warning"]:
            click.echo(f"warning: {res[key]['warning']}")
    echo_table({k: v for k, v in res["approach"].items() if k != "free_limit"},
               title=f"continuum: {res['n_signals']} signals, {res['n_heights']} heights, "
                     f"c_l = {res['c_l_kind']}")
    loc = res["local"]
    click.echo(f"  {'L':>9} {'c_tof':>9} {'c_peak':>9} {'c_zero':>9} {'c_l':>9} {'ratio':>9} "
               f"{'err':>8} {'gamma':>8} {'chi':>8}")
    for i in range(len(loc["height"])):
        click.echo(f"  {loc['height'][i]:9.4g} {loc['c_tof'][i]:9.4g} {loc['c_peak'][i]:9.4g} "
                   f"{loc['c_zero'][i]:9.4g} {loc['c_l'][i]:9.4g} {loc['ratio'][i]:9.4g} "
                   f"{loc['ratio_err'][i]:8.2g} {loc['gamma_eff'][i]:8.3g} {loc['chi_eff'][i]:8.3g}")
    cand = res.get("candidates")
    if cand:
        click.echo("  candidate L* (d) by arrival rule, tolerance and c_l reference "
                   "(c_l x " + " / ".join(f"{x:g}" for x in cand["c_l_scales"]) + "); "
                   "local speed/c_l at the tallest pair")
        rows = {(r["rule"], r["tolerance"], r["c_l_scale"]): r for r in cand["table"]}
        for rule, sp in cand["speeds"].items():
            for tol in cand["tolerances"]:
                cells = []
                for sc in cand["c_l_scales"]:
                    r = rows[(rule, tol, sc)]
                    v = r.get("L_star")
                    cells.append(f"{v:9.4g}" if v is not None else f"{'-':>9}")
                click.echo(f"  {rule:>10} tol {tol:<5g} " + " ".join(cells)
                           + f"   ratio {sp['ratio'][-1]:.4g} ± {sp['ratio_err'][-1]:.2g}")


def distinct_files(paths, what: str) -> None:
    """InputError (one line) for a file given twice (by any name): it would count as two packings."""
    import os

    from ..errors import InputError

    seen = {}
    for p in paths:
        try:
            st = os.stat(p)
        except OSError:
            continue  # the reader says it in its own words
        key = (st.st_dev, st.st_ino)
        if key in seen:
            raise InputError(f"{seen[key]} and {p} are one {what} file, given twice: each packing "
                             "counts once")
        seen[key] = p
