"""Speed and accuracy of the linear-response path (printed, not a test).

    python benchmarks/linear.py [--quick] [--big-steps N]

Systems: 2D frictional triangular lattices (p = 1e-4, mu = 0.5, 3 dofs per
grain), about square, of 600, 2400 and 9600 grains. For each: assembly,
PSD/zero-mode check, dense eigensolve, modal signal, time-domain cost per
step and for one signal over 1.5 crossing times, peak memory (tracemalloc:
numpy arrays including the LAPACK workspace scipy allocates; not numba's or
scipy.sparse's C-level temporaries). Then: the crossover size where the time
domain beats diagonalization for one signal, the time-domain error against
the modal sum as a function of dt, eigensolve vs bare
scipy.linalg.eigh(driver="evd") at 1800 dofs, and a 1e5-grain lattice
(cost per step measured, full crossing time extrapolated unless --big-run).
Absolute times drift on a shared machine; ratios measured in one run are the
meaningful numbers.
"""

from __future__ import annotations

import argparse
import math
import time
import tracemalloc

import numpy as np
import scipy.linalg

from granwave import theory
from granwave.linear.assemble import check_stiffness, linearize
from granwave.linear.eigen import eigensolve, mass_weighted
from granwave.linear.propagate import (modal_propagate, stable_time_step, time_domain_signal,
                                      verlet_steps)

PRESSURE = 1e-4
FRICTION = 0.5


def lattice(n_grains: int):
    """About square frictional lattice: width w, rows r with r * (sqrt(3)/2) ~ w."""
    try:
        from granwave.systems import triangular_lattice
    except ImportError:  # before the systems module existed
        from granwave.linear.check import reference_lattice as _ref

        def triangular_lattice(*, rows, width, pressure, friction):
            return _ref(rows, width, pressure=pressure, friction=friction)
    width = int(round(math.sqrt(n_grains * math.sqrt(3) / 2)))
    rows = int(round(n_grains / width))
    return triangular_lattice(rows=rows, width=width, pressure=PRESSURE, friction=FRICTION)


def timed(fn, *args, **kwargs):
    tracemalloc.start()
    t = time.perf_counter()
    out = fn(*args, **kwargs)
    dt = time.perf_counter() - t
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return out, dt, peak / 1e6


def kernel_step_time(system, dt: float, n_steps: int = 200) -> float:
    """Seconds per velocity-Verlet step of the fused kernel alone (no omega_max, no sampling)."""
    D = system.stiffness.tocsr()
    args = (D.indptr.astype(np.int64), D.indices.astype(np.int64), D.data.astype(np.float64),
            1.0 / system.mass)
    u = np.zeros(system.n_dof)
    v = system.source_velocity.copy()
    a = np.zeros(system.n_dof)
    verlet_steps(*args, u, v, a, dt, 1, 1e-200)  # compile / warm up
    t = time.perf_counter()
    verlet_steps(*args, u, v, a, dt, n_steps, 1e-200)
    return (time.perf_counter() - t) / n_steps


