"""``granwave prepare-packing``: a disordered packing by piston compression (SPEC §3)."""

from __future__ import annotations

import click

from .common import NON_NEGATIVE, POSITIVE, FiniteFloat, output_option, progress_printer, seed_option, stage


@click.command("prepare-packing")
@click.option("--dim", type=click.Choice(["2", "3"]), default="2", show_default=True,
              help="2: sphere centres in a plane (x periodic, y vertical); 3: x, y periodic, z vertical.")
@click.option("--grains", type=click.IntRange(min=1), default=600, show_default=True,
              help="Number of grains N.")
@click.option("--pressure", type=POSITIVE, default=1e-4, show_default=True,
              help="Piston pressure p in units of E* (2D: force / (L1 x 1 d); 3D: force / (L1 L2)).")
@click.option("--friction", type=NON_NEGATIVE, default=0.5, show_default=True,
              help="Coulomb friction mu (0: frictionless, no rotational degrees of freedom).")
@click.option("--poisson", type=FiniteFloat(min=0.0, max=0.5, max_open=True), default=0.0,
              show_default=True, help="Poisson ratio nu in [0, 0.5): k_t/k_n = 2(1-nu)/(2-nu).")
@click.option("--polydispersity", type=FiniteFloat(min=0.0, max=1.0, max_open=True), default=0.2,
              show_default=True, help="W: diameters uniform in [1-W, 1+W] (in mean diameters); 0 = monodisperse.")
@click.option("--aspect", type=POSITIVE, default=1.0, show_default=True,
              help="Expected final height / periodic width.")
@click.option("--damping", "damping", type=FiniteFloat(min=0.0, max=1.0), default=0.5, show_default=True,
              help="Contact damping zeta, fraction of critical (normal and tangential).")
@click.option("--background-damping", type=NON_NEGATIVE, default=0.3, show_default=True,
              help="Background viscous damping rate in units of 1/t_i, t_i = sqrt(m/(p d)) "
                   "(sets the compaction speed; keep it fixed within a study).")
@click.option("--piston-mass", type=POSITIVE, default=None,
              help="Piston mass in rho d^3  [default: one layer of grains, mean mass x L1 (2D) or L1 L2 (3D)].")
@click.option("--gas-density", type=FiniteFloat(min=0.0, max=0.6, min_open=True, max_open=True), default=None,
              help="Initial solid fraction of the granular gas  [default: 0.5 in 2D, 0.3 in 3D].")
@click.option("--tol", type=POSITIVE, default=1e-10, show_default=True,
              help="Convergence threshold on every acceleration (E*/(rho d)); velocities are tested too.")
@click.option("--max-steps", type=click.IntRange(min=1), default=2_000_000, show_default=True,
              help="Step budget; not converged by then: error, no output file.")
@click.option("--safety", type=FiniteFloat(min=0.0, min_open=True), default=0.05, show_default=True,
              help="Time-step factor: dt = (safety/0.1) x the stability limit of the stiffest contact "
                   "(normal and rotational modes, contact damping included; docs/dem.md). "
                   "At most 0.06.")
@seed_option
@output_option
@click.option("-q", "--quiet", is_flag=True, help="No progress lines on stderr.")
@stage
def prepare_packing(dim, grains, pressure, friction, poisson, polydispersity, aspect, damping,
                    background_damping, piston_mass, gas_density, tol, max_steps, safety, seed, output,
                    quiet):
    """Prepare a packing in mechanical equilibrium by piston compression of a granular gas.

    Hertz-Mindlin contacts with Coulomb friction and damping; converged when every
    acceleration (grains, rotations, piston) is below --tol and every speed below the
    Hertz impact speed of --tol (see docs/dem.md). Writes a granwave.packing file with
    the force-carrying contacts (j = -1 bottom wall, -2 piston) and the protocol in
    its attributes.
    """
    from ..dem.params import PrepareParams
    from ..dem.protocol import prepare_packing as run
    from ..io.files import check_writable, write_packing

    params = PrepareParams(dim=int(dim), grains=grains, pressure=pressure, friction=friction, poisson=poisson,
                           polydispersity=polydispersity, aspect=aspect, damping=damping,
                           background_damping=background_damping, piston_mass=piston_mass,
                           gas_density=gas_density, tol=tol, max_steps=max_steps, seed=seed, safety=safety)
    check_writable(output)
    packing = run(params, progress=progress_printer(not quiet))
    write_packing(output, packing)
    if not quiet:
        a = packing.attrs
        click.echo(f"wrote {output}: {packing.n_grains} grains, {len(packing.contacts)} contacts, "
                   f"height {packing.height:.4f}, steps {a['steps']}, residual {a['max_acceleration']:.3g}",
                   err=True)
