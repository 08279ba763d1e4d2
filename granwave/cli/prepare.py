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


#: ``--seeds SEEDS``: one packing per seed, one file per seed (the output a pattern with ``{seed}``).
seeds_option = click.option(
    "--seeds", default=None, metavar="SEEDS",
    help="Prepare one packing per seed (e.g. 0-9 or 0,2,5-7; instead of --seed), each written to "
         "the output pattern with {seed} replaced (e.g. -o 'out_{seed}.h5'). Each file is the one "
         "--seed N would write. With --device gpu the seeds are advanced together by the same kernel "
         "launches (docs/gpu.md), with --device cpu one after another.")


def parse_seeds(spec: str) -> list[int]:
    """The seeds of ``spec``: comma-separated seeds and inclusive ranges ``a-b`` ("0-9", "1,4-6")."""
    seeds = []
    for part in spec.split(","):
        lo, sep, hi = part.strip().partition("-")
        try:
            a = int(lo)
            b = int(hi) if sep else a
        except ValueError:
            raise InputError(f"--seeds {spec!r}: expected seeds and ranges such as 0-9 or 0,2,5-7") from None
        if a < 0 or b < a:
            raise InputError(f"--seeds {spec!r}: a range a-b needs 0 <= a <= b (got {part.strip()!r})")
        seeds.extend(range(a, b + 1))
    if len(set(seeds)) != len(seeds):
        raise InputError(f"--seeds {spec!r}: a seed is listed twice")
    return seeds


@click.command("prepare-packing")
@options_from(PrepareParams)
@output_option
@threads_option
@device_option
@checkpoint_option
@checkpoint_every_option
@seeds_option
@quiet_option
@stage
def prepare_packing(output, threads, device, checkpoint, checkpoint_every, seeds, quiet, **options):
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
    if seeds is not None:
        _prepare_seeds(params, parse_seeds(seeds), output, threads, device, checkpoint, quiet)
        return
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


def _prepare_seeds(params, seeds, pattern, threads, device, checkpoint, quiet) -> None:
    """``--seeds``: every output name checked before any work, then one file per seed."""
    from .. import api
    from ..io.files import check_writable, write_packing

    if click.get_current_context().get_parameter_source("seed").name != "DEFAULT":
        raise InputError("--seed and --seeds: give one of them")
    if checkpoint is not None:
        raise InputError("--checkpoint runs one seed; use --seed, or leave --checkpoint out")
    if "{seed}" not in pattern:
        raise InputError(f"--seeds: the output {pattern!r} must contain {{seed}} (one file per seed)")
    outputs = [pattern.replace("{seed}", str(s)) for s in seeds]
    for out in outputs:
        check_writable(out)
    packings = api.prepare_packings(params, seeds=seeds, progress=progress_printer(not quiet), threads=threads,
                                    device=device)
    for out, packing in zip(outputs, packings):
        write_packing(out, packing)
        if not quiet:
            a = packing.attrs
            click.echo(f"wrote {out}: seed {a['seed']}, {packing.n_grains} grains, {len(packing.contacts)} "
                       f"contacts, height {packing.height:.4f}, steps {a['steps']}, residual "
                       f"{a['max_acceleration']:.3g}", err=True)
