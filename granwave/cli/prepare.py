"""``granwave prepare-packing``: a disordered packing by piston compression (docs/method.md §3)."""

from __future__ import annotations

import os

import click

from ..errors import InputError
from ..params import PrepareParams
from .common import options_from, output_option, params_from, progress_printer, quiet_option, stage, threads_option

#: ``--device cpu|gpu`` (also used by ``propagate``): where the stage's kernels run (docs/gpu.md).
device_option = click.option(
    "--device", type=click.Choice(["cpu", "gpu"]), default="cpu", show_default=True,
    help="Run the kernels on the CPU or on one NVIDIA GPU (needs the gpu extra; docs/gpu.md).")


#: ``--checkpoint FILE`` / ``--checkpoint-every SECONDS``: stop a long preparation and go on later
#: (granwave.dem.checkpoint; docs/dem.md "Checkpoints").
checkpoint_option = click.option(
    "--checkpoint", type=click.Path(dir_okay=False), default=None,
    help="Write the run's state to this file every --checkpoint-every seconds; if it exists at the "
         "start (same parameters and seed), go on from it. The packing is the same, bit for bit, as "
         "an uninterrupted run's; the file is removed once the packing is written. CPU only.")
checkpoint_every_option = click.option(
    "--checkpoint-every", type=click.FloatRange(min=0.0), default=600.0, show_default=True,
    metavar="SECONDS", help="Seconds between two checkpoints (0: after every chunk of steps).")


@click.command("prepare-packing")
@options_from(PrepareParams)
@output_option
@threads_option
@device_option
@checkpoint_option
@checkpoint_every_option
@quiet_option
@stage
def prepare_packing(output, threads, device, checkpoint, checkpoint_every, quiet, **options):
    """Prepare a packing in mechanical equilibrium by piston compression of a granular gas.

    Hertz-Mindlin contacts (or harmonic ones: --contact-law) with Coulomb friction and
    damping; converged when every acceleration (grains, rotations, piston) is below --tol
    and every speed below the impact speed of --tol (see docs/dem.md). Writes a granwave.packing file with
    the force-carrying contacts (j = -1 bottom wall, -2 piston) and the protocol in
    its attributes.
    """
    from .. import api
    from ..io.files import check_writable, same_file_as, write_packing

    params = params_from(PrepareParams, options)
    check_writable(output)
    if checkpoint is not None and (os.path.abspath(checkpoint) == os.path.abspath(output)
                                   or same_file_as(checkpoint, [output])):
        raise InputError(f"--checkpoint {checkpoint} is the output file; choose another name")
    packing = api.prepare_packing(params, progress=progress_printer(not quiet), threads=threads,
                                  device=device, checkpoint=checkpoint, checkpoint_every=checkpoint_every,
                                  keep_checkpoint=True)
    write_packing(output, packing)
    if checkpoint is not None:
        from ..dem.checkpoint import Checkpoint

        Checkpoint(checkpoint, params).remove()  # the packing is written
    if not quiet:
        a = packing.attrs
        click.echo(f"wrote {output}: {packing.n_grains} grains, {len(packing.contacts)} contacts, "
                   f"height {packing.height:.4f}, steps {a['steps']}, residual {a['max_acceleration']:.3g}",
                   err=True)
