"""Cost of one damped nonlinear DEM pulse against the linear time-domain signal (printed).

    python benchmarks/pulse.py [--grains 600] [--damping 0.1] [--crossings 3] [--packing FILE]

One 2D frictional packing (p = 1e-4, mu = 0.5; prepared here unless
``--packing`` is given, preparation time not counted). Over the same t_max
(``--crossings`` x height / c, c ~ 0.12 at p = 1e-4 for these packings) and the
same output grid:

- linear: ``linearize`` (no prestress) + ``time_domain_signal`` (velocity
  Verlet on the sparse D, dt = 0.1 x 2/omega_max), timed separately;
- DEM: ``propagate_dem`` at ``--damping`` (default 0.1), amplitude 1e-3,
  default dt (0.01 x the shortest contact period), with and without the
  baseline run (the default subtracts an unkicked run: twice the steps).

Prints wall times, steps, time per step and per grain-step, and the ratios
DEM / linear, all measured in this one run (absolute times drift on a
shared machine; the ratios are the meaningful numbers). A warm-up call
compiles the numba kernels first.
"""

from __future__ import annotations

import argparse
import time

from granwave.dem.params import PrepareParams
from granwave.dem.protocol import prepare_packing
from granwave.dem.pulse import propagate_dem
from granwave.io import files
from granwave.linear.assemble import linearize
from granwave.linear.propagate import time_domain_signal


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grains", type=int, default=600)
    ap.add_argument("--damping", type=float, default=0.1)
    ap.add_argument("--crossings", type=float, default=3.0)
    ap.add_argument("--samples", type=int, default=2001)
    ap.add_argument("--packing", default=None, help="use this packing file instead of preparing one")
    args = ap.parse_args()

    if args.packing:
        packing = files.read_packing(args.packing)
    else:
        t0 = time.perf_counter()
        packing = prepare_packing(PrepareParams(grains=args.grains, pressure=1e-4, friction=0.5, seed=1))
        print(f"prepared {packing.n_grains} grains in {time.perf_counter() - t0:.1f} s (not counted)")
    t_max = args.crossings * packing.height / 0.12
    n = packing.n_grains
    print(f"packing: {n} grains, height {packing.height:.2f}, {len(packing.contacts)} contacts; "
          f"t_max = {t_max:.1f}, {args.samples} samples")

    # warm-up (numba compilation, cached after the first run)
    small = dict(t_max=2.0, samples=11)
    time_domain_signal(linearize(packing, check=False), ic="A", **small)
    propagate_dem(packing, damping=args.damping, **small)

    t0 = time.perf_counter()
    system = linearize(packing, check=False)
    t_lin_assemble = time.perf_counter() - t0
    t0 = time.perf_counter()
    lin = time_domain_signal(system, ic="A", t_max=t_max, samples=args.samples)
    t_lin_run = time.perf_counter() - t0
    t_lin = t_lin_assemble + t_lin_run

    t0 = time.perf_counter()
    dem = propagate_dem(packing, damping=args.damping, t_max=t_max, samples=args.samples)
    t_dem = time.perf_counter() - t0
    t0 = time.perf_counter()
    dem1 = propagate_dem(packing, damping=args.damping, t_max=t_max, samples=args.samples, baseline=False)
    t_dem1 = time.perf_counter() - t0

    n_lin, n_dem = lin.attrs["n_steps"], dem.attrs["n_steps"]
    print(f"\nlinear time domain : assemble {t_lin_assemble:7.3f} s + run {t_lin_run:7.3f} s = {t_lin:7.3f} s;"
          f" {n_lin} steps, dt {lin.attrs['dt']:.4g}, {1e6 * t_lin_run / n_lin:.2f} us/step,"
          f" {system.n_dof} dofs")
    print(f"DEM, zeta {args.damping:g}, baseline: {t_dem:7.3f} s; 2 x {n_dem} steps, dt {dem.attrs['dt']:.4g},"
          f" {1e6 * t_dem / (2 * n_dem):.2f} us/step, {1e9 * t_dem / (2 * n_dem * n):.1f} ns/grain-step")
    print(f"DEM, zeta {args.damping:g}, no baseline: {t_dem1:7.3f} s; {n_dem} steps")
    print(f"\nratio DEM (with baseline) / linear time domain : {t_dem / t_lin:6.1f}")
    print(f"ratio DEM (no baseline)   / linear time domain : {t_dem1 / t_lin:6.1f}")
    print(f"ratio of steps DEM / linear                    : {n_dem / n_lin:6.1f}")
    print(f"ratio of cost per step DEM / linear            : {(t_dem1 / n_dem) / (t_lin_run / n_lin):6.1f}")
    print(f"counts: opened {dem.attrs['n_opened']}, formed {dem.attrs['n_formed']}, "
          f"sliding {dem.attrs['n_sliding']}, max displacement / mean overlap "
          f"{dem.attrs['max_displacement_over_overlap']:.2e}")


if __name__ == "__main__":
    main()
