"""The 3D free spins kept in the linear model, with and without prestress (decision 0019).

For each 3D frictional packing given (granwave.packing files): the free spins (grains with
two contacts), the zero and negative modes of D with the spins kept (dense check), the most
negative omega^2 with prestress and its growth over the shear scene's record (3 crossings at
c_t plus four periods of lambda = 16 d), the projections of the shear and normal sources on
those modes, and the time-domain signals: kept with prestress against kept without, and
removed (theta . e = 0) against kept, over that record and four times it, as a fraction of
the signal's peak, and the growth of the prestressed signal (rms of its last quarter over its
second, beside the same ratio without prestress). Prints one JSON line per packing
(benchmarks/results/free_spins.jsonl keeps a run; docs/decisions/0019-free-spins-default.md).

    python benchmarks/free_spins.py PACKING.h5 [...]
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from granwave import api
from granwave.io import files
from granwave.linear.assemble import linearize
from granwave.linear.eigen import eigensolve
from granwave.linear.propagate import time_domain_signal
from granwave.workflow_config import shear_record_length

SAFETY = 0.1


def _signal(system, kind, t_max, samples):
    return time_domain_signal(system.for_source(kind), ic="A", t_max=t_max, samples=samples,
                              safety=SAFETY).force


def measure(path: str) -> dict:
    t0 = time.perf_counter()
    pk = files.read_packing(path)
    kept = linearize(pk)
    kept_p = linearize(pk, prestress=True)
    removed = linearize(pk, remove_spins=True)
    c_t = float(api.moduli(pk, system=kept)["c_t"])
    t_rec = shear_record_length(pk.height, c_t, record=3.0, wavelengths=[16.0])
    out = dict(packing=path, grains=pk.n_grains, pressure=float(pk.attrs["pressure"]),
               height=pk.height, free_spins=int(kept.attrs["n_free_spins"]), n_dof=kept.n_dof,
               c_t=c_t, t_record=t_rec,
               kept=dict(zero=kept.attrs["n_zero_modes"], negative=kept.attrs["n_negative_modes"],
                         expected_zero=kept.attrs["expected_zero_modes"]),
               kept_prestress=dict(zero=kept_p.attrs["n_zero_modes"],
                                   negative=kept_p.attrs["n_negative_modes"],
                                   min_omega2_rel=kept_p.attrs["min_omega2"] / kept_p.attrs["omega2_max"],
                                   lowest_positive_omega2_rel=kept_p.attrs["lowest_nonzero_omega2"]
                                   / kept_p.attrs["omega2_max"]))
    modes = eigensolve(kept_p)
    neg = modes.omega2 < 0
    w = kept_p.attrs["min_omega2"]
    growth = math.sqrt(-w) if w < 0 else 0.0
    out["kept_prestress"].update(growth_rate=growth, growth_over_record=math.exp(growth * t_rec),
                                 growth_over_4_records=math.exp(growth * 4 * t_rec))
    for kind in ("shear", "normal"):
        m = modes.for_source(kind)
        weight = np.abs(m.amplitude_A * m.coupling) if kind == "normal" else np.abs(
            m.amplitude_A * m.coupling)
        out["kept_prestress"][f"{kind}_weight_on_negative_rel"] = float(
            weight[neg].max() / weight.max()) if neg.any() else 0.0
    for span, t_max in (("record", t_rec), ("4 records", 4 * t_rec)):
        samples = 801 if span == "record" else 3201
        for kind in ("shear", "normal"):
            ref = _signal(kept, kind, t_max, samples)
            peak = np.abs(ref).max()
            pre = _signal(kept_p, kind, t_max, samples)
            rem = _signal(removed, kind, t_max, samples)
            q = samples // 4  # growth: rms of the last quarter over the second, with and without
            growth = [float(np.sqrt(np.mean(x[3 * q:] ** 2) / np.mean(x[q:2 * q] ** 2))) for x in (pre, ref)]
            out.setdefault("signals", {})[f"{kind}, {span}"] = dict(
                prestress_vs_no=float(np.abs(pre - ref).max() / peak),
                rms_last_over_second_quarter_prestress=growth[0],
                rms_last_over_second_quarter_no_prestress=growth[1],
                removed_vs_kept=float(np.abs(rem - ref).max() / peak))
    out["seconds"] = time.perf_counter() - t0
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("packings", nargs="+")
    args = ap.parse_args()
    for path in args.packings:
        print(json.dumps(measure(path)), flush=True)


if __name__ == "__main__":
    main()
