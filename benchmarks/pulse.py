"""Cost of one damped nonlinear DEM pulse against the linear time-domain signal (printed); with
``--shock``, a strong push across a 10⁴-grain column against the preparation engine (recorded).

    python benchmarks/pulse.py [--grains 600] [--damping 0.1] [--crossings 3] [--packing FILE]
    nice -n 10 python benchmarks/pulse.py --shock [--rows 1250 --width 8] [--pairs 5] [--shock-damping 0]
        [--shock-friction 0] [--no-record]
    python benchmarks/pulse.py --shock --device gpu      # on a GPU machine (pip install -e '.[gpu]')

``--shock`` (issue #63, docs/shocks.md): a triangular lattice of rows x width grains (default 1250 x
8 = 10⁴, Hertz, p = 1e-4, frictionless unless ``--shock-friction``) pushed by the piston at the
strain 10 δ0/d (a strong push: ε/δ0 = 10; undamped unless ``--shock-damping``) over ``--fraction``
of the default record, sampled as the default record is (its 2001 samples' interval: the same steps
per sample, so the pulse field's per-sample reading costs what it costs in a full run);
grain-steps/s of the pulse (``propagate_dem``, pulse field on, no baseline) on one thread against
the preparation engine's (``Engine.run``, damped, piston, the lattice's friction, on the same state)
on one thread, in the same run; and the pulse's rate on 2 threads against 1 (the thread ratio); also
the pulse against the preparation engine stepping the same push (``Engine.run`` on the pulse's own
set-up: the same neighbour rebuilds, without the pulse's bookkeeping and readings), which splits the
difference. The machine is shared and its speed drifts by up to 50 % over seconds, so each ratio is
the median over ``--pairs`` adjacent pairs of runs, the order alternating (CPU time of this process
for one thread, wall time for two); the load average is recorded. ``--device gpu``: the pulse and
the preparation engine (granwave.gpu's GpuEngine) on the GPU, wall time, no thread ratio (the
prepared measurement for a GPU machine). Appends benchmarks/results/pulse.jsonl unless
``--no-record``.

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


def shock(args) -> dict:
    """The ``--shock`` measurement (module docstring): a dict of rates and ratios."""
    import os
    import statistics

    import numba
    import numpy as np

    from granwave.dem.kick import RECORD_CROSSINGS, front_speed_bound, kick_size, peak_overlap
    from granwave.systems import triangular_lattice

    gpu = args.device == "gpu"
    if gpu:
        from granwave.devices import backend

        engine_class = backend("gpu").engine  # checks the GPU first (one line, exit 2 without one)
    else:
        from granwave.dem.integrator import Engine as engine_class
    load_start = os.getloadavg()
    packing = triangular_lattice(rows=args.rows, width=args.width, pressure=1e-4, friction=args.shock_friction)
    n = packing.n_grains
    delta0 = float(np.mean(packing.contacts.overlap[packing.contacts.j >= 0]))
    strain = 10.0 * delta0 / 1.0  # ε = 10 δ0 / d
    size = kick_size(packing, drive="piston", strain=strain)
    peak, _ = peak_overlap(packing, ic="A", velocity=size["velocity"], displacement=0.0, drive="piston")
    t_max = args.fraction * RECORD_CROSSINGS * packing.height / front_speed_bound(packing, peak=peak)["speed"]
    # the default record's sampling (2001 samples over the whole record): as many steps per sample
    samples = max(11, int(round(args.fraction * (args.samples - 1))) + 1)
    kw = dict(drive="piston", strain=strain, baseline=False, samples=samples, device=args.device,
              damping=args.shock_damping)
    print(f"lattice {args.rows} x {args.width} = {n} grains, height {packing.height:.1f}; piston strain "
          f"{strain:.3g} (10 delta0), v_p {size['velocity']:.3g}; t_max {t_max:.4g} "
          f"({args.fraction:g} of the default record); pulse damping {args.shock_damping:g}, friction "
          f"{args.shock_friction:g}; device {args.device}; "
          f"load average {load_start[0]:.2f} {load_start[1]:.2f} {load_start[2]:.2f}", flush=True)
    for threads in ((1,) if gpu else (1, 2)):  # compile (the one-thread and the parallel kernels)
        numba.set_num_threads(threads)
        propagate_dem(packing, t_max=t_max / 100, **{**kw, "samples": 11})

    def clock(threads: int):
        """CPU time of this process on one CPU thread (the other agents' load does not count),
        wall time on two threads or on the GPU."""
        return time.process_time if threads == 1 and not gpu else time.perf_counter

    def pulse_rate(threads: int) -> tuple[float, dict]:
        numba.set_num_threads(threads)
        now = clock(threads)
        t0 = now()
        sig = propagate_dem(packing, t_max=t_max, **kw)
        return n * sig.attrs["n_steps"] / (now() - t0), sig.attrs

    def prepare_rate() -> float:
        numba.set_num_threads(1)
        eng = engine_class(packing.position, packing.radius, packing.box[:-1], float(packing.box[-1]),
                           friction=args.shock_friction,
                           damping=0.5, skin=0.2, piston_mass=float(n), piston_force=1e-4 * float(packing.box[0]),
                           velocity=np.random.default_rng(0).normal(0.0, 1e-4, packing.position.shape))
        eng.run(20)
        now = clock(1)
        t0 = now()
        rebuilds = eng.rebuilds
        eng.run(args.prepare_steps)
        prep_rebuilds.append(eng.rebuilds - rebuilds)
        return n * args.prepare_steps / (now() - t0)

    def push_rate(steps: int) -> float:
        """The preparation engine's own stepping (Engine.run, no bookkeeping, no readings) of the
        same push: the pulse's engine in the stored state with the piston set moving as
        granwave.dem.pulse._run sets it, so the same neighbour rebuilds (one thread)."""
        from granwave.dem import kernels as K
        from granwave.dem import pulse as P

        numba.set_num_threads(1)
        eng = P.engine_from_packing(packing, dt=attrs["dt"], damping=args.shock_damping)
        grains, _ = P.source(packing, "normal")
        eng.mass[grains] *= P.PISTON_MASS_FACTOR
        eng.inertia[grains] *= P.PISTON_MASS_FACTOR
        K.pair_constants(eng.pair_i, eng.pair_j, eng.n_pairs, eng.radius, eng.mass, eng.ws.pair_c)
        eng.velocity[grains, packing.dim - 1] = attrs["piston_velocity"]
        P._forces_now(eng)
        t0 = time.process_time()
        eng.run(steps)
        return n * steps / (time.process_time() - t0)

    prep_rebuilds = []  # the preparation runs' neighbour rebuilds

    # adjacent pairs, the order alternating (the machine's speed drifts over seconds): the median
    # of the pairs' ratios is the number, not one run
    pulse1, prep, ratios = [], [], []
    for k in range(args.pairs):
        if k % 2 == 0:
            r1, attrs = pulse_rate(1)
            rp = prepare_rate()
        else:
            rp = prepare_rate()
            r1, attrs = pulse_rate(1)
        pulse1.append(r1)
        prep.append(rp)
        ratios.append(r1 / rp)
        print(f"pair {k}: pulse {r1:.3g}, preparation {rp:.3g} grain-steps/s: ratio {r1 / rp:.3f}", flush=True)
    out = {"grains": n, "device": args.device, "damping": args.shock_damping, "friction": args.shock_friction,
           "steps": attrs["n_steps"],
           "samples": samples, "dt": attrs["dt"], "t_max": t_max, "front_speed": attrs["front_speed"], "front_speed_bound": attrs["front_speed_bound"],
           "pairs": args.pairs, "pulse_rates_1": pulse1, "prepare_rates_1": prep, "pair_ratios": ratios,
           "pulse_rate_1": statistics.median(pulse1), "prepare_rate_1": statistics.median(prep),
           "pulse_over_prepare": statistics.median(ratios), "load_average_start": list(load_start),
           "prepare_steps": args.prepare_steps, "prepare_rebuilds": prep_rebuilds,
           "pulse_rebuilds": attrs["neighbour_rebuilds"]}
    print(f"pulse / preparation, {'on the GPU' if gpu else 'one thread'}: median of {args.pairs} adjacent pairs "
          f"{out['pulse_over_prepare']:.3f} (pairs {', '.join(f'{r:.3f}' for r in ratios)})")
    if not gpu:
        # the bookkeeping's and readings' share: the pulse against the engine stepping the same push
        push, push_ratios = [], []
        for k in range(args.pairs):
            if k % 2 == 0:
                r1, _ = pulse_rate(1)
                re = push_rate(attrs["n_steps"])
            else:
                re = push_rate(attrs["n_steps"])
                r1, _ = pulse_rate(1)
            push.append(re)
            push_ratios.append(r1 / re)
            print(f"pair {k}: pulse {r1:.3g}, engine on the same push {re:.3g} grain-steps/s: ratio {r1 / re:.3f}",
                  flush=True)
        out.update(push_rates_1=push, push_pair_ratios=push_ratios, push_rate_1=statistics.median(push),
                   pulse_over_push=statistics.median(push_ratios), neighbour_rebuilds=attrs["neighbour_rebuilds"])
        print(f"pulse / engine on the same push ({attrs['neighbour_rebuilds']} rebuilds), one thread: median of "
              f"{args.pairs} adjacent pairs {out['pulse_over_push']:.3f}")
        two, thread_ratios = [], []
        for k in range(args.pairs):
            if k % 2 == 0:
                r2, _ = pulse_rate(2)
                r1, _ = pulse_rate(1)
            else:
                r1, _ = pulse_rate(1)
                r2, _ = pulse_rate(2)
            two.append(r2)
            thread_ratios.append(r2 / r1)
            print(f"pair {k}: pulse on 2 threads {r2:.3g} (wall), on 1 thread {r1:.3g} (CPU time) grain-steps/s: "
                  f"ratio {r2 / r1:.3f}", flush=True)
        out.update(pulse_rates_2=two, thread_pair_ratios=thread_ratios, pulse_rate_2=statistics.median(two),
                   threads_2_over_1=statistics.median(thread_ratios))
        print(f"pulse 2 threads / 1: median of {args.pairs} adjacent pairs {out['threads_2_over_1']:.3f}")
    out["load_average_end"] = list(os.getloadavg())
    print(f"load average at the end: {' '.join(f'{x:.2f}' for x in out['load_average_end'])}")
    numba.set_num_threads(1)
    return out


def record_shock(result: dict, argv: list[str]) -> None:
    import json
    import os
    import platform
    from pathlib import Path

    from granwave.provenance import git_revision

    load = (f"load average {result['load_average_start'][0]:.2f} at the start, "
            f"{result['load_average_end'][0]:.2f} at the end")
    summary = {"grains": result["grains"], "device": result["device"], "pulse damping": result["damping"],
               "friction": result.get("friction", 0.0),
               ("pulse / preparation per core" if result["device"] == "cpu" else "pulse / preparation on the GPU"): {
                   "values": f"{result['pulse_rate_1']:.3g} / {result['prepare_rate_1']:.3g} grain-steps/s (medians)",
                   "ratio": round(result["pulse_over_prepare"], 3), "goal": 1.0}}
    if "pulse_over_push" in result:
        summary["pulse / engine on the same push per core"] = {
            "values": f"{result['pulse_rate_1']:.3g} / {result['push_rate_1']:.3g} grain-steps/s (medians; "
                      f"{result['neighbour_rebuilds']} neighbour rebuilds in {result['steps']} steps in both; "
                      f"the preparation's {max(result['prepare_rebuilds'])} at most in {result['prepare_steps']})",
            "ratio": round(result["pulse_over_push"], 3)}
    if "threads_2_over_1" in result:
        summary["2 threads / 1"] = {"values": f"{result['pulse_rate_2']:.3g} / {result['pulse_rate_1']:.3g} "
                                              f"({load})", "ratio": round(result["threads_2_over_1"], 3)}
    rec = {"date": time.strftime("%Y-%m-%d"), "benchmark": "pulse_shock",
           "command": "python benchmarks/pulse.py " + " ".join(argv), "git_revision": git_revision(),
           "machine": {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
                       "shared": True},
           "summary": summary,
           "notes": f"shared 2-core machine with other work running ({load}): absolute rates drift by up to "
                    "50 % over seconds; each ratio is the median over adjacent pairs of runs, the order alternating "
                    "(one thread: CPU time of this process; two threads and the GPU: wall time)",
           "result": result}
    path = Path(__file__).resolve().parent / "results" / "pulse.jsonl"
    with path.open("a") as fh:
        fh.write(json.dumps(rec) + "\n")
    print(f"recorded {path}")


def main() -> None:
    import sys

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shock", action="store_true", help="the strong push across a 10^4-grain column (recorded)")
    ap.add_argument("--rows", type=int, default=1250)
    ap.add_argument("--width", type=int, default=8)
    ap.add_argument("--fraction", type=float, default=0.05, help="--shock: the part of the default record run")
    ap.add_argument("--pairs", type=int, default=5, help="--shock: adjacent pairs of runs (the median ratio)")
    ap.add_argument("--device", choices=("cpu", "gpu"), default="cpu",
                    help="--shock: the pulse and the preparation engine on this device (gpu: wall time)")
    ap.add_argument("--shock-damping", type=float, default=0.0,
                    help="--shock: the pulse's contact damping zeta (default 0, the pulses' default)")
    ap.add_argument("--shock-friction", type=float, default=0.0,
                    help="--shock: the lattice's friction mu, the preparation engine's too (default 0, frictionless)")
    ap.add_argument("--prepare-steps", type=int, default=2000)
    ap.add_argument("--no-record", action="store_true")
    ap.add_argument("--grains", type=int, default=600)
    ap.add_argument("--damping", type=float, default=0.1)
    ap.add_argument("--crossings", type=float, default=3.0)
    ap.add_argument("--samples", type=int, default=2001)
    ap.add_argument("--packing", default=None, help="use this packing file instead of preparing one")
    args = ap.parse_args()
    if args.shock:
        result = shock(args)
        if not args.no_record:
            record_shock(result, sys.argv[1:])
        return

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
