"""``granwave prepare-packing``: a disordered packing by piston compression (docs/method.md §3)."""

from __future__ import annotations

import os

import click

from ..errors import InputError
from ..params import PrepareParams
from .common import (long_run_option, options_from, output_option, params_from, progress_printer, quiet_option,
                     stage, threads_option)

#: ``--device cpu|gpu`` (also used by ``propagate``): where the stage's kernels run (docs/gpu.md).
device_option = click.option(
    "--device", type=click.Choice(["cpu", "gpu"]), default="cpu", show_default=True,
    help="Run the kernels on the CPU or on one NVIDIA GPU (needs the gpu extra; docs/gpu.md).")


#: ``--checkpoint FILE`` / ``--checkpoint-every SECONDS``: stop a long preparation and go on later
#: (granwave.dem.checkpoint; docs/dem.md "Checkpoints").
checkpoint_option = click.option(
    "--checkpoint", type=click.Path(dir_okay=False), default=None,
    help="Write the run's state to this file every --checkpoint-every seconds; if it exists at the "
         "start (same parameters, seed and --device), go on from it. The packing is the same, bit for "
         "bit, as an uninterrupted run's; the file is removed once the packing is written. With "
         "--seeds a pattern with {seed}: one checkpoint per seed (e.g. 'ck_{seed}.h5').")
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


#: ``--material NAME``: the grains' Poisson ratio from a material preset (granwave.units.MATERIALS),
#: recorded in the packing for SI conversions (docs/units.md).
material_option = click.option(
    "--material", type=click.Choice(["glass", "quartz", "steel"]), default=None,
    help="Grain material preset: sets --poisson to the material's (glass 0.23, eta = 0.870; quartz "
         "0.08; steel 0.29) and records the material (E, nu, rho) in the packing, so that SI "
         "conversions (analyze front --units si) describe the grains that ran (docs/units.md).")


def with_material(options: dict, material: str | None) -> dict:
    """``options`` with the poisson of ``material`` (unchanged without one); an explicit
    --poisson that differs from the material's is refused (one line)."""
    if material is None:
        return options
    from ..units import MATERIALS

    nu = MATERIALS[material]["nu"]
    given = click.get_current_context().get_parameter_source("poisson").name != "DEFAULT"
    if given and abs(float(options["poisson"]) - nu) > 1e-12:
        raise InputError(f"--poisson {options['poisson']:g} and --material {material} (nu = {nu:g}): "
                         "give one of them")
    return {**options, "poisson": nu}


def record_material(packing, material: str | None):
    """Record ``material`` (name, E, nu, rho; JSON) in the packing's attributes; later stages
    carry it (granwave.provenance.SAMPLE_ATTRS). Nothing without one: outputs stay as before."""
    if material is not None:
        import json

        from ..units import material_record

        packing.attrs["material"] = json.dumps(material_record(material), sort_keys=True)
    return packing


def parse_seeds(spec: str) -> list[int]:
    """The seeds of ``spec``: comma-separated seeds and inclusive ranges ``a-b`` ("0-9", "1,4-6")."""
    return [s for a, b in seed_ranges(spec) for s in range(a, b + 1)]


def seed_ranges(spec: str) -> list[tuple[int, int]]:
    """The inclusive ranges (a, b) of a ``--seeds`` spec, checked (no seed twice) without listing
    the seeds: a range of 10^8 seeds is counted, not built."""
    ranges = []
    for part in spec.split(","):
        lo, sep, hi = part.strip().partition("-")
        try:
            a = int(lo)
            b = int(hi) if sep else a
        except ValueError:
            raise InputError(f"--seeds {spec!r}: expected seeds and ranges such as 0-9 or 0,2,5-7") from None
        if a < 0 or b < a:
            raise InputError(f"--seeds {spec!r}: a range a-b needs 0 <= a <= b (got {part.strip()!r})")
        ranges.append((a, b))
    ordered = sorted(ranges)
    if any(c <= b for (_, b), (c, _) in zip(ordered, ordered[1:])):
        raise InputError(f"--seeds {spec!r}: a seed is listed twice")
    return ranges


def check_seed_count(spec: str, params) -> None:
    """Refuse (before any seed is listed or any name checked) a ``--seeds`` spec whose
    preparations are predicted to take longer than the run-time limit (``--allow-long-run``
    lifts it): at least PREPARE_MIN_STEPS steps each (granwave.resources.prepare_seconds)."""
    from ..resources import PREPARE_MIN_STEPS, check_run_time, prepare_seconds

    count = sum(b - a + 1 for a, b in seed_ranges(spec))
    check_run_time(count * prepare_seconds(params.grains),
                   f"--seeds {spec}: {count} preparations of {params.grains} grains (each at least "
                   f"{PREPARE_MIN_STEPS} steps)")


