"""Frictionless harmonic packings near jamming: excess coordination and G/K against pressure.

    python benchmarks/harmonic_jamming.py [--grains 400] [--seeds 4] [--pressures 3e-5,...] [--no-record]

For harmonic contacts (granwave.contact_models.harmonic, k_n = 1 E* d between grains)
O'Hern et al. (PRE 68, 011306, 2003) find z - z_iso ~ p^(1/2) and G/K ~ p^(1/2) near
jamming (z_iso = 2 d = 4 in 2D, frictionless). This prepares 2D frictionless packings at
pressures p (in units of k_n / d, so p is also the typical overlap) with several seeds,
measures the bulk coordination without rattlers (granwave.analysis.statics, walls' layer
of 2 d left out, rattlers: fewer than d + 1 = 3 contacts) and the global moduli (granwave.linear.moduli, no prestress terms:
they are O(p / k_n) here), K = (C11 + C22 + 2 C12) / 4, G = C33 and the other shear modulus
G' = (C11 + C22 - 2 C12) / 4 (the packing, compressed by the piston, is not isotropic), and fits the
exponents of z - 4 and G/K against p by least squares on the logs of all packings,
with the slope's standard error (packings with z < 4 left out of the first), and also
z = z_c + A p^b with z_c free (all packings). Appends one record to
benchmarks/results/harmonic_jamming.jsonl (summarize it with
benchmarks/results/summarize.py). Small systems with walls: the excess coordination
cannot fall below ~1/N and the walls add contacts, so the lowest pressures bend away
from the power law; read the exponents with their errors.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import pathlib
import time

import numpy as np

from granwave.analysis.statics import statics
from granwave.dem.protocol import prepare_packing
from granwave.linear.moduli import moduli
from granwave.params import PrepareParams
from granwave.provenance import git_revision, machine

RESULTS = pathlib.Path(__file__).parent / "results" / "harmonic_jamming.jsonl"
Z_ISO = 4.0  # 2D, frictionless
LAYER = 2.0  # d left out next to each wall in the coordination
#: a frictionless grain in 2D needs d + 1 = 3 contacts to be stable; fewer: a rattler
MIN_CONTACTS = 3


def fit_power(p, y) -> tuple[float, float, float]:
    """(exponent, its standard error, prefactor) of y = A p^b by least squares on the logs."""
    x, v = np.log(np.asarray(p, float)), np.log(np.asarray(y, float))
    a = np.vstack([x, np.ones_like(x)]).T
    coef, res, _, _ = np.linalg.lstsq(a, v, rcond=None)
    dof = max(1, len(x) - 2)
    s2 = float(np.sum((v - a @ coef) ** 2)) / dof
    cov = s2 * np.linalg.inv(a.T @ a)
    return float(coef[0]), float(math.sqrt(cov[0, 0])), float(math.exp(coef[1]))


def fit_offset_power(p, z) -> tuple[float, float, float, float]:
    """(exponent, its standard error, z_c, its standard error) of z = z_c + A p^b (least squares):
    a finite packing with walls jams at a z_c a little off 2 d."""
    from scipy.optimize import curve_fit

    p, z = np.asarray(p, float), np.asarray(z, float)
    popt, pcov = curve_fit(lambda x, zc, a, b: zc + a * x**b, p, z, p0=(Z_ISO, 4.0, 0.5), maxfev=20000)
    return float(popt[2]), float(math.sqrt(pcov[2, 2])), float(popt[0]), float(math.sqrt(pcov[0, 0]))


def measure(pressure: float, seed: int, grains: int) -> dict:
    t = time.process_time()
    pk = prepare_packing(PrepareParams(dim=2, grains=grains, pressure=pressure, friction=0.0, seed=seed,
                                       contact_law="harmonic", harmonic_stiffness=1.0))
    st = statics(pk, layer=LAYER, min_contacts=MIN_CONTACTS)
    m = moduli(pk)
    bulk = 0.25 * (m["C11"] + m["C22"] + 2.0 * m["C12"])
    shear = m["C33"]
    pure = 0.25 * (m["C11"] + m["C22"] - 2.0 * m["C12"])  # the other shear (pure shear at 45 degrees)
    return dict(pressure=pressure, seed=seed, grains=grains, steps=int(pk.attrs["steps"]),
                z_star=float(st["z_star"]), excess_z=float(st["z_star"]) - Z_ISO,
                rattler_fraction=float(st["rattler_fraction"]), K=float(bulk), G=float(shear),
                G_over_K=float(shear / bulk), G_pure_over_K=float(pure / bulk), cpu_s=round(time.process_time() - t, 2))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grains", type=int, default=400)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--pressures", default="3e-5,1e-4,3e-4,1e-3,3e-3,1e-2")
    ap.add_argument("--no-record", action="store_true", help="do not append to the JSONL file")
    ap.add_argument("--note", default="", help="free text stored with the record (e.g. other load)")
    args = ap.parse_args()
    pressures = [float(x) for x in args.pressures.split(",")]
    rows = []
    for p in pressures:
        for seed in range(args.seeds):
            r = measure(p, seed, args.grains)
            rows.append(r)
            print(json.dumps(r), flush=True)
    ok = [r for r in rows if r["excess_z"] > 0 and r["G_over_K"] > 0 and r["G_pure_over_K"] > 0]
    bz, ez, _ = fit_power([r["pressure"] for r in ok], [r["excess_z"] for r in ok])
    bg, eg, _ = fit_power([r["pressure"] for r in ok], [r["G_over_K"] for r in ok])
    bp, ep, _ = fit_power([r["pressure"] for r in ok], [r["G_pure_over_K"] for r in ok])
    bc, ec, zc, ezc = fit_offset_power([r["pressure"] for r in rows], [r["z_star"] for r in rows])
    summary = {"exponent of z - 4": f"{bz:.3f} ± {ez:.3f}",
               "exponent of z - z_c (z_c fitted)": f"{bc:.3f} ± {ec:.3f}", "z_c": f"{zc:.3f} ± {ezc:.3f}",
               "exponent of G/K": f"{bg:.3f} ± {eg:.3f}",
               "exponent of G'/K (G' = (C11 + C22 - 2 C12) / 4)": f"{bp:.3f} ± {ep:.3f}", "expected (O'Hern 2003)": 0.5,
               "packings used": f"{len(ok)} of {len(rows)}"}
    print(json.dumps(summary))
    if not args.no_record:
        rec = dict(date=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                   benchmark="harmonic_jamming",
                   command="python benchmarks/harmonic_jamming.py "
                           f"--grains {args.grains} --seeds {args.seeds} --pressures {args.pressures}",
                   git_revision=git_revision(), machine={"machine": machine()}, summary=summary,
                   notes=args.note or None, result=rows)
        with open(RESULTS, "a") as f:
            f.write(json.dumps(rec) + "\n")


if __name__ == "__main__":
    main()
