"""The workflow's shear scene (docs/shear.md, "The shear scene"): V_s(p), V_p(p), G_max(p),
V_p/V_s and the Poisson ratio from waves against the moduli, and the pick table.

Input: one record per packing (:func:`sample_record`, written by the workflow's shear
batches): the packing's global moduli (c_l, c_t, Φ3*, the stiffness tensor) and, for each
source wavelength λ (d), the bender-element picks (:func:`granwave.analysis.shear.shear_picks`)
of the shear kick (against c_t, at f = c_t/λ) and of the compressional kick (against c_l, at
f = c_l/λ: the same wavelength in grain diameters, so both waves sample the same disorder
scale). Both kicks are impulses (initial condition A) convolved with the same pulse shape.

What :func:`shear_scene` computes (every error one standard error):

* per pressure, at the **fit height** (the tallest nominal height measured at every
  pressure) and the reference wavelength (the first one) with the scene's ``pick``:
  V_s and V_p (L / T of the pick), c_t and c_l (moduli), G_max = Φ3* V_s² (reduced units,
  grain density 1; granwave.units converts) and the moduli's G = Φ3* c_t² (2D C33, 3D
  (C44 + C55)/2), r = V_p/V_s and the Poisson ratio ν(r), all as means ± standard error over
  the packings (ratios per packing, then averaged);
* power laws through the per-pressure means (:func:`granwave.analysis.fits.power_law_fit`,
  log-log least squares, as ``pressure-sweep``): V_s ∝ p^ν_s, V_p ∝ p^ν_p, c_t, c_l, and
  G_max ∝ p^n (n = 2 ν_s up to the Φ3* drift); G_max against p^(1/3) (Hertz–Mindlin effective
  medium): the prefactor of the fixed-exponent line and the rms of the log residuals of both
  lines, and (n − 1/3)/δn;
* the Poisson ratio of an isotropic medium from a speed ratio r = c_l/c_t
  (:func:`poisson_from_ratio`): 2D ν = 1 − 2/r² = (K − G)/(K + G) (plane, K the 2D bulk
  modulus), 3D ν = (r² − 2)/(2(r² − 1)); from waves r = V_p/V_s, from the moduli
  r = c_l/c_t = sqrt(C22/C33) (2D; 3D sqrt(C33/((C44 + C55)/2))). The tensor's own contraction
  ratio (:func:`poisson_from_tensor`: 2D C12/C22, 3D C13/(C13 + C33)) equals these only in an
  isotropic medium, so the difference measures the packing's anisotropy;
* the pick table: per pressure and wavelength, every pick's V/c_t against distance by
  :func:`granwave.analysis.shear.shear_series` (grouped by nominal height), with the picks whose
  mean lies within 5 % of c_t.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import InputError
from .ensemble import describe
from .fits import power_law_fit
from .shear import PICKS, shear_series

#: The Hertz–Mindlin effective-medium exponent of G_max(p).
HERTZ_EXPONENT = 1.0 / 3.0
#: The tolerance of the pick table.
TOLERANCE = 0.05


def poisson_from_ratio(r, dim: int):
    """Poisson ratio of an isotropic medium with c_l/c_t = ``r`` (module docstring)."""
    r2 = np.asarray(r, dtype=float) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        out = 1.0 - 2.0 / r2 if dim == 2 else (r2 - 2.0) / (2.0 * (r2 - 1.0))
    return float(out) if np.ndim(out) == 0 else out


def poisson_from_tensor(moduli: Mapping, dim: int) -> float:
    """The stiffness tensor's contraction ratio: 2D C12/C22, 3D C13/(C13 + C33) (NaN if absent)."""
    try:
        if dim == 2:
            return float(moduli["C12"]) / float(moduli["C22"])
        return float(moduli["C13"]) / (float(moduli["C13"]) + float(moduli["C33"]))
    except (KeyError, TypeError, ZeroDivisionError):
        return math.nan


def shear_modulus(moduli: Mapping, dim: int) -> float:
    """The moduli's shear modulus of a vertical shear wave: 2D C33, 3D (C44 + C55)/2."""
    try:
        return float(moduli["C33"]) if dim == 2 else 0.5 * (float(moduli["C44"]) + float(moduli["C55"]))
    except (KeyError, TypeError):
        return math.nan