def crossing_time(system) -> float:
    return system.height / theory.lattice_speed(PRESSURE, friction=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="only 600 and 2400 grains; no big lattice")
    ap.add_argument("--big-steps", type=int, default=200, help="steps timed on the 1e5-grain lattice")
    ap.add_argument("--big-run", action="store_true", help="run the 1e5-grain signal in full")
    ap.add_argument("--dense-max", type=int, default=8000, help="largest dof count for the dense eigensolve")
    args = ap.parse_args()
    sizes = (600, 2400) if args.quick else (600, 2400, 9600)

    print("== per size (2D frictional lattice, p = 1e-4)")
    print("(seconds; 'step ms' = fused Verlet kernel alone; 'time-dom' = one signal over 1.5\n"
          " crossing times including the omega_max Lanczos estimate and sampling)")
    print(f"{'grains':>7} {'dof':>6} {'assemble':>9} {'check':>8} {'eigen':>9} {'eig MB':>8} "
          f"{'modal':>7} {'step ms':>8} {'steps':>7} {'time-dom':>9} {'td MB':>7}")
    rows = []
    for n in sizes:
        pk = lattice(n)
        system, t_asm, _ = timed(linearize, pk, check=False)
        _, t_chk, _ = timed(check_stiffness, system)
        t_max = 1.5 * crossing_time(system)
        if system.n_dof <= args.dense_max:
            modes, t_eig, mem_eig = timed(eigensolve, system)
            _, t_modal, _ = timed(modal_propagate, modes, ic="A", t_max=t_max, samples=2001)
        else:
            modes, t_eig, mem_eig, t_modal = None, float("nan"), 3 * system.n_dof**2 * 8 / 1e6, float("nan")
        # time domain: one full signal over 1.5 crossing times
        # (401 samples: the sample interval then never limits the step, the safety rule does)
        sig, t_td, mem_td = timed(time_domain_signal, system, ic="A", t_max=t_max, samples=401)
        per_step = kernel_step_time(system, sig.attrs["dt"])
        rows.append(dict(n=n, dof=system.n_dof, t_eig=t_eig, t_modal=t_modal, t_td=t_td,
                         steps=sig.attrs["n_steps"], per_step=per_step, t_asm=t_asm))
        print(f"{n:7d} {system.n_dof:6d} {t_asm:9.3f} {t_chk:8.2f} {t_eig:9.2f} {mem_eig:8.0f} "
              f"{t_modal:7.2f} {1e3 * per_step:8.3f} {sig.attrs['n_steps']:7d} {t_td:9.2f} {mem_td:7.1f}")

    # Crossover: eigensolve ~ a n^3; one time-domain signal ~ b n^1.5 (steps ~ height ~ sqrt(n),
    # cost per step ~ n). Fit a and b on the measured sizes.
    meas = [r for r in rows if math.isfinite(r["t_eig"])]
    a = np.exp(np.mean([math.log(r["t_eig"] / r["dof"] ** 3) for r in meas[-1:]]))
    b = np.exp(np.mean([math.log(r["t_td"] / r["dof"] ** 1.5) for r in rows[1:]]))
    n_cross = (b / a) ** (1 / 1.5)
    print(f"\ncrossover: eigensolve ~ {a:.3g} n^3 s, time domain (1.5 crossings) ~ {b:.3g} n^1.5 s;"
          f" time domain cheaper above ~{n_cross:.0f} dof (~{n_cross / 3:.0f} grains)")
    for r in rows:
        if not math.isfinite(r["t_eig"]):
            print(f"  {r['n']} grains ({r['dof']} dof): dense eigensolve not run "
                  f"(needs ~{3 * r['dof']**2 * 8 / 1e9:.0f} GB); extrapolated {a * r['dof']**3:.0f} s "
                  f"vs time domain {r['t_td']:.1f} s measured")

    print("\n== time-domain error vs modal sum (600 grains, IC A, 1.5 crossing times)")
    pk = lattice(600)
    system = linearize(pk, check=False)
    modes = eigensolve(system)
    t_max = 1.5 * crossing_time(system)
    ref = modal_propagate(modes, ic="A", t_max=t_max, samples=101).force
    dt0, wmax = stable_time_step(system)
    prev = None
    for safety in (0.4, 0.2, 0.1, 0.05, 0.025):
        sig = time_domain_signal(system, ic="A", t_max=t_max, samples=101, safety=safety)
        err = np.abs(sig.force - ref).max() / np.abs(ref).max()
        ratio = f"  ratio {prev / err:.2f}" if prev else ""
        print(f"  safety {safety:5.3f}  omega_max dt {sig.attrs['omega_max_dt']:.4f}  "
              f"rel. max error {err:.3e}{ratio}  ({sig.attrs['wall_time']:.2f} s)")
        prev = err

    print("\n== eigensolve vs bare scipy.linalg.eigh(driver='evd'), 1800 dof")
    A, _ = mass_weighted(system)
    dense = A.toarray()
    t_bare, t_ours = [], []
    for _ in range(3):
        t = time.perf_counter()
        scipy.linalg.eigh(dense, driver="evd")
        t_bare.append(time.perf_counter() - t)
        t = time.perf_counter()
        eigensolve(system)
        t_ours.append(time.perf_counter() - t)
    t = time.perf_counter()
    scipy.linalg.eigh(dense)
    t_default = time.perf_counter() - t
    print(f"  bare evd {min(t_bare):.3f} s, granwave eigensolve {min(t_ours):.3f} s "
          f"(ratio {min(t_ours) / min(t_bare):.2f}); scipy default driver {t_default:.3f} s "
          f"({t_default / min(t_bare):.1f}x evd)")

    if args.quick:
        return
    print("\n== 1e5-grain lattice, time domain")
    pk, t_gen, _ = timed(lattice, 100_000)
    system, t_asm, mem_asm = timed(linearize, pk, check=False)
    (dt, wmax), t_w, _ = timed(stable_time_step, system)
    t_cross = crossing_time(system)
    steps_needed = int(math.ceil(t_cross / dt))
    print(f"  {pk.n_grains} grains, {system.n_dof} dof, nnz {system.stiffness.nnz}: generate {t_gen:.1f} s, "
          f"assemble {t_asm:.1f} s ({mem_asm:.0f} MB peak), omega_max {t_w:.1f} s")
    if args.big_run:
        sig, t_run, mem = timed(time_domain_signal, system, ic="A", t_max=t_cross, samples=401,
                                progress=print, progress_interval=60)
        print(f"  full crossing t = {t_cross:.0f}: {sig.attrs['n_steps']} steps in {t_run:.0f} s "
              f"({mem:.0f} MB peak)")
    else:
        per_step = kernel_step_time(system, dt, args.big_steps)
        print(f"  {args.big_steps} steps: {1e3 * per_step:.1f} ms/step; "
              f"crossing time {t_cross:.0f} = {steps_needed} steps at dt {dt:.3g} -> "
              f"extrapolated {per_step * steps_needed:.0f} s (goal < 600 s)")


if __name__ == "__main__":
    main()
