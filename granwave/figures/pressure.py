"""Sound speeds against pressure (docs/method.md §10) with the lattice theory and guides."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from ..analysis.fits import power_law_fit
from .common import C_UNIT, array, need, new_figure, save_figure, scene_title, value_text


def speeds_vs_pressure(sweep: Mapping, path, *, lattice_theory: Callable | None = None,
                       lattice_points: Sequence[Mapping] = (), poisson: float = 0.0,
                       pdf: bool = False, scene: str | None = None) -> list[Path]:
    """c_tof, c_ℓ and c_t against p (log–log) with the lattice theory and guides.

    ``sweep``: ``pressure`` array and any of ``c_tof``, ``c_l``, ``c_t`` arrays
    (and ``*_err`` for error bars). ``lattice_theory(p, friction=bool, poisson=ν)``
    gives the triangular-lattice speed (default :func:`granwave.theory` when
    available); ``lattice_points``: dicts ``pressure``, ``speed``, ``friction``
    (and optional ``label``) from simulated lattices, drawn as open markers above the
    measured points (so that neither hides the other). Guide lines p^{1/6} and p^{1/4} go
    through the geometric middle of c_tof. Both axes label their decades only (10^k).
    """
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    p = array(sweep["pressure"], "pressure")
    need(np.all(p > 0), "pressures must be positive for a log axis")
    fig = new_figure((8, 6))
    ax = fig.add_subplot(1, 1, 1)
    styles = {"c_tof": ("o", "C0", r"$c_{\rm tof}$", "tof"), "c_l": ("s", "C1", r"$c_\ell$", "ℓ"),
              "c_t": ("^", "C2", r"$c_t$", "t")}
    anchor = None
    for key, (mk, col, lab, sub) in styles.items():
        if sweep.get(key) is None:
            continue
        y = np.asarray(sweep[key], float)
        err = sweep.get(key + "_err")
        err = None if err is None else np.asarray(err, float)
        ax.errorbar(p, y, yerr=err, fmt=mk, color=col, ms=6, capsize=3, label=lab, zorder=3)
        ok = (y > 0) & np.isfinite(y)
        if np.unique(p[ok]).size >= 2:
            fit = power_law_fit(p[ok], y[ok], what=f"{key} against pressure")
            px = np.geomspace(p[ok].min(), p[ok].max(), 20)
            ax.plot(px, fit.prefactor * px ** fit.exponent, "-", color=col, lw=0.7,
                    label=f"fit {lab} ∝ $p^κ$: κ_{sub} = " + value_text(fit.exponent, fit.exponent_err))
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
        ax.plot(float(q["pressure"]), float(q["speed"]), "D" if fr else "s", ms=11, mfc="none",
                mew=1.6, color="0.15" if fr else "0.45", zorder=6,
                label=q.get("label") or ("lattice simulation, " + ("frictional" if fr else "frictionless")))
    p0, c0 = anchor
    for e, ls in ((1 / 6, ":"), (1 / 4, "-.")):
        ax.plot(prange, c0 * (prange / p0) ** e, ls, color="C7", lw=1,
                label=f"$p^{{{'1/6' if e < 0.2 else '1/4'}}}$ guide")
    ax.set_xscale("log")
    ax.set_yscale("log")
    # one notation per axis: pressures as decades 10^k; speeds as plain numbers at 1, 2, 5 × 10^k
    ax.xaxis.set_major_locator(LogLocator(base=10))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(r"pressure $p$  [$E^*$]")
    ax.set_ylabel(f"speed  [{C_UNIT}]")
    handles, labels = ax.get_legend_handles_labels()
    uniq = dict(zip(labels, handles))
    ax.legend(uniq.values(), uniq.keys(), fontsize=8)
    ax.set_title(scene_title("sound speeds against pressure (c_tof between the edge heights; c_ℓ, c_t: "
                             "every height of a pressure pooled)", scene=scene,
                             count=f"{p.size} pressures", width=80), fontsize=10)
    return save_figure(fig, path, pdf=pdf)


def _theory_lattice_speed() -> Callable:
    from ..theory import lattice_speed

    return lambda p, *, friction, poisson=0.0: float(lattice_speed(p, friction=friction,
                                                                    poisson=poisson))