def reference_speeds(moduli: Mapping) -> dict:
    """The reference speeds of one packing's ``analyze moduli`` output (docs/shear.md).

    ``c_t``, ``c_l``: the bulk slab's (``c_t_slab``, ``c_l_slab``: the slab's own strain and its
    own density, one volume and one rattler rule for both; decision 0014), ``speed_reference``
    "bulk slab"; where the column has no slab (thinner than 1 d), the whole cell's, "whole cell".
    ``c_t_cell``, ``c_l_cell``: the whole cell's moduli over the whole cell's density
    ``phi3_star_cell`` (the same rattler rule: the grains of D and M), beside them. In 3D also
    the whole cell's in-plane shear block [[C55, C45], [C45, C44]] (waves along z, polarised in
    the xy plane): its eigen-speeds ``c_t_polarisations`` [slow, fast] over ``phi3_star_cell``,
    ``c_t_x_cell`` the one whose polarisation lies nearest x (the shear kick's direction), its
    polarisation angle from x ``polarisation_deg`` and ``C45_ratio`` = C45/sqrt(C44 C55).
    """
    dim = int(moduli.get("dim", 2))
    phi_cell = _num(moduli.get("phi3_star_cell"))
    g_cell = shear_modulus(moduli, dim)
    m_cell = _num(moduli.get("C22" if dim == 2 else "C33"))

    def speed(m, rho):
        return math.sqrt(m / rho) if (math.isfinite(m) and math.isfinite(rho) and m > 0 and rho > 0) \
            else math.nan

    out = {"c_t_cell": speed(g_cell, phi_cell), "c_l_cell": speed(m_cell, phi_cell)}
    ct_slab, cl_slab = _num(moduli.get("c_t_slab")), _num(moduli.get("c_l_slab"))
    slab = math.isfinite(ct_slab)
    out.update(c_t=ct_slab if slab else out["c_t_cell"],
               c_l=cl_slab if math.isfinite(cl_slab) else out["c_l_cell"],
               speed_reference="bulk slab" if slab else "whole cell")
    if dim == 3:
        out.update(c_t_polarisations=[math.nan, math.nan], c_t_x_cell=math.nan, polarisation_deg=math.nan,
                   C45_ratio=math.nan)
        voigt = moduli.get("voigt")
        try:
            v = np.asarray(voigt, float)
            block = np.array([[v[4, 4], 0.5 * (v[3, 4] + v[4, 3])], [0.5 * (v[3, 4] + v[4, 3]), v[3, 3]]])
        except (TypeError, ValueError, IndexError):
            block = None
        if block is not None and np.all(np.isfinite(block)) and phi_cell > 0:
            lam, vec = np.linalg.eigh(block)
            k = int(np.argmax(np.abs(vec[0])))
            out.update(c_t_polarisations=[speed(x, phi_cell) for x in lam],
                       c_t_x_cell=speed(lam[k], phi_cell),
                       polarisation_deg=float(np.degrees(np.arctan2(abs(vec[1, k]), abs(vec[0, k])))),
                       C45_ratio=float(block[0, 1] / math.sqrt(block[0, 0] * block[1, 1]))
                       if block[0, 0] > 0 and block[1, 1] > 0 else math.nan)
    return out


def sample_record(*, scene: str, source_scene: str, pressure: float, size: str, seed: int,
                  moduli: Mapping, shear: Sequence[Mapping], normal: Sequence[Mapping],
                  wavelengths: Sequence[float], pulse: str, extra: Mapping | None = None) -> dict:
    """One packing's record for :func:`shear_scene`: ``shear`` and ``normal`` hold one
    :func:`granwave.analysis.shear.shear_picks` result per wavelength (same order)."""
    dim = int(moduli.get("dim", 2))
    keys = ("C11", "C12", "C22", "C33") if dim == 2 else ("C11", "C22", "C33", "C12", "C13", "C23",
                                                         "C44", "C55", "C66")
    rec = {"scene": scene, "source_scene": source_scene, "pressure": float(pressure), "size": size,
           "seed": int(seed), "dim": dim, "pulse": pulse,
           "wavelengths": [float(w) for w in wavelengths],
           "height": float(shear[0]["height"]) if shear else math.nan,
           **reference_speeds(moduli),
           "phi3_star": _num(moduli.get("phi3_star")), "phi3_star_slab": _num(moduli.get("phi3_star_slab")),
           "phi3_star_cell": _num(moduli.get("phi3_star_cell")),
           "moduli": {k: _num(moduli.get(k)) for k in keys},
           "shear": list(shear), "normal": list(normal)}
    rec.update(extra or {})
    return rec


