"""A free collision (two grains, or a grain and the rigid bottom wall) run in granwave's DEM engine
and in LAMMPS with the words ``export lammps`` writes: the checks of contact sub-models against
LAMMPS (tests/test_linear_history.py, tests/test_constant_viscous.py).

Both in 3D, in a 10 x 10 x 10 box periodic in x and y, the bottom wall at z = 0 (granwave's top
wall, fixed, at z = 10, never reached); velocity Verlet with the same dt in both (LAMMPS's
``fix nve/sphere``: solid spheres of density 1, I = m d^2 / 10, as granwave's grains).
"""

import numpy as np

BOX = 10.0


def granwave_collision(*, position, radius, velocity, spin, dt: float, steps: int, friction: float,
                       poisson: float = 0.0, damping: float = 0.0, **contact):
    """(velocities, spins) (N, 3) after ``steps`` steps of granwave's engine from the given state;
    ``contact``: the sub-models by their PrepareParams names (granwave.contact_models.options)."""
    from granwave.dem.integrator import Engine

    e = Engine(np.asarray(position, float), np.asarray(radius, float), [BOX, BOX], BOX, friction=friction,
               poisson=poisson, damping=damping, dt=dt, skin=0.2, check_every=0,
               velocity=np.asarray(velocity, float), angular_velocity=np.asarray(spin, float), **contact)
    e.run(steps)
    return e.velocity.copy(), e.angular_velocity.copy()


def lammps_collision(lammps, *, position, radius, velocity, spin, dt: float, steps: int, pair_words: str,
                     wall_words: str | None = None):
    """(velocities, spins) (N, 3) after ``steps`` steps of LAMMPS from the same state (atom order);
    ``pair_words`` / ``wall_words``: the granular model words of pairs and of the bottom wall
    (granwave.interop.lammps.granular_model); ``lammps``: the lammps Python module."""
    L = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
    lines = ["units lj", "atom_style sphere", "atom_modify map array", "dimension 3", "boundary p p f",
             "comm_modify vel yes", "newton off", f"region box block 0 {BOX} 0 {BOX} 0 {BOX}",
             "create_box 1 box"]
    for k, (x, r, v, w) in enumerate(zip(position, radius, velocity, spin)):
        lines += [f"create_atoms 1 single {x[0]!r} {x[1]!r} {x[2]!r}",
                  f"set atom {k + 1} diameter {2.0 * r!r}", f"set atom {k + 1} density 1.0",
                  f"set atom {k + 1} vx {v[0]!r} vy {v[1]!r} vz {v[2]!r}",
                  f"set atom {k + 1} omega {w[0]!r} {w[1]!r} {w[2]!r}"]
    lines += ["pair_style granular", f"pair_coeff * * {pair_words}", "neighbor 0.3 bin"]
    if wall_words is not None:
        lines.append(f"fix wall all wall/gran granular {wall_words} zplane 0.0 NULL")
    lines += ["fix move all nve/sphere", f"timestep {dt!r}", f"run {steps}"]
    for line in lines:
        L.command(line)
    ids = L.numpy.extract_atom("id").copy()
    v = L.numpy.extract_atom("v").copy()
    w = L.numpy.extract_atom("omega").copy()
    L.close()
    order = np.argsort(ids)
    return v[order], w[order]