@click.command("prepare-packing")
@options_from(PrepareParams)
@output_option
@threads_option
@device_option
@checkpoint_option
@checkpoint_every_option
@seeds_option
@material_option
@quiet_option
@long_run_option
@stage
def prepare_packing(output, threads, device, checkpoint, checkpoint_every, seeds, material, quiet, **options):
    """Prepare a packing in mechanical equilibrium by piston compression of a granular gas.

    The contact sub-models of --contact-law, --damping-law, --tangential and --rolling
    (Hertz-Mindlin with Coulomb friction and damping by default); converged when every acceleration (grains, rotations, piston) is below --tol
    and every speed below the impact speed of --tol (see docs/dem.md). Writes a granwave.packing file with
    the force-carrying contacts (j = -1 bottom wall, -2 piston) and the protocol in
    its attributes.
    """
    from .. import api
    from ..io.files import check_writable, write_packing

    from .common import given

    params = params_from(PrepareParams, with_material(options, material))
    if given("checkpoint_every") and checkpoint is None:
        raise InputError("--checkpoint-every without --checkpoint: no checkpoint would be written "
                         "(give --checkpoint FILE)")
    if seeds is not None:
        check_seed_count(seeds, params)
        _prepare_seeds(params, parse_seeds(seeds), output, threads, device, checkpoint, checkpoint_every, quiet,
                       material)
        return
    check_writable(output)
    if checkpoint is not None:
        _not_an_output(checkpoint, [output])
    packing = api.prepare_packing(params, progress=progress_printer(not quiet), threads=threads,
                                  device=device, checkpoint=checkpoint, checkpoint_every=checkpoint_every,
                                  keep_checkpoint=True)
    write_packing(output, record_material(packing, material))
    if checkpoint is not None:
        _remove_when_written(checkpoint, params)
    if not quiet:
        a = packing.attrs
        click.echo(f"wrote {output}: {packing.n_grains} grains, {len(packing.contacts)} contacts, "
                   f"height {packing.height:.4f}, steps {a['steps']}, residual {a['max_acceleration']:.3g}",
                   err=True)


def _not_an_output(checkpoint, outputs) -> None:
    """Refuse a checkpoint that is one of the outputs (one line)."""
    from ..io.files import same_file_as

    if (any(os.path.abspath(checkpoint) == os.path.abspath(out) for out in outputs)
            or same_file_as(checkpoint, outputs)):
        raise InputError(f"--checkpoint {checkpoint} is the output file; choose another name")


def _remove_when_written(checkpoint, params) -> None:
    """Delete the checkpoint once the command's outputs are all in place (never when one of them
    could not be written: a second run goes on from it)."""
    from ..dem.checkpoint import Checkpoint
    from ..io.atomic import after_outputs

    after_outputs(Checkpoint(checkpoint, params).remove)


def _prepare_seeds(params, seeds, pattern, threads, device, checkpoint, checkpoint_every, quiet,
                   material=None) -> None:
    """``--seeds``: every output name checked before any work, then one file per seed; with
    ``--checkpoint`` a pattern with {seed}, each seed's checkpoint removed only once every file
    is written (a seed that fails writes no file and leaves every checkpoint)."""
    import dataclasses

    from .. import api
    from ..io.files import check_writable, write_packing

    if click.get_current_context().get_parameter_source("seed").name != "DEFAULT":
        raise InputError("--seed and --seeds: give one of them")
    if "{seed}" not in pattern:
        raise InputError(f"--seeds: the output {pattern!r} must contain {{seed}} (one file per seed)")
    if checkpoint is not None and "{seed}" not in checkpoint:
        raise InputError(f"--seeds: the checkpoint {checkpoint!r} must contain {{seed}} (one checkpoint per seed)")
    outputs = [pattern.replace("{seed}", str(s)) for s in seeds]
    for out in outputs:
        check_writable(out)
    checkpoints = [] if checkpoint is None else [checkpoint.replace("{seed}", str(s)) for s in seeds]
    for path in checkpoints:
        _not_an_output(path, outputs)
    packings = api.prepare_packings(params, seeds=seeds, progress=progress_printer(not quiet), threads=threads,
                                    device=device, checkpoint=checkpoint, checkpoint_every=checkpoint_every,
                                    keep_checkpoint=True)
    for k, (out, packing) in enumerate(zip(outputs, packings)):
        write_packing(out, record_material(packing, material))
        if checkpoints:
            _remove_when_written(checkpoints[k], dataclasses.replace(params, seed=seeds[k]))
        if not quiet:
            a = packing.attrs
            click.echo(f"wrote {out}: seed {a['seed']}, {packing.n_grains} grains, {len(packing.contacts)} "
                       f"contacts, height {packing.height:.4f}, steps {a['steps']}, residual "
                       f"{a['max_acceleration']:.3g}", err=True)
