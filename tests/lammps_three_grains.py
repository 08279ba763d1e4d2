"""One LAMMPS run shared by the contact-law checks against LAMMPS (tests/test_interop.py,
tests/test_harmonic.py): grain 1 (d = 1) held at the origin, grain 2 (d = 0.9) touching it along
x, grain 3 (d = 1) touching the wall z = -3, each pair at overlap ``overlap``; grains 2 and 3
moved by fix move at the normal and tangential speeds for ``nsteps`` steps of ``dt``."""

import numpy as np


def three_grain_forces(lammps, pair_words: str, wall_words: str, *, r1: float, r2: float,
                       overlap: float, v_normal: float, v_tangential: float, dt: float, nsteps: int):
    """(forces, positions) of the three grains after the run, in atom-id order.

    ``lammps``: the lammps Python module; ``pair_words`` / ``wall_words``: the granular model
    words of the pair and of the wall (granwave.interop.lammps.granular_model).
    """
    n = overlap
    L = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
    for line in ["units lj", "atom_style sphere", "atom_modify map array", "boundary f f f",
                 "comm_modify vel yes", "newton off", "region box block -3 3 -3 3 -3 3",
                 "create_box 1 box", "create_atoms 1 single 0 0 0",
                 f"create_atoms 1 single {r1 + r2 - n!r} 0 0",
                 f"create_atoms 1 single 0 0 {-3 + r1 - n!r}",
                 "set atom 1 diameter 1.0", "set atom 2 diameter 0.9", "set atom 3 diameter 1.0",
                 "set atom 1*3 density 1", "pair_style granular",
                 f"pair_coeff * * {pair_words}",
                 f"fix wall all wall/gran granular {wall_words} zplane -3 NULL",
                 "group one id 1", "group two id 2", "group three id 3",
                 "fix a one move linear 0 0 0",
                 f"fix b two move linear {-v_normal!r} {v_tangential!r} 0",
                 f"fix c three move linear {v_tangential!r} 0 {-v_normal!r}",
                 # fix move sets velocities only when it moves: set them for the setup forces
                 f"velocity two set {-v_normal!r} {v_tangential!r} 0",
                 f"velocity three set {v_tangential!r} 0 {-v_normal!r}",
                 f"timestep {dt!r}", f"run {nsteps}"]:
        L.command(line)
    f = L.numpy.extract_atom("f").copy()
    ids = L.numpy.extract_atom("id").copy()
    x = L.numpy.extract_atom("x").copy()
    L.close()
    order = np.argsort(ids)
    return f[order], x[order]