def _num(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _nominal(size: str) -> float:
    return float(str(size)[1:])


def _fit(p, y, what) -> dict | None:
    p, y = np.asarray(p, float), np.asarray(y, float)
    ok = np.isfinite(y) & (y > 0)
    if np.unique(p[ok]).size < 2:
        return None
    return power_law_fit(p[ok], y[ok], what=what).as_dict()


def _stats(values) -> dict:
    d = describe(values)
    return {"mean": d["mean"], "sem": d["sem"], "n": d["count"]}


def _fixed_exponent(p, y, exponent: float) -> dict | None:
    """y = A p^exponent through the points (log least squares: A is the geometric mean of
    y/p^exponent), its prefactor ± standard error and the rms of the log residuals."""
    p, y = np.asarray(p, float), np.asarray(y, float)
    ok = np.isfinite(y) & (y > 0)
    if ok.sum() < 2:
        return None
    res = np.log(y[ok]) - exponent * np.log(p[ok])
    a = math.exp(float(res.mean()))
    err = a * float(res.std(ddof=1)) / math.sqrt(ok.sum()) if ok.sum() > 1 else math.nan
    rms = float(np.sqrt(np.mean((res - res.mean()) ** 2)))
    return {"exponent": exponent, "prefactor": a, "prefactor_err": err, "rms_log_residual": rms,
            "n": int(ok.sum())}


def _rms_free(p, y, fit) -> float:
    p, y = np.asarray(p, float), np.asarray(y, float)
    ok = np.isfinite(y) & (y > 0)
    res = np.log(y[ok]) - math.log(fit["prefactor"]) - fit["exponent"] * np.log(p[ok])
    return float(np.sqrt(np.mean(res ** 2)))


def si_rows(rows: Sequence[Mapping], *, material: str, diameter_mm: float, wavelength: float,
            poisson: float | None = None) -> dict:
    """The per-pressure speeds (m/s) and moduli (MPa) of :func:`shear_scene`'s rows for grains of
    ``material`` (granwave.units.MATERIALS) and mean diameter ``diameter_mm``, and the source
    frequencies f = c_t/λ and c_l/λ (kHz) of ``wavelength`` (d): speeds and moduli do not depend
    on the diameter, frequencies do (docs/units.md). ``poisson``: the packings' own Poisson
    ratio; where it is not the material's, ``poisson_mismatch`` says so (the report warns)."""
    from ..units import material_scales, poisson_mismatch

    sc = material_scales(material, diameter_mm * 1e-3)
    speed, modulus = sc["speed"], sc["E_star"] / 1e6

    def scaled(stat, k):
        return {"mean": stat["mean"] * k, "sem": stat["sem"] * k, "n": stat["n"]}

    out = []
    for r in rows:
        khz = speed / (wavelength * diameter_mm * 1e-3) / 1e3
        out.append({"pressure": r["pressure"],
                    "pressure_kPa": r["pressure"] * sc["E_star"] / 1e3,
                    "V_s_m_s": scaled(r["V_s"], speed), "V_p_m_s": scaled(r["V_p"], speed),
                    "c_t_m_s": scaled(r["c_t"], speed), "c_l_m_s": scaled(r["c_l"], speed),
                    "G_max_MPa": scaled(r["G_max"], modulus), "G_moduli_MPa": scaled(r["G_moduli"], modulus),
                    "f_shear_kHz": r["c_t"]["mean"] * khz, "f_normal_kHz": r["c_l"]["mean"] * khz})
    return {"material": material, "diameter_mm": float(diameter_mm), "E_star_GPa": sc["E_star"] / 1e9,
            "density": sc["rho"], "wavelength": float(wavelength), "rows": out,
            "poisson_run": None if poisson is None else float(poisson),
            "poisson_mismatch": None if poisson is None else poisson_mismatch(material, poisson)}


def shear_scene(records: Sequence[Mapping], *, pick: str = "first_deflection",
                material: str | None = None, diameter_mm: float = 1.0,
                poisson: float | None = None) -> dict:
    """The scene's analysis (module docstring) from :func:`sample_record` records; with
    ``material`` also the speeds and moduli in SI (:func:`si_rows`, key ``si``)."""
    if pick not in PICKS:
        raise InputError(f"pick must be one of {', '.join(PICKS)} (got {pick!r})")
    records = list(records)
    if not records:
        raise InputError("no shear scene records")
    dims = {int(r["dim"]) for r in records}
    if len(dims) != 1:
        raise InputError(f"the records mix dimensions {sorted(dims)}")
    dim = dims.pop()
    lams = [float(w) for w in records[0]["wavelengths"]]
    if any([float(w) for w in r["wavelengths"]] != lams for r in records):
        raise InputError("the records have different source wavelengths")
    pressures = sorted({float(r["pressure"]) for r in records})
    by_p = {p: [r for r in records if float(r["pressure"]) == p] for p in pressures}
    common = set.intersection(*({_nominal(r["size"]) for r in rs} for rs in by_p.values()))
    fit_height = max(common) if common else None

    rows = []
    for p in pressures:
        h = fit_height if fit_height is not None else max(_nominal(r["size"]) for r in by_p[p])
        rs = [r for r in by_p[p] if _nominal(r["size"]) == h]
        vs = np.array([r["shear"][0]["picks"][pick]["speed"] for r in rs], float)
        vp = np.array([r["normal"][0]["picks"][pick]["speed"] for r in rs], float)
        ct = np.array([r["c_t"] for r in rs], float)
        cl = np.array([r["c_l"] for r in rs], float)
        phi = np.array([r["phi3_star"] for r in rs], float)
        g_mod = np.array([shear_modulus(r["moduli"], dim) for r in rs], float)
        ct_cell = np.array([r.get("c_t_cell", math.nan) for r in rs], float)
        ct_x = np.array([r.get("c_t_x_cell", math.nan) for r in rs], float)
        with np.errstate(divide="ignore", invalid="ignore"):
            r_wave, r_mod = vp / vs, cl / ct
        rows.append({
            "pressure": p, "height_nominal": h, "n": len(rs),
            "height": _stats([r["height"] for r in rs]),
            "V_s": _stats(vs), "V_p": _stats(vp), "c_t": _stats(ct), "c_l": _stats(cl),
            "V_s_over_c_t": _stats(vs / ct), "V_p_over_c_l": _stats(vp / cl),
            "c_t_cell": _stats(ct_cell), "V_s_over_c_t_cell": _stats(vs / ct_cell),
            "c_t_x_cell": _stats(ct_x), "V_s_over_c_t_x_cell": _stats(vs / ct_x),
            "C45_ratio": _stats([r.get("C45_ratio", math.nan) for r in rs]),
            "speed_reference": sorted({r.get("speed_reference", "whole cell") for r in rs}),
            "phi3_star": _stats(phi),
            "G_max": _stats(phi * vs * vs), "G_moduli": _stats(g_mod),
            "ratio_waves": _stats(r_wave), "ratio_moduli": _stats(r_mod),
            "poisson_waves": _stats(poisson_from_ratio(r_wave, dim)),
            "poisson_moduli": _stats(poisson_from_ratio(r_mod, dim)),
            "poisson_tensor": _stats([poisson_from_tensor(r["moduli"], dim) for r in rs]),
        })

    ps = [row["pressure"] for row in rows]
    mean = {key: [row[key]["mean"] for row in rows]
            for key in ("V_s", "V_p", "c_t", "c_l", "G_max", "G_moduli")}
    fits = {key: _fit(ps, mean[key], f"{key}(p)") for key in mean}
    gmax = {"free": fits["G_max"], "hertz": _fixed_exponent(ps, mean["G_max"], HERTZ_EXPONENT)}
    if fits["G_max"] is not None:
        gmax["free"] = {**fits["G_max"], "rms_log_residual": _rms_free(ps, mean["G_max"], fits["G_max"])}
        err = fits["G_max"]["exponent_err"]
        gmax["deviation_from_hertz"] = ((fits["G_max"]["exponent"] - HERTZ_EXPONENT) / err
                                        if err and math.isfinite(err) and err > 0 else math.nan)

    table = []
    for p in pressures:
        for k, lam in enumerate(lams):
            results = [r["shear"][k] for r in by_p[p]]
            nominal = [_nominal(r["size"]) for r in by_p[p]]
            for h in sorted(set(nominal)):
                members = [res for res, n in zip(results, nominal) if n == h]
                # one group: the packings of one nominal height (their L differ by a few %)
                series = shear_series(members, group_rtol=math.inf)["rows"][0]
                table.append({"pressure": p, "wavelength": lam, "height_nominal": h, **series})
    si = si_rows(rows, material=material, diameter_mm=diameter_mm, wavelength=lams[0],
                 poisson=poisson) if material else None
    return {"dim": dim, "pick": pick, "pulse": records[0].get("pulse"), "wavelengths": lams, "si": si,
            "fit_height": fit_height, "n_records": len(records), "pressures": rows, "fits": fits,
            "G_max": gmax, "hertz_exponent": HERTZ_EXPONENT, "tolerance": TOLERANCE,
            "pick_table": table, "picks": list(PICKS),
            "poisson_formula": ("nu = 1 - 2/r^2 (2D isotropic, r = c_l/c_t)" if dim == 2 else
                                "nu = (r^2 - 2)/(2 (r^2 - 1)) (3D isotropic, r = c_l/c_t)"),
            "tensor_formula": "C12/C22" if dim == 2 else "C13/(C13 + C33)"}
