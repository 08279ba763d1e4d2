"""``granwave prepare-packing``: a disordered packing by piston compression (docs/method.md §3)."""

from __future__ import annotations

import click

from ..params import PrepareParams
from .common import options_from, output_option, params_from, progress_printer, quiet_option, stage, threads_option

#: ``--device cpu|gpu`` (also used by ``propagate``): where the stage's kernels run (docs/gpu.md).
device_option = click.option(
    "--device", type=click.Choice(["cpu", "gpu"]), default="cpu", show_default=True,
    help="Run the kernels on the CPU or on one NVIDIA GPU (needs the gpu extra; docs/gpu.md).")


@click.command("prepare-packing")
@options_from(PrepareParams)
@output_option
@threads_option
@device_option
@quiet_option
@stage
def prepare_packing(output, threads, device, quiet, **options):
    """Prepare a packing in mechanical equilibrium by piston compression of a granular gas.

    Hertz-Mindlin contacts (or harmonic ones: --contact-law) with Coulomb friction and
    damping; converged when every acceleration (grains, rotations, piston) is below --tol
    and every speed below the impact speed of --tol (see docs/dem.md). Writes a granwave.packing file with
    the force-carrying contacts (j = -1 bottom wall, -2 piston) and the protocol in
    its attributes.
    """
    from .. import api
    from ..io.files import check_writable, write_packing

    params = params_from(PrepareParams, options)
    check_writable(output)
    packing = api.prepare_packing(params, progress=progress_printer(not quiet), threads=threads,
                                  device=device)
    write_packing(output, packing)
    if not quiet:
        a = packing.attrs
        click.echo(f"wrote {output}: {packing.n_grains} grains, {len(packing.contacts)} contacts, "
                   f"height {packing.height:.4f}, steps {a['steps']}, residual {a['max_acceleration']:.3g}",
                   err=True)
