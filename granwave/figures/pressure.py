"""Sound speeds against pressure (docs/method.md §10) with the lattice theory and guides."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from ..analysis.fits import power_law_fit
from .common import C_UNIT, array, fmt_err, need, new_figure, save_figure


def speeds_vs_pressure(sweep: Mapping, path, *, lattice_theory: Callable | None = None,
                       lattice_points: Sequence[Mapping] = (), poisson: float = 0.0,
                       pdf: bool = False) -> list[Path]:
    """c_tof, c_ℓ and 2 c_t against p (log–log) with the lattice theory and guides.

    ``sweep``: ``pressure`` array and any of ``c_tof``, ``c_l``, ``c_t`` arrays
    (and ``*_err`` for error bars). ``lattice_theory(p, friction=bool, poisson=ν)``
    gives the triangular-lattice speed (default :func:`granwave.theory` when
    available); ``lattice_points``: dicts ``pressure``, ``speed``, ``friction``
    (and optional ``label``) from simulated lattices, drawn as markers. Guide
    lines p^{1/6} and p^{1/4} go through the geometric middle of c_tof.
    """
    p = array(sweep["pressure"], "pressure")
    need(np.all(p > 0), "pressures must be positive for a log axis")
    fig = new_figure((8, 6))
    ax = fig.add_subplot(1, 1, 1)
    styles = {"c_tof": ("o", "C0", r"$c_{\rm tof}$"), "c_l": ("s", "C1", r"$c_\ell$"),
              "c_t": ("^", "C2", r"$2\,c_t$")}
    anchor = None
    for key, (mk, col, lab) in styles.items():
        if sweep.get(key) is None:
            continue
        factor = 2.0 if key == "c_t" else 1.0
        y = np.asarray(sweep[key], float) * factor
        err = sweep.get(key + "_err")
        err = None if err is None else np.asarray(err, float) * factor
        ax.errorbar(p, y, yerr=err, fmt=mk, color=col, ms=6, capsize=3, label=lab)
        ok = (y > 0) & np.isfinite(y)
        if np.unique(p[ok]).size >= 2:
            fit = power_law_fit(p[ok], y[ok], what=f"{key} against pressure")
            px = np.geomspace(p[ok].min(), p[ok].max(), 20)
            ax.plot(px, fit.prefactor * px ** fit.exponent, "-", color=col, lw=0.7,
                    label=f"fit: {lab} ∝ $p^{{{fit.exponent:.3f}}}$" + fmt_err(fit.exponent_err))
        if anchor is None and ok.any():
            anchor = (float(np.exp(np.mean(np.log(p[ok])))), float(np.exp(np.mean(np.log(y[ok])))))
    need(anchor is not None, "no speeds (c_tof, c_l, c_t) in the sweep")
    prange = np.geomspace(p.min() / 2, p.max() * 2, 50)
    if lattice_points:
        prange = np.geomspace(min(prange[0], min(float(q["pressure"]) for q in lattice_points)),
                              max(prange[-1], max(float(q["pressure"]) for q in lattice_points)), 50)
    if lattice_theory is None:
        lattice_theory = _theory_lattice_speed()
    if lattice_theory:
        for fr, ls in ((False, "-"), (True, "--")):
            ax.plot(prange, [lattice_theory(q, friction=fr, poisson=poisson) for q in prange],
                    ls, color="k", lw=1,
                    label="triangular lattice theory, " + ("frictional" if fr else "frictionless"))
    for q in lattice_points:
        fr = bool(q.get("friction", 0))
        ax.plot(float(q["pressure"]), float(q["speed"]), "*" if fr else "P", ms=10,
                color="0.3" if fr else "0.55",
                label=q.get("label") or ("lattice simulation, " + ("frictional" if fr else "frictionless")))
    p0, c0 = anchor
    for e, ls in ((1 / 6, ":"), (1 / 4, "-.")):
        ax.plot(prange, c0 * (prange / p0) ** e, ls, color="C7", lw=1,
                label=f"$p^{{{'1/6' if e < 0.2 else '1/4'}}}$ guide")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"pressure $p$  [$E^*$]")
    ax.set_ylabel(f"speed  [{C_UNIT}]")
    handles, labels = ax.get_legend_handles_labels()
    uniq = dict(zip(labels, handles))
    ax.legend(uniq.values(), uniq.keys(), fontsize=8)
    return save_figure(fig, path, pdf=pdf)


def _theory_lattice_speed() -> Callable:
    from ..theory import lattice_speed

    return lambda p, *, friction, poisson=0.0: float(lattice_speed(p, friction=friction,
                                                                    poisson=poisson))

